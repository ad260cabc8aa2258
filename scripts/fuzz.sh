#!/usr/bin/env bash
# Runs every cargo-fuzz target in fuzz/ for SECONDS each (default 600), one
# after the other, at low priority, and prints executions, time and crashes
# per target. Crash inputs land in fuzz/artifacts/<target>/.
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]
#
# Needs cargo-fuzz (`cargo install cargo-fuzz`). On a stable toolchain
# RUSTC_BOOTSTRAP=1 lets cargo-fuzz use the nightly-only flags it needs;
# FUZZ_SANITIZER (default: address, falls back to none when the ASan build
# fails) picks the sanitizer. Logs: ${FUZZ_LOG_DIR:-/tmp}/fuzz_<target>.log.
set -euo pipefail

SECONDS_PER_TARGET="${1:-600}"
shift || true
cd "$(dirname "$0")/.."
ROOT="$PWD"
LOG_DIR="${FUZZ_LOG_DIR:-/tmp}"
export RUSTC_BOOTSTRAP=1

if ! command -v cargo-fuzz >/dev/null 2>&1; then
    echo "cargo-fuzz not found: cargo install cargo-fuzz" >&2
    exit 2
fi

if [ "$#" -gt 0 ]; then
    TARGETS=("$@")
else
    mapfile -t TARGETS < <(cd fuzz && cargo fuzz list)
fi

SANITIZER="${FUZZ_SANITIZER:-address}"
if ! nice -n 10 cargo fuzz build --fuzz-dir fuzz -s "$SANITIZER" >"$LOG_DIR/fuzz_build.log" 2>&1; then
    if [ "$SANITIZER" != none ]; then
        echo "build with sanitizer '$SANITIZER' failed; using --sanitizer none" >&2
        SANITIZER=none
    fi
fi

printf '%-12s %14s %9s %8s\n' target executions seconds crashes
status=0
for t in "${TARGETS[@]}"; do
    log="$LOG_DIR/fuzz_$t.log"
    mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t"
    before=$(find "fuzz/artifacts/$t" -type f | wc -l)
    start=$(date +%s)
    set +e
    nice -n 10 cargo fuzz run --fuzz-dir fuzz -s "$SANITIZER" "$t" "fuzz/corpus/$t" -- \
        -max_total_time="$SECONDS_PER_TARGET" -timeout=10 -rss_limit_mb=2048 \
        -max_len=8192 -print_final_stats=1 >"$log" 2>&1
    rc=$?
    set -e
    end=$(date +%s)
    after=$(find "fuzz/artifacts/$t" -type f | wc -l)
    execs=$(grep -ao 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1 || true)
    printf '%-12s %14s %9s %8s\n' "$t" "${execs:-?}" "$((end - start))" "$((after - before))"
    if [ "$rc" -ne 0 ]; then
        status=1
        echo "  $t exited with $rc; see $log and fuzz/artifacts/$t/" >&2
    fi
done
exit "$status"
