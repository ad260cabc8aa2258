#!/usr/bin/env bash
# The test suite of deformlab: the Rust tests, then the Python binding built
# into a virtual environment and its pytest tests.
#
#   scripts/test.sh            # both (the README's test command, what CI runs)
#   scripts/test.sh rust       # only the Rust tests
#   scripts/test.sh python     # only the Python part (build, install, pytest)
#   DEFORMLAB_VENV=DIR scripts/test.sh   # another venv (default below)
#
# Needs a Rust toolchain, python3 (with venv and pip) and network access to
# PyPI for the Python packages (maturin, numpy, scipy, pandas, pytest;
# libigl when it installs, else its cross-check is skipped). The report's
# browser test uses Chromium (/usr/bin/chromium or DEFORMLAB_CHROMIUM) and
# skips without it, except under CI, whose .ci/run installs it. The binding is
# compiled into the same target/ folder, profile and feature sets as the
# Rust tests, so the library they compiled is reused (the script fails if it
# is compiled a second time). Real meshes (DEFORMLAB_DATA, else
# ../shared/data) are used when present; tests that need them skip, saying
# why, when absent.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}"

part="${1:-all}"
case "$part" in
  all | rust | python) ;;
  *) echo "usage: scripts/test.sh [rust|python]" >&2; exit 2 ;;
esac

if [ "$part" != python ]; then
  # `--profile release`, not `--release` (which is Cargo's `bench` profile:
  # the same settings under another name, part of each artifact's key): the
  # binding below is built in the release profile and then links the
  # library compiled here instead of compiling it again.
  echo "== Rust: cargo test --profile release"
  cargo test --locked --profile release
else
  # The CLI binary the equality tests compare with (built by the line above
  # in a full run).
  cargo build --locked --release
fi
[ "$part" = rust ] && exit 0

echo "== Python: build the binding (maturin) into a venv"
venv="${DEFORMLAB_VENV:-${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/deformlab/venv}"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
py="$venv/bin/python"
"$py" -m pip install --quiet --upgrade pip
"$py" -m pip install --quiet "maturin>=1.5,<2" numpy scipy pandas pytest
if ! "$py" -m pip install --quiet libigl; then
  echo "note: libigl did not install; its cross-check will be skipped"
fi
wheels="$CARGO_TARGET_DIR/wheels"
rm -f "$wheels"/deformlab-*.whl
build_log=$(mktemp)
PYO3_PYTHON="$py" "$venv/bin/maturin" build --release --locked \
  -m python/Cargo.toml --interpreter "$py" --out "$wheels" 2>&1 | tee "$build_log"
# python/ is a member of the root workspace, and the root Cargo.toml asks for
# the binding's feature sets of the crates they share, so the binding reuses
# what the tests compiled. Hold that: a second compilation of the library
# costs minutes.
if grep -qE "Compiling (deformlab|faer) v" "$build_log"; then
  echo "error: the binding compiled the library a second time (is python/ still a member of the root workspace, and do the feature sets of the root and python/ agree? compare 'cargo tree -e features' of the two)" >&2
  rm -f "$build_log"
  exit 1
fi
rm -f "$build_log"
"$py" -m pip install --quiet --force-reinstall --no-deps "$wheels"/deformlab-*.whl
# Run from outside the checkout: the installed wheel is what is tested, not
# the source folder.
"$py" -c "import deformlab, sys; print('deformlab', deformlab.__version__, 'from', deformlab.__file__)"

echo "== Python: pytest"
DEFORMLAB_CLI="${DEFORMLAB_CLI:-$CARGO_TARGET_DIR/release/deformlab}" \
  "$py" -m pytest "$root/python/tests" -ra -p no:cacheprovider
