#!/usr/bin/env bash
# End-to-end test of the Slurm recipe in docs/sweeps.md, on this machine.
#
#   sudo scripts/slurm_sweep_test.sh        # Debian/Ubuntu, as root
#
# 1. installs slurm-wlm and munge with apt-get if they are missing (no
#    service is started by the packages: a policy-rc.d forbids it);
# 2. builds `pneumo` (cargo build --release -p pneumo-cli) unless $PNEUMO
#    names a binary;
# 3. starts a private single-node cluster under a temporary directory: its
#    own munge key and socket, slurmctld and slurmd in the foreground (no
#    systemd), one node named after this machine with CPUs = nproc, on ports
#    $SLURM_TEST_PORTS (default 16817 16818);
# 4. submits scripts/slurm/sweep_shard.sbatch as an array of $SHARDS (4)
#    tasks over a 12-case study, and scripts/slurm/merge.sbatch with
#    --dependency=afterok on the array; waits for both;
# 5. runs the same sweep locally and compares the merged file with it byte
#    for byte;
# 6. stops the daemons it started and removes the directory (KEEP=1 keeps it).
#
# Exit status 0 only if every job completed and the files are identical.
set -euo pipefail

REPO=$(cd "$(dirname "$0")/.." && pwd)
SHARDS=${SHARDS:-4}
read -r CTLD_PORT SLURMD_PORT <<<"${SLURM_TEST_PORTS:-16817 16818}"
TIMEOUT=${TIMEOUT:-600}
STUDY=(--vary "flow_control.C=1.41 L/min/bar,2.68 L/min/bar,13.2 L/min/bar,210 L/min/bar"
       --vary "supply.p=4 bar,5.5 bar,7 bar" --cycles 2)

say() { echo "slurm_sweep_test: $*" >&2; }
die() { say "FAILED: $*"; exit 1; }

[ "$(id -u)" -eq 0 ] || die "run as root (it installs packages and starts daemons)"
command -v apt-get >/dev/null || die "needs a Debian-like system (apt-get)"

# -- 1. packages --------------------------------------------------------------
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null || ! command -v sbatch >/dev/null; then
    say "installing slurm-wlm and munge"
    policy=/usr/sbin/policy-rc.d
    made_policy=0
    if [ ! -e "$policy" ]; then
        printf '#!/bin/sh\nexit 101\n' >"$policy"
        chmod 755 "$policy"
        made_policy=1
    fi
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
    if [ "$made_policy" = 1 ]; then rm -f "$policy"; fi
fi
id munge >/dev/null 2>&1 || die "the munge package did not create the munge user"

# -- 2. pneumo ------------------------------------------------------------------
if [ -z "${PNEUMO:-}" ]; then
    say "building pneumo (release)"
    (cd "$REPO" && cargo build --release --locked -p pneumo-cli)
    PNEUMO="${CARGO_TARGET_DIR:-$REPO/target}/release/pneumo"
fi
PNEUMO=$(realpath "$PNEUMO")
[ -x "$PNEUMO" ] || die "no pneumo binary at $PNEUMO"
export PNEUMO

# -- 3. a private cluster ---------------------------------------------------------
WORK=$(mktemp -d /tmp/pneumo-slurm.XXXXXX)
chmod 755 "$WORK"
PIDS=()
cleanup() {
    local status=$?
    for pid in "${PIDS[@]}"; do
        kill "$pid" 2>/dev/null || true
    done
    for pid in "${PIDS[@]}"; do
        wait "$pid" 2>/dev/null || true
    done
    if [ "${KEEP:-0}" = 1 ] || [ "$status" -ne 0 ]; then
        say "files kept in $WORK"
    else
        rm -rf "$WORK"
    fi
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

HOST=$(hostname -s)
CPUS=$(nproc)
install -d -o munge -g munge -m 0755 "$WORK/munge"
head -c 1024 /dev/urandom >"$WORK/munge/munge.key"
chown munge:munge "$WORK/munge/munge.key"
chmod 0400 "$WORK/munge/munge.key"
SOCKET="$WORK/munge/munge.sock"
setpriv --reuid=munge --regid=munge --init-groups -- \
    munged --foreground --socket="$SOCKET" --key-file="$WORK/munge/munge.key" \
    --pid-file="$WORK/munge/munged.pid" --log-file="$WORK/munge/munged.log" --seed-file="$WORK/munge/munged.seed" \
    >"$WORK/munge/stdout.log" 2>&1 &
PIDS+=($!)
for _ in $(seq 50); do [ -S "$SOCKET" ] && break; sleep 0.1; done
[ -S "$SOCKET" ] || die "munged did not start: $(cat "$WORK/munge/"*.log 2>/dev/null)"

mkdir -p "$WORK/state" "$WORK/spool" "$WORK/logs" "$WORK/out"
export SLURM_CONF="$WORK/slurm.conf"
cat >"$SLURM_CONF" <<CONF
ClusterName=pneumo-test
SlurmctldHost=$HOST(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
AuthType=auth/munge
AuthInfo=socket=$SOCKET
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$WORK/state
SlurmdSpoolDir=$WORK/spool
SlurmctldPidFile=$WORK/slurmctld.pid
SlurmdPidFile=$WORK/slurmd.pid
SlurmctldLogFile=$WORK/slurmctld.log
SlurmdLogFile=$WORK/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MailProg=/bin/true
NodeName=$HOST NodeAddr=127.0.0.1 CPUs=$CPUS State=UNKNOWN
PartitionName=test Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
CONF

slurmctld -D -i -f "$SLURM_CONF" >"$WORK/slurmctld.stdout" 2>&1 &
PIDS+=($!)
slurmd -D -N "$HOST" -f "$SLURM_CONF" >"$WORK/slurmd.stdout" 2>&1 &
PIDS+=($!)

deadline=$((SECONDS + 60))
until [ "$(sinfo -h -n "$HOST" -o %t 2>/dev/null)" = "idle" ]; do
    [ $SECONDS -lt $deadline ] || die "node $HOST did not become idle: $(sinfo 2>&1 | tail -2); see $WORK/*.log"
    sleep 0.5
done
say "cluster up: node $HOST, $CPUS CPUs, slurm $(sinfo -V | awk '{print $2}')"

# -- 4. the array and the merge ------------------------------------------------
cd "$REPO"
started=$SECONDS
array=$(sbatch --parsable --array="1-$SHARDS" --chdir="$REPO" --output="$WORK/logs/shard_%a.log" \
    scripts/slurm/sweep_shard.sbatch "$SHARDS" "$WORK/out" models/meter_out.json "${STUDY[@]}")
merge=$(sbatch --parsable --dependency="afterok:$array" --chdir="$REPO" --output="$WORK/logs/merge.log" \
    scripts/slurm/merge.sbatch "$SHARDS" "$WORK/out" "$WORK/out/merged.csv")
say "submitted array job $array ($SHARDS tasks) and merge job $merge (afterok:$array)"

state_of() { scontrol show job -o "$1" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | cut -d= -f2 | sort | uniq | tr '\n' ' '; }
deadline=$((SECONDS + TIMEOUT))
while :; do
    s=$(state_of "$merge")
    case "$s" in
        "COMPLETED ") break ;;
        *FAILED* | *CANCELLED* | *TIMEOUT* | *NODE_FAIL* | *OUT_OF_MEMORY*) die "merge job $merge ended $s; array: $(state_of "$array"); logs in $WORK/logs" ;;
    esac
    [ $SECONDS -lt $deadline ] || die "jobs did not finish within $TIMEOUT s (array: $(state_of "$array"), merge: $s)"
    sleep 1
done
[ "$(state_of "$array")" = "COMPLETED " ] || die "array tasks: $(state_of "$array")"
say "array and merge completed in $((SECONDS - started)) s"

# -- 5. the same sweep locally -------------------------------------------------
"$PNEUMO" sweep models/meter_out.json "${STUDY[@]}" --jobs "$CPUS" --out "$WORK/out/local.csv" >"$WORK/logs/local.log"
for k in $(seq 1 "$SHARDS"); do
    [ -s "$WORK/out/shard_$k.csv" ] || die "shard $k wrote nothing"
done
if ! cmp "$WORK/out/merged.csv" "$WORK/out/local.csv"; then
    diff <(cut -c1-200 "$WORK/out/merged.csv") <(cut -c1-200 "$WORK/out/local.csv") | head -20 >&2 || true
    die "the merged shards differ from the local sweep"
fi
cases=$(($(wc -l <"$WORK/out/local.csv") - 1))
say "PASSED: $SHARDS shards via Slurm, merged, are byte-identical to the local sweep ($cases cases, $(wc -c <"$WORK/out/local.csv") bytes)"
