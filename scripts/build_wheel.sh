#!/usr/bin/env bash
# Builds the one Python wheel of deformlab for Linux x86_64 that every
# CPython >= 3.9 installs: abi3 (the binding uses the stable ABI, pyo3's
# abi3-py39) and manylinux2014 (glibc >= 2.17), linked by zig (from PyPI's
# ziglang) so that the machine's newer glibc does not raise the tag.
#
#   scripts/build_wheel.sh [OUT_DIR]     # default dist/
#
# Needs a Rust toolchain, python3 with venv and pip, and PyPI (maturin,
# ziglang). Installing the wheel needs neither Rust nor a compiler:
#   pip install dist/deformlab-*.whl            # with numpy and scipy
#   pip install --no-deps dist/deformlab-*.whl  # into an environment that has them
# The build has its own target folder (target/wheel): zig links differently
# from the test build, which it would otherwise invalidate.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-dist}"
venv="${DEFORMLAB_WHEEL_VENV:-${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/deformlab/wheel-venv}"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet "maturin>=1.5,<2" "ziglang>=0.11"
mkdir -p "$out"
rm -f "$out"/deformlab-*.whl
# maturin finds zig through `python -m ziglang` of the python on PATH.
PATH="$venv/bin:$PATH" CARGO_TARGET_DIR="$PWD/target/wheel" \
  "$venv/bin/maturin" build --release --locked --zig --compatibility manylinux2014 \
  -m python/Cargo.toml --out "$out"
wheel=$(ls "$out"/deformlab-*.whl)
case "$wheel" in
  *-cp39-abi3-*manylinux_2_17_x86_64*.whl) ;;
  *) echo "error: $wheel is not tagged cp39-abi3 manylinux2014" >&2; exit 1 ;;
esac
echo "$wheel"
