#!/usr/bin/env bash
# A one-machine Slurm cluster for the tests of `hisfm reconstruct --executor
# slurm`: munged, slurmctld and slurmd on localhost, all state in one folder.
#
#   scripts/local_slurm.sh start   # idempotent; prints the line to source
#   scripts/local_slurm.sh start --optional  # same, but only a note and
#                                  # exit 0 where Slurm is not installed
#   scripts/local_slurm.sh status  # exit 0 if the cluster answers
#   scripts/local_slurm.sh stop    # kills the daemons, removes the folder
#   scripts/local_slurm.sh env     # prints: export SLURM_CONF=...
#
# The folder is HISFM_SLURM_DIR (default /tmp/hisfm-slurm-$(id -u)); the
# Slurm commands find the cluster through SLURM_CONF=$HISFM_SLURM_DIR/
# slurm.conf. Ports: HISFM_SLURM_PORT (slurmctld, default 16817) and the next
# one (slurmd), so that a system Slurm on the default ports is not touched.
# No cgroups (containers often lack them): proctrack/linuxproc, task/none.
# Needs the Debian packages slurm-wlm and munge (scripts/setup.sh); runs as
# root or as the user who owns the folder (SlurmUser is that user).
set -euo pipefail

DIR="${HISFM_SLURM_DIR:-/tmp/hisfm-slurm-$(id -u)}"
PORT="${HISFM_SLURM_PORT:-16817}"
CONF="$DIR/slurm.conf"
SOCKET="$DIR/munge/munge.socket"
export SLURM_CONF="$CONF"

die() { echo "local_slurm: $*" >&2; exit 1; }

PATH="$PATH:/usr/sbin:/sbin"
missing() {
  for b in munged mungekey slurmctld slurmd sinfo sbatch; do
    command -v "$b" > /dev/null 2>&1 || { echo "$b"; return 0; }
  done
}

pid_alive() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2> /dev/null; }

answers() {
  pid_alive "$DIR/slurmctld.pid" && pid_alive "$DIR/slurmd.pid" \
    && timeout 10 sinfo -h -o %t 2> /dev/null | grep -qE '^(idle|mix|alloc)'
}

write_conf() {
  local cpus mem user
  cpus=$(nproc)
  # slurmd -C reports the memory slurmd will see; keep a margin below it.
  mem=$(slurmd -C 2> /dev/null | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p')
  mem=$(( ${mem:-1024} * 9 / 10 ))
  user=$(id -un)
  cat > "$CONF" <<EOF
# Written by scripts/local_slurm.sh: a one-machine cluster for the tests.
ClusterName=hisfm-local
SlurmctldHost=localhost
SlurmctldPort=$PORT
SlurmdPort=$((PORT + 1))
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$SOCKET
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/slurmctld.log
SlurmdLogFile=$DIR/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
SwitchType=switch/none
MinJobAge=300
MaxArraySize=10001
SlurmctldTimeout=30
SlurmdTimeout=60
InactiveLimit=0
KillWait=5
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
}

start() {
  local m
  m=$(missing)
  if [ -n "$m" ]; then
    if [ "${1:-}" = "--optional" ]; then
      echo "local_slurm: $m not found (slurm-wlm and munge not installed): no cluster" >&2
      return 0
    fi
    die "$m not found: install slurm-wlm and munge (scripts/setup.sh)"
  fi
  if answers; then
    echo "export SLURM_CONF=$CONF"
    return 0
  fi
  stop_daemons
  mkdir -p "$DIR/state" "$DIR/spool" "$DIR/munge"
  chmod 700 "$DIR/munge"
  [ -f "$DIR/munge/munge.key" ] || mungekey -c -k "$DIR/munge/munge.key" -b 1024 2> /dev/null \
    || dd if=/dev/urandom of="$DIR/munge/munge.key" bs=1024 count=1 status=none
  chmod 400 "$DIR/munge/munge.key"
  # --force: the folder may sit in a world-writable /tmp.
  munged --force --key-file="$DIR/munge/munge.key" --socket="$SOCKET" \
    --pid-file="$DIR/munge/munged.pid" --log-file="$DIR/munge/munged.log" \
    --seed-file="$DIR/munge/munged.seed" \
    || die "munged did not start: $(tail -3 "$DIR/munge/munged.log" 2> /dev/null)"
  write_conf
  # -i: ignore state of an earlier cluster in this folder.
  slurmctld -i -f "$CONF" || die "slurmctld did not start: $(tail -3 "$DIR/slurmctld.log")"
  slurmd -N localhost -f "$CONF" || die "slurmd did not start: $(tail -3 "$DIR/slurmd.log")"
  for _ in $(seq 1 60); do
    if answers; then
      echo "export SLURM_CONF=$CONF"
      return 0
    fi
    scontrol update nodename=localhost state=resume > /dev/null 2>&1 || true
    sleep 0.5
  done
  die "the cluster did not come up within 30 s: $(tail -2 "$DIR/slurmctld.log" 2> /dev/null) / $(tail -2 "$DIR/slurmd.log" 2> /dev/null)"
}

kill_pidfile() {
  local f="$1" pid
  [ -f "$f" ] || return 0
  pid=$(cat "$f")
  if kill -0 "$pid" 2> /dev/null; then
    kill "$pid" 2> /dev/null || true
    for _ in $(seq 1 50); do
      kill -0 "$pid" 2> /dev/null || break
      sleep 0.1
    done
    kill -9 "$pid" 2> /dev/null || true
  fi
  rm -f "$f"
}

stop_daemons() {
  if [ -f "$CONF" ] && pid_alive "$DIR/slurmctld.pid"; then
    timeout 10 scancel --quiet --full --user="$(id -un)" 2> /dev/null || true
  fi
  kill_pidfile "$DIR/slurmd.pid"
  kill_pidfile "$DIR/slurmctld.pid"
  kill_pidfile "$DIR/munge/munged.pid"
}

case "${1:-}" in
  start) start "${2:-}" ;;
  stop)
    stop_daemons
    rm -rf "$DIR"
    ;;
  status)
    if answers; then echo "running: export SLURM_CONF=$CONF"; else
      echo "not running"; exit 1; fi
    ;;
  env) echo "export SLURM_CONF=$CONF" ;;
  *) die "usage: $0 start|stop|status|env" ;;
esac
