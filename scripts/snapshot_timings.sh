#!/bin/sh
# Copies the volatile timing files of a results root (default: results/)
# into docs/timings/<experiment>/ -- summary.csv (the seconds_* metrics)
# and runs.json (every invocation: start, wall time, threads, revision).
#
# A run writes its timings under results/<experiment>/timings/, which git
# ignores: they differ from run to run, and the main job must leave a clean
# checkout clean. The docs quote measured times from this snapshot instead
# (tests/readme.rs holds them to it); take it deliberately, after a
# measurement worth quoting, and commit it with the docs that quote it.
set -eu
root="${1:-results}"
cd "$(dirname "$0")/.."
found=0
for d in "$root"/*/timings; do
    [ -d "$d" ] || continue
    name=$(basename "$(dirname "$d")")
    mkdir -p "docs/timings/$name"
    for f in summary.csv runs.json; do
        [ -f "$d/$f" ] && cp "$d/$f" "docs/timings/$name/$f"
    done
    found=$((found + 1))
done
echo "snapshot of $found experiments' timings in docs/timings/"
