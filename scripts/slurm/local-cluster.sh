#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for trying the batch scripts end to end (not part of the test command).
#
#   scripts/slurm/local-cluster.sh start    start munged, slurmctld and slurmd for localhost (state in $PRISMATIC_SLURM_DIR)
#   scripts/slurm/local-cluster.sh stop     stop them (the state directory is kept for its logs)
#   scripts/slurm/local-cluster.sh status   sinfo and squeue of the cluster
#   scripts/slurm/local-cluster.sh env      the export line that points Slurm's commands at the cluster
#   scripts/slurm/local-cluster.sh test [SCENE [SPP [TASKS...]]]
#                                           start the cluster, render SCENE (default scenes/cornell-glass.pbrt at
#                                           256 spp) as a job array of 1, 2 and 4 tasks (default) with a dependent
#                                           merge job, check each merged image against a single-process render and
#                                           print the wall-clock times; then stop the cluster
#
# Needs Debian's slurm-wlm and munge (`apt-get install slurm-wlm munge`, as root: the daemons run as the user who
# starts them, and slurmd must be able to start jobs). Everything the cluster writes (configuration, munge key and
# socket, daemon state, logs, spool) lies in one directory, default /tmp/prismatic-slurm; nothing under /etc is
# touched and no system munged is needed. The node is `localhost` with this machine's CPUs and memory; jobs are
# tracked without cgroups (proctrack/linuxproc), so it also runs in a container.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$PWD
dir=${PRISMATIC_SLURM_DIR:-/tmp/prismatic-slurm}
conf=$dir/slurm.conf

usage() {
    sed -n '3,14p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
}

need() {
    for c in munged mungekey slurmctld slurmd sbatch squeue sinfo scontrol; do
        command -v "$c" >/dev/null || { echo "missing '$c': install Debian's slurm-wlm and munge" >&2; exit 1; }
    done
}

write_config() {
    local cpus mem_mb
    cpus=$(nproc)
    mem_mb=$(awk '/^MemTotal:/ { printf "%d", $2 / 1024 * 0.9 }' /proc/meminfo)
    mkdir -p "$dir"/{state,spool,log,munge}
    chmod 700 "$dir/munge"
    cat >"$conf" <<CONF
# Written by scripts/slurm/local-cluster.sh: a one-node cluster on localhost.
ClusterName=prismatic
SlurmctldHost=localhost
SlurmctldPort=${PRISMATIC_SLURM_PORT:-6917}
SlurmdPort=$((${PRISMATIC_SLURM_PORT:-6917} + 1))
SlurmUser=$(id -un)
SlurmdUser=$(id -un)
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
# A test cluster: look at pending jobs every 2 s (defaults 60 s and 30 s), so that the next array tasks start as
# soon as CPUs free up and the timings measure rendering, not the scheduler's period.
SchedulerParameters=sched_interval=2,bf_interval=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
ReturnToService=2
SlurmdTimeout=60
InactiveLimit=0
MinJobAge=300
KillWait=5
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
}

running() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

start() {
    need
    write_config
    if ! running "$dir/munge/munged.pid"; then
        [ -f "$dir/munge/munge.key" ] || mungekey --create --keyfile="$dir/munge/munge.key" --force
        chmod 400 "$dir/munge/munge.key"
        munged --force --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
            --pid-file="$dir/munge/munged.pid" --log-file="$dir/log/munged.log" --seed-file="$dir/munge/munged.seed"
    fi
    export SLURM_CONF=$conf
    running "$dir/slurmctld.pid" || slurmctld -f "$conf"
    running "$dir/slurmd.pid" || slurmd -f "$conf" -N localhost
    # Wait for the node to register and become idle.
    for _ in $(seq 60); do
        state=$(sinfo -h -N -o '%T' 2>/dev/null | head -1 || true)
        case "$state" in idle | mixed | allocated) echo "cluster up: node localhost $state, SLURM_CONF=$conf"; return 0 ;; esac
        sleep 1
    done
    echo "the node did not come up (state '${state:-none}'); logs in $dir/log" >&2
    tail -5 "$dir/log/slurmctld.log" "$dir/log/slurmd.log" >&2 || true
    exit 1
}

stop() {
    export SLURM_CONF=$conf
    [ -f "$conf" ] && scancel --quiet --user="$(id -un)" 2>/dev/null || true
    for pidfile in "$dir/slurmd.pid" "$dir/slurmctld.pid" "$dir/munge/munged.pid"; do
        if running "$pidfile"; then
            pid=$(cat "$pidfile")
            kill "$pid"
            for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done
        fi
        rm -f "$pidfile"
    done
    echo "cluster stopped (logs in $dir/log)"
}

# Seconds since the epoch with a fraction.
now() { date +%s.%N; }

run_test() {
    local scene=${1:-scenes/cornell-glass.pbrt} spp=${2:-256}
    shift $(($# >= 2 ? 2 : $#))
    local tasks=("$@")
    [ ${#tasks[@]} -gt 0 ] || tasks=(1 2 4)
    cargo build --release -q -p prismatic
    local bin=$root/target/release/prismatic
    # Global: the EXIT trap runs after this function has returned.
    work=$(mktemp -d "${TMPDIR:-/tmp}/prismatic-slurm-test.XXXXXX")
    trap 'stop >/dev/null; rm -rf "$work"' EXIT
    start
    export SLURM_CONF=$conf
    echo "single-process reference: $scene, $spp spp"
    local s0 s1
    s0=$(now)
    "$bin" render "$scene" --spp "$spp" --quiet -o "$work/single.exr"
    s1=$(now)
    local single_secs
    single_secs=$(awk -v a="$s0" -v b="$s1" 'BEGIN { printf "%.1f", b - a }')
    local rows=()
    for n in "${tasks[@]}"; do
        local t0 t1
        t0=$(now)
        PRISMATIC=$bin scripts/slurm/submit.sh --tasks "$n" --cpus-per-task 1 --wait \
            --parts "$work/parts-$n" "$scene" "$work/merged-$n.exr" -- --spp "$spp"
        t1=$(now)
        local cmp max
        cmp=$("$bin" compare "$work/merged-$n.exr" "$work/single.exr")
        max=$(awk '$1 == "max_difference_over_pixel_max" { print $2 }' <<<"$cmp")
        # Equal to the single-process render within one f32 unit in the last place of each pixel's largest value.
        if ! awk -v m="$max" 'BEGIN { exit !(m <= 2 ^ -23) }'; then
            echo "FAIL: $n tasks: merged image differs from the single-process render" >&2
            echo "$cmp" >&2
            exit 1
        fi
        rows+=("$n $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }') $(awk '$1 == "identical_values" { print $2 "/" $4 }' <<<"$cmp") $max")
    done
    # Pre-emption: requeue task 1 of a 2-task array mid-render; it resumes from its checkpoint when it runs again.
    echo "requeue check: 2 tasks, task 1 requeued after 5 s"
    local job
    job=$(PRISMATIC=$bin scripts/slurm/submit.sh --tasks 2 --cpus-per-task 1 --parts "$work/parts-rq" "$scene" \
        "$work/merged-rq.exr" -- --spp "$spp" --checkpoint-every 0 | awk '/^array job/ { sub(":", "", $3); print $3 }')
    sleep 5
    scontrol requeue "${job}_1"
    sleep 1
    # Slurm holds a requeued job for two minutes; let it start again at once.
    scontrol update jobid="${job}_1" starttime=now
    while squeue -h -u "$(id -un)" | grep -q .; do sleep 1; done
    grep -q "interrupted by SIGTERM" "$work/parts-rq/shard-1.log" && grep -q resuming "$work/parts-rq/shard-1.log" ||
        { echo "FAIL: task 1 was not interrupted and resumed:" >&2; cat "$work/parts-rq/shard-1.log" >&2; exit 1; }
    local rq
    rq=$("$bin" compare "$work/merged-rq.exr" "$work/single.exr" | awk '$1 == "max_difference_over_pixel_max" { print $2 }')
    awk -v m="$rq" 'BEGIN { exit !(m <= 2 ^ -23) }' || { echo "FAIL: the requeued render differs ($rq)" >&2; exit 1; }
    echo "requeued task interrupted and resumed; merged image equals the single-process render ($rq)"

    echo
    echo "scene $scene, $spp spp, $(nproc) CPUs, one CPU per array task;" \
        "one process without Slurm, all CPUs: $single_secs s"
    echo "| array tasks | wall clock, submit to merged (s) | speed-up | values identical to one process | largest difference / pixel max |"
    echo "|---|---|---|---|---|"
    local base
    base=$(awk '{ print $2; exit }' <<<"${rows[0]}")
    for r in "${rows[@]}"; do
        read -r n secs same max <<<"$r"
        printf '| %s | %s | %.2f× | %s | %s |\n' "$n" "$secs" "$(awk -v a="$base" -v b="$secs" 'BEGIN { print a / b }')" "$same" "$max"
    done
}

[ $# -ge 1 ] || usage
case "$1" in
start) start ;;
stop) stop ;;
status) export SLURM_CONF=$conf; sinfo; squeue ;;
env) echo "export SLURM_CONF=$conf" ;;
test) shift; run_test "$@" ;;
*) usage ;;
esac
