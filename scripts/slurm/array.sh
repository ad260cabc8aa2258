#!/usr/bin/env bash
# Run an experiment suite as a Slurm job array: one array task per shard
# (`deformlab run --shard i/N`), then one dependent job that merges the
# shards of every experiment (`deformlab merge`) into RESULTS/<name>/.
#
# Usage (from the repository root, on the cluster's login node):
#   scripts/slurm/array.sh N CONFIG... [-- EXTRA SBATCH OPTIONS]
# e.g.
#   scripts/slurm/array.sh 8 experiments/*.toml -- --partition=short --time=02:00:00
#
# Environment:
#   DEFORMLAB   the binary (default: target/release/deformlab, built if missing)
#   RESULTS     merged results root (default: results)
#   SHARDS      per-shard results root (default: $RESULTS/shards)
#   THREADS     threads per task (default: $SLURM_CPUS_PER_TASK, else 2)
#   CPUS        --cpus-per-task of the array tasks (default: 2)
#   DRY_RUN=1   print the sbatch commands instead of submitting them
#
# Inside the array, task $SLURM_ARRAY_TASK_ID runs
#   deformlab run CONFIG... --shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT \
#       --out $SHARDS/$SLURM_ARRAY_TASK_ID
# (resumable: a requeued or re-submitted task continues where it stopped);
# the merge job runs after all tasks succeeded (afterok) and calls, per config,
#   deformlab merge $SHARDS/0/<name> ... $SHARDS/N-1/<name> --out $RESULTS/<name>
set -euo pipefail

if [[ "${1:-}" == "--task" ]]; then
    # Array task: --task N CONFIG...
    shift
    n="$1"; shift
    i="${SLURM_ARRAY_TASK_ID:?not running inside a Slurm array task}"
    count="${SLURM_ARRAY_TASK_COUNT:-$n}"
    if [[ "$count" != "$n" ]]; then
        echo "error: array has $count tasks but $n shards were requested" >&2
        exit 2
    fi
    threads="${THREADS:-${SLURM_CPUS_PER_TASK:-2}}"
    exec "$DEFORMLAB" run "$@" --shard "$i/$count" --out "$SHARDS/$i" --threads "$threads" --no-plots
fi

if [[ "${1:-}" == "--merge" ]]; then
    # Merge job: --merge N CONFIG...
    shift
    n="$1"; shift
    status=0
    for cfg in "$@"; do
        name="$(sed -n 's/^name[[:space:]]*=[[:space:]]*"\([^"]*\)".*/\1/p' "$cfg" | head -n 1)"
        if [[ -z "$name" ]]; then
            echo "error: $cfg: no top-level name = \"...\" line" >&2
            status=1
            continue
        fi
        dirs=()
        for ((i = 0; i < n; i++)); do
            if [[ -d "$SHARDS/$i/$name" ]]; then
                dirs+=("$SHARDS/$i/$name")
            else
                echo "error: shard $i of $name is missing ($SHARDS/$i/$name)" >&2
                status=1
            fi
        done
        if ((${#dirs[@]} > 0)); then
            "$DEFORMLAB" merge "${dirs[@]}" --out "$RESULTS/$name" || status=1
        fi
    done
    exit "$status"
fi

if (($# < 2)) || ! [[ "$1" =~ ^[1-9][0-9]*$ ]]; then
    sed -n '2,13p' "$0" >&2
    exit 2
fi
n="$1"; shift
configs=()
while (($# > 0)) && [[ "$1" != "--" ]]; do
    [[ -f "$1" ]] || { echo "error: config $1 not found" >&2; exit 2; }
    configs+=("$(realpath "$1")")
    shift
done
[[ "${1:-}" == "--" ]] && shift
extra=("$@")
((${#configs[@]} > 0)) || { echo "error: no config given" >&2; exit 2; }

export DEFORMLAB="$(realpath "${DEFORMLAB:-target/release/deformlab}" 2>/dev/null || true)"
if [[ ! -x "$DEFORMLAB" ]]; then
    cargo build --release
    export DEFORMLAB="$(realpath target/release/deformlab)"
fi
export RESULTS="$(realpath -m "${RESULTS:-results}")"
export SHARDS="$(realpath -m "${SHARDS:-$RESULTS/shards}")"
mkdir -p "$SHARDS" "$RESULTS"
self="$(realpath "$0")"
cpus="${CPUS:-2}"

submit() {
    if [[ "${DRY_RUN:-0}" == 1 ]]; then
        echo "sbatch $*" >&2
        echo "DRYRUN$RANDOM"
    else
        sbatch --parsable "$@"
    fi
}

array_id="$(submit --job-name=deformlab-shards --array="0-$((n - 1))" \
    --cpus-per-task="$cpus" --export=ALL --output="$SHARDS/slurm-%A_%a.out" \
    "${extra[@]}" "$self" --task "$n" "${configs[@]}")"
merge_id="$(submit --job-name=deformlab-merge --dependency="afterok:${array_id%%;*}" \
    --cpus-per-task=1 --export=ALL --output="$SHARDS/slurm-merge-%j.out" \
    "${extra[@]}" "$self" --merge "$n" "${configs[@]}")"
echo "submitted array job $array_id ($n shards) and merge job $merge_id; results → $RESULTS/<name>/"
