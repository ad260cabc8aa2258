#!/usr/bin/env bash
# The ratio table of deformlab against its anchors (libigl, scipy, trimesh;
# issue 19, goal 6) in one command. Not part of CI or of scripts/test.sh.
#
#   scripts/bench_anchors.sh [OPTIONS]     # options go to scripts/bench_anchors.py
#   scripts/bench_anchors.sh --quick       # smallest size only, a few minutes
#   scripts/bench_anchors.sh --rows bbw,eig --out results/bench/anchors.md
#   DEFORMLAB_BENCH_VENV=DIR scripts/bench_anchors.sh   # another venv
#
# 1. makes (or refreshes) a virtual environment, by default
#    ~/.cache/deformlab/bench-venv, with numpy, scipy, libigl and trimesh
#    from the package index (and maturin to build the binding); an anchor
#    that does not install is reported as SKIP by the benchmark;
# 2. builds the CLI (cargo build --release) and the Python binding of this
#    checkout (maturin build --release, into the same target folder: it
#    reuses the library the CLI build compiled, and the script fails if the
#    library or faer is compiled a second time) and installs the wheel there;
# 3. runs scripts/bench_anchors.py with the venv's Python from the
#    repository root (deformlab bench fbt finds ../shared/data from there).
#
# Needs a Rust toolchain, python3 with venv and pip, network access to PyPI.
# Real meshes come from DEFORMLAB_DATA, else ../shared/data; rows whose data
# are missing print SKIP. CARGO_BUILD_JOBS is honoured (set it to 1 on a
# shared machine).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}"

venv="${DEFORMLAB_BENCH_VENV:-${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/deformlab/bench-venv}"
echo "== venv: $venv"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
py="$venv/bin/python"
"$py" -m pip install --quiet --upgrade pip
"$py" -m pip install --quiet "maturin>=1.5,<2" numpy scipy
for anchor in libigl trimesh; do
  if ! "$py" -m pip install --quiet "$anchor"; then
    echo "note: $anchor did not install; its rows will print SKIP"
  fi
done

echo "== build: CLI and Python binding (release)"
cargo build --locked --release
wheels="$CARGO_TARGET_DIR/wheels"
rm -f "$wheels"/deformlab-*.whl
build_log=$(mktemp)
PYO3_PYTHON="$py" "$venv/bin/maturin" build --release --locked \
  -m python/Cargo.toml --interpreter "$py" --out "$wheels" 2>&1 | tee "$build_log"
# The binding links the library the line above compiled (the root
# Cargo.toml asks for the binding's feature sets; as in scripts/test.sh).
# A second compilation costs minutes on a shared machine: refuse it.
if grep -qE "Compiling (deformlab|faer) v" "$build_log"; then
  echo "error: the binding compiled the library a second time (the feature sets of the root and python/ differ; compare 'cargo tree -e features' of the two)" >&2
  rm -f "$build_log"
  exit 1
fi
rm -f "$build_log"
"$py" -m pip install --quiet --force-reinstall --no-deps "$wheels"/deformlab-*.whl

echo "== benchmark"
DEFORMLAB_CLI="${DEFORMLAB_CLI:-$CARGO_TARGET_DIR/release/deformlab}" \
  exec "$py" "$root/scripts/bench_anchors.py" "$@"
