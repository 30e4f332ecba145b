#!/usr/bin/env bash
# ci/slurm.sh: a private one-node Slurm cluster on this machine, for the render-farm test (ci/farm-test.sh).
#
#   ci/slurm.sh up       writes a slurm.conf into the state directory, starts munged, slurmctld and
#                        slurmd, waits until the node is idle, and prints the line to paste:
#                          export SLURM_CONF=<state dir>/slurm.conf
#   ci/slurm.sh down     cancels the cluster's jobs and stops the daemons that `up` started (by their
#                        pid files); touches nothing outside the state directory; safe to run twice
#   ci/slurm.sh status   says whether each daemon runs, and shows sinfo and squeue when slurmctld does;
#                        exits 0 when all three run, 1 otherwise
#
# State directory: $VKPATH_SLURM_DIR, by default /tmp/vkpath-slurm. Everything lives there: the munge
# key and socket, slurm.conf, the controller's state, slurmd's spool, pid files and logs. Nothing
# system-wide is used or changed: munged runs with its own key and socket (Slurm finds it through
# AuthInfo=socket=...), so a munged or Slurm already on the machine is left alone.
#
# Needs root (SlurmUser=root and SlurmdUser=root keep the cluster free of extra accounts) and the
# Debian packages slurmctld, slurmd, slurm-client and munge. No systemd and no cgroups are used
# (proctrack/linuxproc, task/none), so it runs in containers and sandboxes.
# Everything talks over loopback: the controller and the node are both 127.0.0.1.
set -euo pipefail

state_dir=${VKPATH_SLURM_DIR:-/tmp/vkpath-slurm}
case $state_dir in
    /*) ;;
    *) state_dir=$PWD/$state_dir ;; # slurm.conf needs absolute paths
esac
conf=$state_dir/slurm.conf
munge_dir=$state_dir/munge
munge_socket=$munge_dir/munge.socket
run_dir=$state_dir/run
log_dir=$state_dir/log
node=$(hostname -s)
# Bounded waits, in seconds.
up_timeout=${VKPATH_SLURM_UP_TIMEOUT:-60}
stop_timeout=15

die() {
    echo "ci/slurm.sh: $*" >&2
    exit 1
}

usage() {
    # The comment block at the top of this file, without the '# '.
    awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"
}

# The pid in a pid file if that process is alive and is the daemon we expect (its command name),
# so that a stale pid file whose number was reused by another process never gets that process killed.
live_pid() {
    local pidfile=$1 name=$2 pid comm
    [ -r "$pidfile" ] || return 1
    pid=$(tr -dc '0-9' <"$pidfile")
    [ -n "$pid" ] || return 1
    comm=$(cat "/proc/$pid/comm" 2>/dev/null) || return 1
    [ "$comm" = "$name" ] || return 1
    echo "$pid"
}

# True when nothing listens on 127.0.0.1:$1 (a connect attempt fails). Plain bash, so no iproute2.
port_free() {
    ! (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null
}

# Two free ports next to each other for slurmctld and slurmd: not Slurm's defaults (6817/6818),
# so that a real Slurm on the machine, or a second private cluster, does not collide with ours.
pick_ports() {
    local base
    for base in 16817 17817 18817 19817 20817 21817 22817 23817; do
        if port_free "$base" && port_free $((base + 1)); then
            echo "$base"
            return 0
        fi
    done
    die "no free port pair found for slurmctld and slurmd (tried 16817..23818)"
}

show_logs() {
    local f
    for f in "$log_dir/slurmctld.log" "$log_dir/slurmd.log" "$munge_dir/munged.log"; do
        if [ -s "$f" ]; then
            echo "----- last lines of $f -----" >&2
            tail -n 30 "$f" >&2
        fi
    done
}

write_munge_key() {
    # munged insists on: a key readable by its owner only, and a socket directory that everyone
    # may enter (it refuses to start when the socket's directory lacks o+x).
    mkdir -p "$munge_dir"
    chmod 0755 "$state_dir" "$munge_dir"
    if [ ! -s "$munge_dir/munge.key" ]; then
        if command -v mungekey >/dev/null; then
            mungekey --create --keyfile="$munge_dir/munge.key"
        else
            # Older munge packages have no mungekey; any 1024 random bits make a good key.
            (umask 077 && dd if=/dev/urandom of="$munge_dir/munge.key" bs=128 count=1 status=none)
        fi
    fi
    chmod 0400 "$munge_dir/munge.key"
}

write_conf() {
    local base=$1 cpus mem_mb
    cpus=$(nproc)
    # RealMemory a bit (10%) under the machine's, in MiB. Memory is not a consumable resource here
    # (CR_Core), so this only has to be plausible.
    mem_mb=$(awk '/^MemTotal:/ { printf "%d", $2 / 1024 * 0.9 }' /proc/meminfo)
    mkdir -p "$state_dir/ctld" "$state_dir/spool" "$run_dir" "$log_dir"
    cat >"$conf" <<EOF
# Written by ci/slurm.sh up: a private one-node cluster for vkpath's render-farm test.
ClusterName=vkpath-ci
# The controller and the node are both this machine, reached over loopback only (no DNS needed).
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$base
SlurmdPort=$((base + 1))
# Root runs everything: no slurm account, no file ownership to arrange.
SlurmUser=root
SlurmdUser=root

# Our own munged, through its private socket (the default is the system's /run/munge socket).
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$munge_socket

# Every path is in the state directory.
StateSaveLocation=$state_dir/ctld
SlurmdSpoolDir=$state_dir/spool
SlurmctldPidFile=$run_dir/slurmctld.pid
SlurmdPidFile=$run_dir/slurmd.pid
SlurmctldLogFile=$log_dir/slurmctld.log
SlurmdLogFile=$log_dir/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
# An empty SPANK stack, instead of the default (plugstack.conf beside this file, which we don't write).
PlugStackConfig=$state_dir/plugstack.conf

# No cgroups and no systemd: processes are tracked through /proc, tasks are not confined. This is
# what works in containers and sandboxes without cgroup delegation.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
# No mail from this cluster (the default, /usr/bin/mail, is usually missing: an error in the log).
MailProg=/bin/true
MpiDefault=none
SwitchType=switch/none

# Allocate single cores, so that several array tasks run side by side on the one node.
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
# React within a second or two, not Slurm's production pace (main loop every 60 s, backfill every
# 30 s, batch jobs' scheduling delayed up to 3 s): the test's jobs last seconds.
SchedulerParameters=batch_sched_delay=0,sched_interval=1,bf_interval=1
# A job whose dependency can never be met (afterok on a cancelled or failed job) is cancelled
# instead of pending forever with reason DependencyNeverSatisfied: the merge job of a render whose
# part failed. (Slurm 22.05 reads this here; older releases had it in SchedulerParameters.)
DependencyParameters=kill_invalid_depend

# Short timeouts for a test cluster: SIGKILL 5 s after SIGTERM; a DOWN node comes back by itself
# when its slurmd registers. Finished jobs stay visible to scontrol for 5 minutes (there is no
# accounting database, so \`scontrol show job\` is how the test reads a finished job's state).
KillWait=5
MinJobAge=300
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
MessageTimeout=10
InactiveLimit=0
Waittime=0

# The node: this machine. config_overrides: trust these numbers rather than what slurmd detects,
# so that a sandbox reporting an odd CPU topology or memory does not get the node drained.
SlurmdParameters=config_overrides
NodeName=$node NodeAddr=127.0.0.1 NodeHostname=$node CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=ci Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
    : >"$state_dir/plugstack.conf"
}

start_munged() {
    if live_pid "$munge_dir/munged.pid" munged >/dev/null; then
        return 0
    fi
    rm -f "$munge_socket" "$munge_socket.lock"
    /usr/sbin/munged --key-file="$munge_dir/munge.key" --socket="$munge_socket" \
        --pid-file="$munge_dir/munged.pid" --log-file="$munge_dir/munged.log" \
        --seed-file="$munge_dir/munged.seed" ||
        {
            show_logs
            die "munged did not start"
        }
    # A credential round trip proves the key and the socket work.
    if ! munge -S "$munge_socket" -n | unmunge -S "$munge_socket" >/dev/null; then
        show_logs
        die "munged started but a munge/unmunge round trip through $munge_socket failed"
    fi
}

up() {
    [ "$(id -u)" = 0 ] || die "must run as root (the private cluster runs its daemons as root)"
    # slurm.conf has no quoting: a path with blanks or '#' would be cut short there.
    if [[ $state_dir =~ [[:space:]#] ]]; then
        die "the state directory '$state_dir' has a blank or '#' in its name, which slurm.conf cannot hold: set VKPATH_SLURM_DIR"
    fi
    local cmd
    for cmd in /usr/sbin/munged /usr/sbin/slurmctld /usr/sbin/slurmd sinfo sbatch scontrol munge; do
        command -v "$cmd" >/dev/null ||
            die "$cmd not found: install the Debian packages slurmctld slurmd slurm-client munge"
    done
    if live_pid "$run_dir/slurmctld.pid" slurmctld >/dev/null &&
        live_pid "$run_dir/slurmd.pid" slurmd >/dev/null &&
        live_pid "$munge_dir/munged.pid" munged >/dev/null; then
        echo "ci/slurm.sh: the cluster in $state_dir already runs" >&2
        echo "export SLURM_CONF=$conf"
        return 0
    fi
    # Some daemon is missing: start over from a clean state (stopping the rest, keeping the key).
    down >/dev/null
    rm -rf "$state_dir/ctld" "$state_dir/spool" "$run_dir" "$log_dir"

    local start=$SECONDS base
    write_munge_key
    start_munged
    base=$(pick_ports)
    write_conf "$base"
    export SLURM_CONF=$conf

    # -c: start with no jobs from an earlier run. Both fork into the background and write their
    # pid files themselves.
    /usr/sbin/slurmctld -c -f "$conf" || {
        show_logs
        die "slurmctld did not start"
    }
    /usr/sbin/slurmd -c -f "$conf" -N "$node" || {
        show_logs
        die "slurmd did not start"
    }

    # Wait until the node is idle: slurmd registered and the controller accepts it.
    local state=""
    while [ $((SECONDS - start)) -lt "$up_timeout" ]; do
        state=$(sinfo -h -n "$node" -o '%T' 2>/dev/null || true)
        if [ "$state" = idle ]; then
            echo "ci/slurm.sh: cluster up in $((SECONDS - start)) s (node $node, $(nproc) CPUs, ports $base-$((base + 1)), state in $state_dir)" >&2
            echo "export SLURM_CONF=$conf"
            return 0
        fi
        sleep 0.5
    done
    echo "ci/slurm.sh: node $node not idle after $up_timeout s (sinfo says '${state:-nothing}')" >&2
    sinfo -N -l 2>&1 | sed 's/^/  /' >&2 || true
    scontrol show node "$node" 2>&1 | sed 's/^/  /' >&2 || true
    show_logs
    down >/dev/null
    exit 1
}

# Stops daemons, given as PIDFILE:NAME pairs: SIGTERM to all of them at once (each takes a second or two
# to save its state and exit), then waits for each; SIGKILL for one still there after $stop_timeout s.
stop_daemons() {
    local spec pidfile name pid pids=() names=() i waited
    for spec in "$@"; do
        pidfile=${spec%%:*}
        name=${spec#*:}
        if pid=$(live_pid "$pidfile" "$name"); then
            kill "$pid" 2>/dev/null || true
            pids+=("$pid")
            names+=("$name")
        fi
        rm -f "$pidfile"
    done
    for i in "${!pids[@]}"; do
        waited=0
        while kill -0 "${pids[$i]}" 2>/dev/null && [ "$waited" -lt $((stop_timeout * 5)) ]; do
            sleep 0.2
            waited=$((waited + 1))
        done
        if kill -0 "${pids[$i]}" 2>/dev/null; then
            echo "ci/slurm.sh: ${names[$i]} (${pids[$i]}) still runs $stop_timeout s after SIGTERM; killing it" >&2
            kill -KILL "${pids[$i]}" 2>/dev/null || true
        fi
        echo "ci/slurm.sh: stopped ${names[$i]} (${pids[$i]})"
    done
}

down() {
    export SLURM_CONF=$conf
    # First the jobs, while the controller and slurmd still run: their processes (slurmstepd and
    # what it started) are not children of the daemons and would outlive them.
    if [ -f "$conf" ] && live_pid "$run_dir/slurmctld.pid" slurmctld >/dev/null &&
        live_pid "$run_dir/slurmd.pid" slurmd >/dev/null; then
        local waited=0
        if [ -n "$(squeue -h -o '%i' 2>/dev/null || true)" ]; then
            scancel --user="$(id -un)" 2>/dev/null || true
            # KillWait=5 bounds a polite end; allow for SIGKILL and the epilog too.
            while [ -n "$(squeue -h -t all -o '%i %t' 2>/dev/null | awk '$2 != "CA" && $2 != "CD" && $2 != "F"' || true)" ] &&
                [ "$waited" -lt $((stop_timeout * 5)) ]; do
                sleep 0.2
                waited=$((waited + 1))
            done
        fi
    fi
    stop_daemons "$run_dir/slurmd.pid:slurmd" "$run_dir/slurmctld.pid:slurmctld"
    # munged last: the Slurm daemons may still authenticate a message while they stop.
    stop_daemons "$munge_dir/munged.pid:munged"
}

status() {
    local name pidfile pid rc=0
    for name in munged slurmctld slurmd; do
        case $name in
            munged) pidfile=$munge_dir/munged.pid ;;
            *) pidfile=$run_dir/$name.pid ;;
        esac
        if pid=$(live_pid "$pidfile" "$name"); then
            echo "$name: running (pid $pid)"
        else
            echo "$name: not running"
            rc=1
        fi
    done
    if live_pid "$run_dir/slurmctld.pid" slurmctld >/dev/null; then
        echo "export SLURM_CONF=$conf"
        SLURM_CONF=$conf sinfo -N -l || true
        SLURM_CONF=$conf squeue || true
    fi
    return "$rc"
}

case ${1:-} in
    up) up ;;
    down) down ;;
    status) status ;;
    -h | --help) usage ;;
    *)
        usage >&2
        exit 2
        ;;
esac
