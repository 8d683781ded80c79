#!/usr/bin/env bash
# A one-node Slurm cluster in a folder, for tests and benchmarks: munged with a fresh key,
# slurmctld and slurmd from a generated slurm.conf, no cgroups (proctrack/linuxproc, task/none),
# ports picked free. Nothing outside DIR is touched; clients find it through SLURM_CONF.
#   slurm_cluster.sh start DIR   -> prints "export SLURM_CONF=DIR/slurm.conf" and exits 0 once the
#                                   node is idle; exit 3 with one line on stderr when the daemons
#                                   cannot start here (no Slurm, no munge, not permitted)
#   slurm_cluster.sh stop DIR    -> stops the daemons started in DIR (by their pid files)
set -euo pipefail
action="${1:?usage: slurm_cluster.sh start|stop DIR}"
dir="${2:?usage: slurm_cluster.sh start|stop DIR}"

cannot() { echo "slurm_cluster: cannot start a one-node cluster: $*" >&2; exit 3; }

stop() {
  # cancel what still runs, so no job step outlives its cluster
  if [ -f "$dir/slurm.conf" ] && [ -f "$dir/slurmctld.pid" ]; then
    SLURM_CONF="$dir/slurm.conf" timeout 10 scancel --quiet --user="$(id -un)" >/dev/null 2>&1 || true
    for _ in $(seq 30); do
      [ -z "$(SLURM_CONF="$dir/slurm.conf" timeout 5 squeue -h -t R,CG 2>/dev/null)" ] && break
      sleep 0.2
    done
  fi
  for name in slurmd slurmctld munged; do
    local pidfile="$dir/$name.pid"
    [ -f "$pidfile" ] || continue
    local pid; pid=$(cat "$pidfile" 2>/dev/null || true)
    if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
      kill "$pid" 2>/dev/null || true
      for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
      kill -9 "$pid" 2>/dev/null || true
    fi
    rm -f "$pidfile"
  done
  # job steps of this cluster left by a slurmd that was killed mid-job (found by their SLURM_CONF)
  local conf="SLURM_CONF=$dir/slurm.conf"
  for p in $(pgrep -x slurmstepd 2>/dev/null || true); do
    if tr '\0' '\n' <"/proc/$p/environ" 2>/dev/null | grep -qx "$conf"; then kill -9 "$p" 2>/dev/null || true; fi
  done
}

free_port() {
  python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'
}

if [ "$action" = stop ]; then stop; exit 0; fi
[ "$action" = start ] || { echo "slurm_cluster: unknown action '$action' (start or stop)" >&2; exit 2; }

for tool in munged slurmctld slurmd sbatch squeue sinfo scontrol; do
  command -v "$tool" >/dev/null 2>&1 || [ -x "/usr/sbin/$tool" ] || cannot "'$tool' is not installed (apt-get install slurm-wlm munge)"
done
PATH="$PATH:/usr/sbin"
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)
chmod 0700 "$dir"
mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
chmod 0700 "$dir/munge"

# munge: a fresh key, its own socket
dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
chmod 0400 "$dir/munge/munge.key"
munged --force --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
  --pid-file="$dir/munged.pid" --log-file="$dir/munged.log" --seed-file="$dir/munge/seed" \
  >"$dir/munged.out" 2>&1 || cannot "munged failed: $(tail -1 "$dir/munged.out")"

user=$(id -un)
host=$(hostname -s)
cpus=$(nproc)
mem=$(awk '/MemTotal/ {print int($2 / 1024 * 0.8)}' /proc/meminfo)
ctld_port=$(free_port)
slurmd_port=$(free_port)
cat >"$dir/slurm.conf" <<CONF
ClusterName=weft-test
SlurmctldHost=$host(127.0.0.1)
SlurmUser=$user
SlurmdUser=$user
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket,cred_expire=10
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool/%n
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=600
KillWait=5
Waittime=0
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
CONF
export SLURM_CONF="$dir/slurm.conf"
slurmctld -i -f "$SLURM_CONF" >"$dir/slurmctld.out" 2>&1 || { stop; cannot "slurmctld failed: $(tail -1 "$dir/slurmctld.log" 2>/dev/null)"; }
slurmd -f "$SLURM_CONF" >"$dir/slurmd.out" 2>&1 || { stop; cannot "slurmd failed: $(tail -1 "$dir/slurmd.log" 2>/dev/null)"; }
for _ in $(seq 150); do
  state=$(sinfo -h -N -o '%t' 2>/dev/null | head -1 || true)
  case "$state" in
    idle|mix|alloc) echo "export SLURM_CONF=$SLURM_CONF"; exit 0 ;;
  esac
  sleep 0.2
done
last=$(tail -1 "$dir/slurmd.log" 2>/dev/null || true)
stop
cannot "the node did not come up in 30 s (state '${state:-none}'; slurmd: $last)"
