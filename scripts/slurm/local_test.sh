#!/usr/bin/env bash
# End-to-end check of the Slurm job-array path on this machine:
#
#   1. installs Debian's slurm-wlm (and munge) if missing,
#   2. writes a one-node cluster configuration (this host, all its CPUs) and
#      starts munged, slurmctld and slurmd on localhost,
#   3. submits the default experiment suite (experiments/*.toml, the
#      synthetic set) as a 4-task job array with a dependent merge job
#      (scripts/slurm/array.sh), waits for both,
#   4. runs the same suite unsharded and checks that every experiment's
#      cases.csv and summary.csv equal the merged ones, apart from the
#      timing columns (seconds_*), which no two runs share.
#
# Usage (as root, from the repository root; takes a few minutes):
#   scripts/slurm/local_test.sh [SHARDS] [CONFIG...]
# Defaults: 4 shards, experiments/*.toml. Work folder: $WORK (default
# /tmp/deformlab-slurm-test, wiped first). DEFORMLAB=PATH uses that binary
# instead of building target/release/deformlab. STOP=1 stops the daemons at the
# end (default: they keep running for inspection; rerunning reuses them).
set -euo pipefail

n="${1:-4}"
shift || true
if (($# > 0)); then configs=("$@"); else configs=(experiments/*.toml); fi
work="${WORK:-/tmp/deformlab-slurm-test}"
root="$(pwd)"
say() { printf '[slurm-test] %s\n' "$*" >&2; }

[[ -f Cargo.toml && -d experiments ]] || { echo "run from the repository root" >&2; exit 2; }
[[ "$(id -u)" == 0 ]] || { echo "needs root (installs packages, starts daemons)" >&2; exit 2; }

# 1. Packages.
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    say "installing slurm-wlm and munge (apt-get)"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq || true
    apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
fi

# 2. One-node cluster on localhost.
cpus="$(nproc)"
mem_mb="$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)"
mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm /run/munge
cat >/etc/slurm/slurm.conf <<CONF
# Written by deformlab scripts/slurm/local_test.sh: a one-node test cluster.
ClusterName=deformlab-local
SlurmctldHost=localhost
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
if [[ ! -s /etc/munge/munge.key ]]; then
    dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key status=none
fi
chown -R munge:munge /etc/munge /run/munge 2>/dev/null || true
chmod 0700 /etc/munge; chmod 0400 /etc/munge/munge.key
if ! pgrep -x munged >/dev/null; then
    say "starting munged"
    if id munge >/dev/null 2>&1; then
        mkdir -p /var/lib/munge /var/log/munge
        chown munge:munge /var/lib/munge /var/log/munge
        su -s /bin/sh munge -c /usr/sbin/munged || /usr/sbin/munged --force
    else
        /usr/sbin/munged --force
    fi
fi
munge -n | unmunge >/dev/null || { echo "munge does not work" >&2; exit 1; }
if ! pgrep -x slurmctld >/dev/null; then
    say "starting slurmctld"
    slurmctld -c      # -c: clean start (no state from an earlier test)
fi
if ! pgrep -x slurmd >/dev/null; then
    say "starting slurmd"
    slurmd -N localhost
fi
for _ in $(seq 60); do
    state="$(sinfo -h -n localhost -o %T 2>/dev/null || true)"
    [[ "$state" == idle* || "$state" == mixed* || "$state" == allocated* ]] && break
    scontrol update nodename=localhost state=resume >/dev/null 2>&1 || true
    sleep 1
done
say "$(sbatch --version); node state: $(sinfo -h -n localhost -o %T)"
[[ "$(sinfo -h -n localhost -o %T)" == idle* ]] || { echo "node not idle" >&2; sinfo >&2; exit 1; }

# 3. The job array and its merge job.
if [[ -n "${DEFORMLAB:-}" ]]; then
    bin="$(realpath "$DEFORMLAB")"      # a given binary (e.g. a copy, while target/ is rebuilt)
else
    cargo build --release >&2
    bin="$root/target/release/deformlab"
fi
rm -rf "$work"; mkdir -p "$work"
export DEFORMLAB="$bin" RESULTS="$work/merged" SHARDS="$work/shards" CPUS=1
out="$(scripts/slurm/array.sh "$n" "${configs[@]}")"
say "$out"
array_id="$(sed -n 's/^submitted array job \([0-9]*\).*/\1/p' <<<"$out")"
merge_id="$(sed -n 's/.*merge job \([0-9]*\).*/\1/p' <<<"$out")"
[[ -n "$array_id" && -n "$merge_id" ]] || { echo "could not parse job ids" >&2; exit 1; }
start=$SECONDS
while squeue -h -j "$array_id,$merge_id" 2>/dev/null | grep -q .; do
    sleep 5
    if ((SECONDS - start > 3600)); then echo "timeout waiting for Slurm" >&2; exit 1; fi
done
say "Slurm jobs finished after $((SECONDS - start)) s"
sacct_ok=1
for f in "$SHARDS"/slurm-*.out; do say "--- $(basename "$f"): $(tail -n 1 "$f")"; done
state="$(scontrol show job "$merge_id" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' || true)"
[[ -z "$state" || "$state" == COMPLETED ]] || { echo "merge job state: $state" >&2; sacct_ok=0; }

# 4. The unsharded run, and the comparison.
say "unsharded run"
"$bin" run "${configs[@]}" --out "$work/single" --no-plots >&2

# Drops the columns whose header starts with seconds_ (timings), and, in
# summary.csv, the rows describing them (column `metric` = seconds_*).
# Fields are split the CSV way (quoted fields may hold commas).
strip() {
    awk 'function split_csv(line, f,    n, i, c, q, cur) {
             n = 0; cur = ""; q = 0
             for (i = 1; i <= length(line); i++) {
                 c = substr(line, i, 1)
                 if (q) { cur = cur c; if (c == "\"") q = 0 }
                 else if (c == "\"") { cur = cur c; q = 1 }
                 else if (c == ",") { f[++n] = cur; cur = "" }
                 else cur = cur c
             }
             f[++n] = cur
             return n
         }
         { nf = split_csv($0, f) }
         NR == 1 { for (i = 1; i <= nf; i++) { drop[i] = (f[i] ~ /^seconds_/); if (f[i] == "metric") col = i } }
         { if (NR > 1 && col && f[col] ~ /^seconds_/) next
           line = ""; sep = ""
           for (i = 1; i <= nf; i++) if (!drop[i]) { line = line sep f[i]; sep = "," }
           print line }' "$1"
}
status=$sacct_ok
checked=0
for cfg in "${configs[@]}"; do
    name="$(sed -n 's/^name[[:space:]]*=[[:space:]]*"\([^"]*\)".*/\1/p' "$cfg" | head -n 1)"
    for f in cases.csv summary.csv; do
        a="$work/merged/$name/$f"; b="$work/single/$name/$f"
        if [[ ! -f "$a" || ! -f "$b" ]]; then
            echo "MISSING $name/$f" >&2; status=0; continue
        fi
        if diff <(strip "$a") <(strip "$b") >/dev/null; then
            checked=$((checked + 1))
        else
            echo "DIFFERENT $name/$f (merged vs unsharded)" >&2
            diff <(strip "$a") <(strip "$b") | head -n 5 >&2
            status=0
        fi
    done
    rows="$(($(wc -l <"$work/merged/$name/cases.csv") - 1))"
    say "$name: $rows case × method rows compared"
done
if [[ "${STOP:-0}" == 1 ]]; then
    scontrol shutdown >/dev/null 2>&1 || true
fi
if ((status == 1)); then
    say "PASS: $n-task array + merge over ${#configs[@]} configs equals the unsharded run ($checked files compared)"
else
    say "FAIL"
    exit 1
fi
