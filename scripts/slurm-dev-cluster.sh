#!/usr/bin/env bash
# A throwaway single-node Slurm on this machine, for trying `sweep launch --executor slurm` and for
# tests/slurm.rs. Everything (munge key and socket, slurm.conf, state, spool, logs, pid files) lives
# under one scratch directory; nothing is installed as a service and nothing outside it is written
# except the Debian packages it installs when they are missing (needs root).
#
#   scripts/slurm-dev-cluster.sh start [DIR]   # prints `export SLURM_CONF=DIR/etc/slurm.conf`
#   scripts/slurm-dev-cluster.sh stop  [DIR]   # cancels its jobs, stops slurmctld, slurmd, munged
#
# DIR defaults to $SLURM_DEV_DIR, else ${TMPDIR:-/tmp}/sweep-slurm. Every Slurm client command
# needs SLURM_CONF in its environment (without it they try a DNS SRV lookup and fail); sbatch
# passes it on to the jobs. The measured recipe is in shared/notes/slurm-single-node.md.
set -euo pipefail

cmd="${1:-}"
dir="${2:-${SLURM_DEV_DIR:-${TMPDIR:-/tmp}/sweep-slurm}}"
packages=(slurmctld slurmd slurm-client munge)

say() { echo "slurm-dev-cluster: $*" >&2; }
die() {
    say "error: $*"
    exit 1
}

install_packages() {
    local missing=()
    for p in "${packages[@]}"; do
        dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    [ "$(id -u)" -eq 0 ] || die "packages ${missing[*]} are missing and installing them needs root"
    command -v apt-get >/dev/null 2>&1 || die "packages ${missing[*]} are missing and there is no apt-get"
    say "installing ${missing[*]}"
    apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

# A TCP port nobody listens on, from a range away from Slurm's defaults (6817/6818), so that a
# second dev cluster or a real slurmd on this machine does not collide with this one.
free_port() {
    local p
    for _ in $(seq 200); do
        p=$((20000 + RANDOM % 20000))
        if ! (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null; then
            echo "$p"
            return 0
        fi
    done
    die "no free TCP port found"
}

pid_alive() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

start() {
    install_packages
    [ "$(id -u)" -eq 0 ] || die "the dev cluster runs its daemons as root (SlurmUser=root)"
    local host conf sock
    host="$(hostname -s)"
    mkdir -p "$dir"
    dir="$(cd "$dir" && pwd)"
    conf="$dir/etc/slurm.conf"
    if [ -f "$dir/run/slurmctld.pid" ] && pid_alive "$dir/run/slurmctld.pid"; then
        say "already running in $dir"
        echo "export SLURM_CONF=$conf"
        return 0
    fi
    mkdir -p "$dir"/{munge,etc,state,spool,log,run}
    # munged refuses a socket whose directories others may write to.
    chmod 755 "$dir" "$dir"/{munge,etc,state,spool,log,run}
    sock="$dir/munge/munge.socket"
    [ -f "$dir/munge/munge.key" ] || mungekey -c -f -k "$dir/munge/munge.key"
    chmod 600 "$dir/munge/munge.key"
    munged --key-file="$dir/munge/munge.key" --socket="$sock" --pid-file="$dir/run/munged.pid" \
        --log-file="$dir/log/munged.log" --seed-file="$dir/munge/munge.seed"
    munge -S "$sock" -n | unmunge -S "$sock" >/dev/null || die "munge does not work (see $dir/log/munged.log)"

    local mem ctld_port d_port
    mem="$(slurmd -C | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' | head -n1)"
    ctld_port="$(free_port)"
    d_port="$(free_port)"
    [ "$ctld_port" != "$d_port" ] || d_port=$((ctld_port + 1))
    cat >"$conf" <<EOF
# Written by scripts/slurm-dev-cluster.sh: a single-node cluster under $dir.
ClusterName=sweepdev
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$d_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$sock,cred_expire=10
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/pgid
TaskPlugin=task/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/backfill
SchedulerParameters=sched_interval=1
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$dir/log/jobcomp.txt
ReturnToService=2
JobRequeue=1
MinJobAge=300
KillWait=5
MailProg=/bin/true
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) RealMemory=${mem:-1000} State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
    export SLURM_CONF="$conf"
    slurmctld -f "$conf"
    slurmd -f "$conf"
    local state=""
    for _ in $(seq 300); do
        state="$(sinfo -h -n "$host" -o %T 2>/dev/null || true)"
        [ "$state" = "idle" ] && break
        sleep 0.1
    done
    [ "$state" = "idle" ] || die "node $host is '${state:-unknown}', not idle, after 30 s (logs in $dir/log)"
    say "up: node $host idle, partition debug, state in $dir"
    echo "export SLURM_CONF=$conf"
}

stop() {
    [ -d "$dir" ] || {
        say "nothing under $dir"
        return 0
    }
    dir="$(cd "$dir" && pwd)"
    export SLURM_CONF="$dir/etc/slurm.conf"
    if pid_alive "$dir/run/slurmctld.pid"; then
        # Jobs first: slurmstepd outlives slurmd, so a job left running would outlive the cluster.
        scancel --user="$(id -un)" 2>/dev/null || true
        for _ in $(seq 200); do
            [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break
            sleep 0.1
        done
        scontrol shutdown >/dev/null 2>&1 || true
    fi
    for f in slurmctld slurmd; do
        for _ in $(seq 200); do
            pid_alive "$dir/run/$f.pid" || break
            sleep 0.1
        done
        if pid_alive "$dir/run/$f.pid"; then
            kill -TERM "$(cat "$dir/run/$f.pid")" 2>/dev/null || true
        fi
    done
    if pid_alive "$dir/run/munged.pid"; then
        kill -TERM "$(cat "$dir/run/munged.pid")" 2>/dev/null || true
    fi
    say "stopped (state left in $dir)"
}

case "$cmd" in
start) start ;;
stop) stop ;;
*)
    echo "usage: $0 start|stop [DIR]" >&2
    exit 2
    ;;
esac
