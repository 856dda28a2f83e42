#!/usr/bin/env bash
#
# local-cluster.sh - a private, throw-away, single-node Slurm cluster on localhost
# (munged + slurmctld + slurmd), for trying the job scripts beside it and for the
# test that runs them (tests/it/slurm.rs). A real cluster needs none of this: submit
# there with submit.sh.
#
# Usage:
#   eval "$(local-cluster.sh start DIR)"   # start; prints `export SLURM_CONF=...`
#   local-cluster.sh stop DIR [--purge]    # stop daemons; --purge also removes DIR
#   local-cluster.sh status DIR            # exit 0 if all three daemons run
#   local-cluster.sh env DIR               # re-print the export lines
#   local-cluster.sh wait DIR JOBID...     # poll until done; 0 iff all COMPLETED
#
# Everything (config, munge key and socket, state, spool, logs, pid files) lives
# under DIR; nothing is written to /etc. The client commands (sbatch, squeue,
# sinfo, scontrol...) find the cluster through $SLURM_CONF, and slurm.conf's
# AuthInfo=socket=... points them at the private munge socket.
#
# Needs Debian/Ubuntu's `slurm-wlm` and `munge` and root (the daemons run as
# root, without systemd). Tested with Slurm 22.05.8 and munge 0.5.15 (Debian 12).
#
# Settings (environment):
#   SLURM_LOCAL_CTLD_PORT    slurmctld port                        (default 6817)
#   SLURM_LOCAL_SLURMD_PORT  slurmd port                           (default 6818)
#   SLURM_LOCAL_CPUS         CPUs the node offers         (default: slurmd -C)
#   SLURM_LOCAL_MEMORY       RealMemory in MB             (default: slurmd -C)
#   SLURM_LOCAL_TIMEOUT      seconds to wait for the node to become idle  (60)
#   SLURM_LOCAL_WAIT_TIMEOUT seconds `wait` polls before giving up       (600)
#
# Messages go to stderr; only the `export` lines go to stdout, so that
# `eval "$(local-cluster.sh start DIR)"` is safe.

set -euo pipefail

PROG=${0##*/}

log() { printf '%s: %s\n' "$PROG" "$*" >&2; }
die() { printf '%s: error: %s\n' "$PROG" "$*" >&2; exit 1; }

usage() {
    sed -n '9,13p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
}

# --------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------

# All paths derived from DIR, in one place.
set_paths() {
    DIR=$(realpath -m -- "$1")
    # slurm.conf has no quoting for paths.
    [[ $DIR != *[[:space:]]* ]] || die "DIR must not contain whitespace: '$DIR'"
    ETC=$DIR/etc
    CONF=$ETC/slurm.conf
    MUNGE_DIR=$DIR/munge           # key, socket, pid, seed (mode 0755)
    MUNGE_KEY=$MUNGE_DIR/munge.key
    MUNGE_SOCKET=$MUNGE_DIR/munge.socket.2
    MUNGE_PID=$MUNGE_DIR/munged.pid
    STATE=$DIR/state               # slurmctld StateSaveLocation
    SPOOL=$DIR/spool               # slurmd SlurmdSpoolDir
    RUN=$DIR/run                   # slurm pid files
    LOGS=$DIR/log
    CTLD_PID=$RUN/slurmctld.pid
    SLURMD_PID=$RUN/slurmd.pid
}

need_root() {
    [[ $(id -u) -eq 0 ]] || die "must run as root (slurmd has to start jobs as
    the submitting user and munged/slurmctld are configured to run as root);
    current uid is $(id -u). Use sudo or run the test as root."
}

need_binaries() {
    local missing=() b
    for b in munged mungekey munge slurmctld slurmd sinfo scontrol sbatch squeue scancel; do
        command -v "$b" >/dev/null 2>&1 || missing+=("$b")
    done
    if ((${#missing[@]})); then
        die "missing binaries: ${missing[*]}
    (PATH=$PATH)
    install them with: apt-get install -y --no-install-recommends slurm-wlm munge"
    fi
}

# Is the process in pid file $1 alive and named $2?  (Guards against stale
# pid files whose pid has been reused by an unrelated process.)
pid_alive() {
    local pidfile=$1 name=$2 pid comm
    [[ -s $pidfile ]] || return 1
    pid=$(<"$pidfile")
    [[ $pid =~ ^[0-9]+$ ]] || return 1
    comm=$(cat "/proc/$pid/comm" 2>/dev/null) || return 1
    [[ $comm == "$name" ]]
}

# Stop the process in pid file $1 (named $2): TERM, wait up to 10 s, KILL.
stop_pidfile() {
    local pidfile=$1 name=$2 pid i
    if pid_alive "$pidfile" "$name"; then
        pid=$(<"$pidfile")
        log "stopping $name (pid $pid)"
        kill -TERM "$pid" 2>/dev/null || true
        for ((i = 0; i < 100; i++)); do
            [[ -d /proc/$pid ]] || break
            sleep 0.1
        done
        if [[ -d /proc/$pid ]]; then
            log "$name (pid $pid) ignored SIGTERM; sending SIGKILL"
            kill -KILL "$pid" 2>/dev/null || true
        fi
    fi
    rm -f -- "$pidfile"
}

# Fail early (with a clear message) if a TCP port on localhost is taken,
# e.g. by another Slurm instance that was never stopped.
port_free() {
    local port=$1
    if command -v ss >/dev/null 2>&1; then
        [[ -z $(ss -Htln "sport = :$port") ]]
    else
        ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null
    fi
}

print_env() {
    printf 'export SLURM_CONF=%q\n' "$CONF"
    printf 'export SLURM_LOCAL_DIR=%q\n' "$DIR"
}

dump_logs() {
    local f
    {
        echo "----- diagnostics for $DIR -----"
        for f in "$LOGS/munged.log" "$LOGS/slurmctld.log" "$LOGS/slurmd.log" \
                 "$LOGS/munged.stderr" "$LOGS/slurmctld.stderr" "$LOGS/slurmd.stderr"; do
            [[ -s $f ]] || continue
            echo "===== $f (last 40 lines) ====="
            tail -n 40 "$f"
        done
        if pid_alive "$CTLD_PID" slurmctld; then
            echo "===== sinfo -N -l ====="
            SLURM_CONF=$CONF timeout 10 sinfo -N -l 2>&1 || true
            echo "===== scontrol show node ====="
            SLURM_CONF=$CONF timeout 10 scontrol show node 2>&1 || true
        fi
        echo "----- end of diagnostics -----"
    } >&2
}

# --------------------------------------------------------------------------
# start
# --------------------------------------------------------------------------

write_slurm_conf() {
    local node=$1 cpus=$2 mem=$3 ctld_port=$4 slurmd_port=$5
    cat >"$CONF" <<EOF
# Generated by $PROG on $(date -u +%FT%TZ) - private single-node cluster.
ClusterName=local
# Controller and node both on this host; explicit 127.0.0.1 so that the
# setup works even if \`hostname\` does not resolve.
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port

# Everything runs as root (the tests run as root).
SlurmUser=root
SlurmdUser=root

# Private munge daemon (socket under DIR) for both auth and job credentials.
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$MUNGE_SOCKET

# Private state / spool / pid / log locations.
StateSaveLocation=$STATE
SlurmdSpoolDir=$SPOOL
SlurmctldPidFile=$CTLD_PID
SlurmdPidFile=$SLURMD_PID
SlurmctldLogFile=$LOGS/slurmctld.log
SlurmdLogFile=$LOGS/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
PlugStackConfig=$ETC/plugstack.conf

# No cgroups (containers usually lack a usable, delegated cgroup tree).
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
# No slurmdbd: sacct will not work; poll squeue / scontrol show job instead.
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none

MpiDefault=none
SwitchType=switch/none
MailProg=/bin/true

# Schedule individual CPUs; memory is not a consumable resource (otherwise
# jobs without --mem would each claim the whole node's memory and run one at
# a time).  Each job/array task gets 1 CPU unless it asks for more.
SchedulerType=sched/backfill
# batch_sched_delay=0: schedule batch jobs right at submit/completion time
# instead of on the default 3 s tick (makes short test jobs much faster).
SchedulerParameters=batch_sched_delay=0
# A job whose afterok dependency failed is cancelled instead of pending
# forever (reason DependencyNeverSatisfied) - tests must not hang on it.
DependencyParameters=kill_invalid_depend
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU

# Bring the node back automatically after restarts; keep finished jobs
# visible to \`scontrol show job\` for 10 minutes.
ReturnToService=2
MinJobAge=600
SlurmdTimeout=60
InactiveLimit=0
KillWait=5

# Only CPUs (not sockets/cores/threads) are given so that every logical CPU
# is a schedulable unit, also on hyper-threaded CI machines.
NodeName=$node NodeHostname=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=$node Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
EOF
}

cmd_start() {
    need_root
    need_binaries

    local ctld_port=${SLURM_LOCAL_CTLD_PORT:-6817}
    local slurmd_port=${SLURM_LOCAL_SLURMD_PORT:-6818}
    local timeout=${SLURM_LOCAL_TIMEOUT:-60}

    if pid_alive "$CTLD_PID" slurmctld || pid_alive "$SLURMD_PID" slurmd ||
       pid_alive "$MUNGE_PID" munged; then
        die "a cluster is already running in $DIR; run '$PROG stop $DIR' first"
    fi
    local p
    for p in "$ctld_port" "$slurmd_port"; do
        port_free "$p" || die "TCP port $p is already in use (another slurmctld/slurmd?
    stop it, or choose other ports via SLURM_LOCAL_CTLD_PORT / SLURM_LOCAL_SLURMD_PORT)"
    done

    # Node name: the short hostname (slurmctld insists that SlurmctldHost
    # matches it), falling back to localhost.
    local node
    node=$(hostname -s 2>/dev/null || uname -n)
    node=${node%%.*}
    [[ -n $node ]] || node=localhost

    # Real hardware as slurmd itself sees it (`slurmd -C`), so the node is not
    # drained for "Low RealMemory" / "Low CPUs".
    local hw cpus mem
    hw=$(slurmd -C 2>/dev/null | head -n1 || true)
    cpus=${SLURM_LOCAL_CPUS:-$(sed -n 's/.*\bCPUs=\([0-9]\+\).*/\1/p' <<<"$hw")}
    mem=${SLURM_LOCAL_MEMORY:-$(sed -n 's/.*\bRealMemory=\([0-9]\+\).*/\1/p' <<<"$hw")}
    [[ -n $cpus ]] || cpus=$(nproc)
    [[ -n $mem ]] || mem=$(awk '/^MemTotal:/ {print int($2/1024)}' /proc/meminfo)

    log "setting up private Slurm in $DIR (node $node, $cpus CPUs, ${mem} MB)"
    mkdir -p -- "$DIR"
    mkdir -p -- "$ETC" "$STATE" "$SPOOL" "$RUN" "$LOGS"
    # munged is picky: its key must be 0600 (0400) and owned by the daemon's
    # user, the directories holding key/socket/logs must not be writable by
    # group/other, and the socket directory must be executable by all (0755).
    mkdir -p -- "$MUNGE_DIR"
    chmod 0755 "$DIR" "$MUNGE_DIR"
    chmod 0700 "$STATE" "$SPOOL"
    rm -f -- "$MUNGE_SOCKET" "$MUNGE_SOCKET.lock"

    if [[ ! -s $MUNGE_KEY ]]; then
        mungekey --create --keyfile="$MUNGE_KEY" >/dev/null 2>&1 ||
            dd if=/dev/urandom of="$MUNGE_KEY" bs=1024 count=1 status=none
    fi
    chmod 0600 "$MUNGE_KEY"

    write_slurm_conf "$node" "$cpus" "$mem" "$ctld_port" "$slurmd_port"
    : >"$ETC/plugstack.conf"       # empty: do not pick up /etc/slurm/plugstack.conf.d
    # slurmd loads a cgroup plugin at start even when nothing uses it (proctrack/linuxproc,
    # task/none above). The default, CgroupPlugin=autodetect, fails where no cgroup
    # filesystem is mounted on /sys/fs/cgroup (a chroot, many containers: "Unable to
    # initialize cgroup plugin"); naming cgroup/v1 skips the detection, and its plugin
    # touches no cgroup until a constraint asks it to, which none here does.
    printf 'CgroupPlugin=cgroup/v1\n' >"$ETC/cgroup.conf"
    export SLURM_CONF=$CONF

    # If anything below fails, show the logs and tear down what was started.
    trap 'rc=$?; if ((rc)); then dump_logs; cmd_stop >/dev/null 2>&1 || true; fi' EXIT

    # -- munged ------------------------------------------------------------
    # Daemons' stdio must be redirected: otherwise they inherit the caller's
    # stdout and `eval "$(local-cluster.sh start DIR)"` never returns.
    log "starting munged"
    munged --socket="$MUNGE_SOCKET" --key-file="$MUNGE_KEY" \
        --pid-file="$MUNGE_PID" --log-file="$LOGS/munged.log" \
        --seed-file="$MUNGE_DIR/munged.seed" \
        </dev/null >"$LOGS/munged.stderr" 2>&1 ||
        die "munged failed to start"
    local i
    for ((i = 0; i < 50; i++)); do
        munge -n --socket="$MUNGE_SOCKET" 2>/dev/null | unmunge --socket="$MUNGE_SOCKET" >/dev/null 2>&1 && break
        sleep 0.1
    done
    ((i < 50)) || die "munged does not answer on $MUNGE_SOCKET"

    # -- slurmctld ---------------------------------------------------------
    # -c: start with clean job state; -i: ignore unreadable old state.
    log "starting slurmctld"
    slurmctld -f "$CONF" -c -i </dev/null >"$LOGS/slurmctld.stderr" 2>&1 ||
        die "slurmctld failed to start"

    # -- slurmd ------------------------------------------------------------
    # -N: the NodeName to serve (must match slurm.conf).
    log "starting slurmd"
    slurmd -f "$CONF" -N "$node" </dev/null >"$LOGS/slurmd.stderr" 2>&1 ||
        die "slurmd failed to start"

    # -- wait until the node is idle --------------------------------------
    local deadline=$((SECONDS + timeout)) state=""
    while ((SECONDS < deadline)); do
        pid_alive "$CTLD_PID" slurmctld || { sleep 0.5; pid_alive "$CTLD_PID" slurmctld ||
            die "slurmctld exited (see $LOGS/slurmctld.log)"; }
        pid_alive "$SLURMD_PID" slurmd || { sleep 0.5; pid_alive "$SLURMD_PID" slurmd ||
            die "slurmd exited (see $LOGS/slurmd.log)"; }
        state=$(timeout 10 sinfo -h -n "$node" -o '%T' 2>/dev/null || true)
        [[ $state == idle ]] && break
        sleep 0.25
    done
    [[ $state == idle ]] ||
        die "node $node did not become idle within ${timeout}s (last state: '${state:-none}')"

    trap - EXIT
    log "cluster up: node $node idle; logs in $LOGS"
    print_env
}

# --------------------------------------------------------------------------
# stop
# --------------------------------------------------------------------------

cmd_stop() {
    local purge=${1:-}
    export SLURM_CONF=$CONF
    # Cancel jobs first so slurmd can clean up its slurmstepd's.
    if pid_alive "$CTLD_PID" slurmctld; then
        timeout 10 scancel --full --quiet --user=root 2>/dev/null || true
        timeout 10 scancel --quiet --state=PENDING 2>/dev/null || true
    fi
    stop_pidfile "$SLURMD_PID" slurmd
    stop_pidfile "$CTLD_PID" slurmctld
    # Any slurmstepd left over from this cluster (it inherits slurmd's
    # SLURM_CONF, which is how we recognise it).
    # (Scans /proc directly: pgrep/procps is not in minimal Debian images.)
    local d pid
    for d in /proc/[0-9]*; do
        [[ $(cat "$d/comm" 2>/dev/null) == slurmstepd ]] || continue
        grep -qxF "SLURM_CONF=$CONF" < <(tr '\0' '\n' <"$d/environ" 2>/dev/null) || continue
        pid=${d#/proc/}
        log "killing leftover slurmstepd $pid"
        kill -KILL "$pid" 2>/dev/null || true
    done
    stop_pidfile "$MUNGE_PID" munged
    rm -f -- "$MUNGE_SOCKET" "$MUNGE_SOCKET.lock"
    if [[ $purge == --purge ]]; then
        log "removing $DIR"
        rm -rf -- "$DIR"
    fi
    log "stopped (${DIR})"
}

# Poll squeue until none of the given jobs is pending/running any more, then
# exit 0 only if every job (and every array task) ended COMPLETED.  Faster
# than `sbatch --wait`, whose poll interval grows to 32 s.
cmd_wait() {
    (($#)) || die "usage: $PROG wait DIR JOBID..."
    export SLURM_CONF=$CONF
    local ids timeout=${SLURM_LOCAL_WAIT_TIMEOUT:-600} deadline id states rc=0
    ids=$(IFS=,; echo "$*")
    deadline=$((SECONDS + timeout))
    # (A test of the captured output, not `squeue | grep -q`: under pipefail, grep quitting
    # early would end the loop through squeue's SIGPIPE.)
    while [[ -n $(squeue -h -j "$ids" 2>/dev/null) ]]; do
        ((SECONDS < deadline)) || die "jobs $ids still queued after ${timeout}s"
        sleep 0.5
    done
    # Finished jobs stay visible to scontrol for MinJobAge (600 s).
    for id in "$@"; do
        states=$(scontrol -o show job "$id" 2>/dev/null |
                 sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | sort -u | paste -sd,)
        log "job $id: ${states:-unknown}"
        [[ $states == COMPLETED ]] || rc=1
    done
    return $rc
}

cmd_status() {
    local ok=0
    pid_alive "$MUNGE_PID" munged && log "munged running" || { log "munged not running"; ok=1; }
    pid_alive "$CTLD_PID" slurmctld && log "slurmctld running" || { log "slurmctld not running"; ok=1; }
    pid_alive "$SLURMD_PID" slurmd && log "slurmd running" || { log "slurmd not running"; ok=1; }
    return $ok
}

# --------------------------------------------------------------------------

(($# >= 2)) || usage
cmd=$1
set_paths "$2"
shift 2
case $cmd in
    start)  cmd_start ;;
    stop)   need_root; cmd_stop "${1:-}" ;;
    status) cmd_status ;;
    env)    print_env ;;
    wait)   cmd_wait "$@" ;;
    *)      usage ;;
esac
