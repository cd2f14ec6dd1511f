#!/usr/bin/env bash
# A real single-node Slurm cluster on this host, from Debian's packages (slurmctld, slurmd,
# slurm-client, munge), started without systemd, for tests and for trying the job scripts:
#
#   ci/slurm/cluster.sh start DIR   # writes DIR/slurm.conf and a munge key, starts munged,
#                                   # slurmctld and slurmd, waits until the node is idle
#   export SLURM_CONF=DIR/slurm.conf   # then sbatch, squeue, sinfo talk to it
#   ci/slurm/cluster.sh stop DIR    # stops the three daemons it started, by their pids
#
# Everything lives in DIR (config, key, sockets, state, logs); nothing under /etc is read or
# written, and the ports are picked free, so it does not collide with a system Slurm or with
# another such cluster. The plugins are the ones that need no cgroups or systemd:
# proctrack/linuxproc, task/none, select/cons_tres (cores as consumable, CR_Core).
# Needs root (slurmd starts jobs as their submitting user). Exit 1 with the reason, and the
# tail of the daemon's log, when something does not start.
set -euo pipefail

die() {
    echo "slurm cluster: $*" >&2
    exit 1
}

cmd=${1:-}
dir=${2:-}
[ -n "$cmd" ] && [ -n "$dir" ] || die "usage: $0 start|stop DIR"

stop() {
    local d=$1 name pid
    for name in slurmd slurmctld munged; do
        [ -f "$d/run/$name.pid" ] || continue
        pid=$(cat "$d/run/$name.pid")
        # Only a process that is still the daemon we started (the pid may have been reused).
        if [ -n "$pid" ] && [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$name" ]; then
            kill "$pid" 2>/dev/null || true
            for _ in $(seq 50); do
                [ -d "/proc/$pid" ] || break
                sleep 0.1
            done
            if [ -d "/proc/$pid" ]; then
                echo "slurm cluster: $name ($pid) ignored SIGTERM for 5 s; SIGKILL" >&2
                kill -9 "$pid" 2>/dev/null || true
            fi
        fi
        rm -f "$d/run/$name.pid"
    done
}

tail_log() {
    local f=$1
    [ -f "$f" ] && { echo "--- last lines of $f:" >&2; tail -n 15 "$f" >&2; }
    return 0
}

free_port() {
    # A port nothing listens on, from a range away from Slurm's defaults (6817/6818).
    local p
    for _ in $(seq 200); do
        p=$((20000 + RANDOM % 20000))
        if ! ss -Hltn "sport = :$p" | grep -q .; then
            echo "$p"
            return
        fi
    done
    die "no free TCP port found in 20000-39999"
}

case "$cmd" in
stop)
    stop "$dir"
    exit 0
    ;;
start) ;;
*) die "unknown command $cmd (start or stop)" ;;
esac

[ "$(id -u)" -eq 0 ] || die "must run as root (slurmd runs jobs as their user; munged and slurmd are started here without systemd)"
for tool in munged slurmctld slurmd sbatch sinfo scontrol; do
    command -v "$tool" >/dev/null ||
        die "$tool not found: apt-get install -y slurmd slurmctld slurm-client munge (ci/test.sh does)"
done

mkdir -p "$dir"
dir=$(cd "$dir" && pwd)
mkdir -p "$dir/state" "$dir/spool" "$dir/log" "$dir/run"
chmod 0755 "$dir" "$dir/run"
# munged refuses a socket whose folders others cannot traverse (mktemp -d makes 0700).
p=$dir
while [ "$p" != / ]; do
    [ "$(($(stat -c %a "$p" | sed 's/^/0/') & 1))" -eq 1 ] ||
        die "$p is not searchable by others (mode $(stat -c %a "$p")); munged needs that for its socket: chmod o+x it or start the cluster elsewhere"
    p=$(dirname "$p")
done
# A fresh key for this cluster only (munge wants it private to its user).
rm -f "$dir/munge.key"
dd if=/dev/urandom of="$dir/munge.key" bs=1024 count=1 status=none
chmod 0400 "$dir/munge.key"

host=$(hostname -s)
# The node line as slurmd sees this machine (CPUs, sockets, cores, threads, memory).
node=$(slurmd -C | head -n 1)
case "$node" in
NodeName=*) ;;
*) die "slurmd -C printed no node line: $node" ;;
esac
ctld_port=$(free_port)
slurmd_port=$(free_port)
[ "$ctld_port" != "$slurmd_port" ] || slurmd_port=$((ctld_port + 1))

cat >"$dir/slurm.conf" <<EOF
# Written by ci/slurm/cluster.sh for one node ($host); see that script.
ClusterName=fragtrace-ci
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/run/munge.socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
# The test's jobs are short: let them be scheduled and reaped promptly.
SchedulerParameters=sched_interval=1
MinJobAge=300
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=ci Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
sed -i 's/ UpTime=[^ ]*//' "$dir/slurm.conf"

# If anything below fails, stop what was started.
trap 'stop "$dir"' ERR

munged --key-file="$dir/munge.key" --socket="$dir/run/munge.socket" \
    --pid-file="$dir/run/munged.pid" --log-file="$dir/log/munged.log" \
    --seed-file="$dir/run/munged.seed" ||
    { tail_log "$dir/log/munged.log"; die "munged did not start"; }
for _ in $(seq 50); do [ -S "$dir/run/munge.socket" ] && break; sleep 0.1; done
munge -S "$dir/run/munge.socket" -n </dev/null | unmunge -S "$dir/run/munge.socket" >/dev/null ||
    { tail_log "$dir/log/munged.log"; die "munge cannot encode and decode a credential"; }

export SLURM_CONF=$dir/slurm.conf
slurmctld -f "$dir/slurm.conf" -i ||
    { tail_log "$dir/log/slurmctld.log"; die "slurmctld did not start"; }
slurmd -f "$dir/slurm.conf" ||
    { tail_log "$dir/log/slurmd.log"; die "slurmd did not start"; }

# Ready when the node reports idle (slurmd registered with slurmctld).
state=""
for _ in $(seq 120); do
    state=$(sinfo -h -n "$host" -o %T 2>/dev/null || true)
    [ "$state" = "idle" ] && break
    sleep 0.5
done
if [ "$state" != "idle" ]; then
    tail_log "$dir/log/slurmctld.log"
    tail_log "$dir/log/slurmd.log"
    stop "$dir"
    die "the node did not become idle within 60 s (state: ${state:-none})"
fi
trap - ERR
echo "slurm cluster: up in $dir (node $host, slurmctld :$ctld_port, slurmd :$slurmd_port; pids munged $(cat "$dir/run/munged.pid"), slurmctld $(cat "$dir/run/slurmctld.pid"), slurmd $(cat "$dir/run/slurmd.pid"))"
