#!/usr/bin/env bash
# Runs every cargo-fuzz target in fuzz/ for SECONDS each (default 600), one
# after the other (FUZZ_JOBS=N: N at a time), at low priority, and prints
# executions, time and crashes per target. Crash inputs land in fuzz/artifacts/<target>/.
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

# One target: runs it, then writes its table row to $LOG_DIR/fuzz_<t>.row.
run_target() {
    local t="$1"
    local log="$LOG_DIR/fuzz_$t.log"
    mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t"
    local before after start end rc execs
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
    printf '%-12s %14s %9s %8s %4s\n' "$t" "${execs:-?}" "$((end - start))" "$((after - before))" "$rc" \
        >"$LOG_DIR/fuzz_$t.row"
}

# FUZZ_JOBS targets at a time (default 1: one after the other).
JOBS="${FUZZ_JOBS:-1}"
running=0
for t in "${TARGETS[@]}"; do
    run_target "$t" &
    running=$((running + 1))
    if [ "$running" -ge "$JOBS" ]; then
        wait -n || true
        running=$((running - 1))
    fi
done
wait

printf '%-12s %14s %9s %8s\n' target executions seconds crashes
status=0
for t in "${TARGETS[@]}"; do
    read -r name execs secs crashes rc <"$LOG_DIR/fuzz_$t.row"
    printf '%-12s %14s %9s %8s\n' "$name" "$execs" "$secs" "$crashes"
    if [ "$rc" -ne 0 ]; then
        status=1
        echo "  $t exited with $rc; see $LOG_DIR/fuzz_$t.log and fuzz/artifacts/$t/" >&2
    fi
done
exit "$status"
