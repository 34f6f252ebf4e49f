#!/usr/bin/env bash
# A throw-away one-node Slurm cluster on localhost, for tests and for trying
# `fabrica batch --shard auto` without a real cluster (docs/batch.md).
#
#   tests/batch/slurm-cluster.sh start DIR   # munged + slurmctld + slurmd, config in DIR
#   export SLURM_CONF=DIR/slurm.conf         # then sbatch, squeue, sinfo as usual
#   tests/batch/slurm-cluster.sh stop DIR    # stops the three daemons (by their pids)
#
# Needs Debian's slurm-wlm and munge (scripts/setup) and root (SlurmUser=root).
# No cgroups (proctrack/linuxproc, task/none), no accounting, no network:
# everything listens on localhost ports chosen free at start, and every file
# (munge key and socket, state, spool, logs, pids) lives in DIR.
set -euo pipefail

usage() { echo "usage: $0 start|stop DIR" >&2; exit 2; }
[ $# -eq 2 ] || usage
cmd=$1
dir=$(mkdir -p "$2" && cd "$2" && pwd)

# A localhost port nothing listens on (bash's /dev/tcp; no other tool needed).
free_port() {
  local port
  while :; do
    port=$((20000 + RANDOM % 40000))
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then echo "$port"; return; fi
  done
}

# Stops one daemon by the pid in FILE (TERM, then KILL after 10 s).
stop_pid() {
  local file=$1 pid
  [ -s "$file" ] || return 0
  pid=$(cat "$file")
  if kill -0 "$pid" 2>/dev/null; then
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null || true
  fi
  rm -f "$file"
}

case "$cmd" in
start)
  for tool in munged slurmctld slurmd sinfo; do
    command -v "$tool" >/dev/null || { echo "$0: $tool not found; run scripts/setup (slurm-wlm, munge)" >&2; exit 4; }
  done
  [ "$(id -u)" -eq 0 ] || { echo "$0: must run as root (SlurmUser=root)" >&2; exit 4; }
  host=$(hostname -s)
  mkdir -p "$dir/state" "$dir/spool" "$dir/log"
  # munge: a fresh key and its own socket.
  head -c 1024 /dev/urandom > "$dir/munge.key"
  chmod 400 "$dir/munge.key"
  munged --key-file="$dir/munge.key" --socket="$dir/munge.sock" --pid-file="$dir/munged.pid" \
    --log-file="$dir/log/munged.log" --seed-file="$dir/munge.seed" --force
  ctl_port=$(free_port)
  d_port=$(free_port)
  while [ "$d_port" = "$ctl_port" ]; do d_port=$(free_port); done
  cat > "$dir/slurm.conf" <<CONF
ClusterName=fabrica-test
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$ctl_port
SlurmdPort=$d_port
AuthType=auth/munge
AuthInfo=socket=$dir/munge.sock
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
NodeName=$host CPUs=$(nproc) State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
  export SLURM_CONF=$dir/slurm.conf
  # Foreground daemons (-D), detached from the caller's terminal and pipes.
  setsid slurmctld -D -c -f "$SLURM_CONF" >"$dir/log/slurmctld.out" 2>&1 </dev/null &
  echo $! > "$dir/slurmctld.pid"
  setsid slurmd -D -f "$SLURM_CONF" >"$dir/log/slurmd.out" 2>&1 </dev/null &
  echo $! > "$dir/slurmd.pid"
  for _ in $(seq 300); do
    state=$(sinfo -h -N -o '%t' 2>/dev/null | head -n 1 || true)
    case "$state" in idle*|mix*|alloc*) echo "slurm: node $host $state; export SLURM_CONF=$SLURM_CONF"; exit 0 ;; esac
    sleep 0.1
  done
  echo "$0: the node did not become idle within 30 s; logs in $dir/log" >&2
  tail -n 20 "$dir"/log/*.log >&2 || true
  exit 4
  ;;
stop)
  stop_pid "$dir/slurmd.pid"
  stop_pid "$dir/slurmctld.pid"
  stop_pid "$dir/munged.pid"
  ;;
*) usage ;;
esac
