# A single-node Slurm cluster in a folder, for tests: its own munge daemon (key, socket, pid and
# log in the folder), slurmctld and slurmd with a generated slurm.conf on non-default ports.
# Source this file, then:
#   cluster_start DIR   starts everything, waits until the node is idle; exports SLURM_CONF
#   cluster_stop DIR    stops the daemons by the pids in their pid files (never by name)
# Needs root (slurmd runs jobs as their submitter; SlurmUser=root) and Debian's slurm-wlm and munge.

cluster_pid_alive() { [ -s "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

cluster_stop() {
  local dir=$1 f pid
  for f in "$dir/slurmd.pid" "$dir/slurmctld.pid" "$dir/munged.pid"; do
    [ -s "$f" ] || continue
    pid=$(cat "$f")
    kill "$pid" 2>/dev/null || continue
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null || true
  done
}

cluster_start() {
  local dir=$1 host port
  host=$(hostname)
  mkdir -p "$dir/munge" "$dir/state" "$dir/spool"
  # munge: a key of our own, everything owned by the munge user in a folder only it can write.
  mungekey --create --keyfile="$dir/munge/munge.key" >/dev/null 2>&1 ||
    dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
  chown -R munge:munge "$dir/munge"
  chmod 700 "$dir/munge"
  chmod 600 "$dir/munge/munge.key"
  chmod 755 "$dir"
  runuser -u munge -- test -x "$dir/munge" ||
    { echo "local_cluster: the munge user cannot reach $dir (a parent folder is private); use a folder others may enter" >&2; return 1; }
  runuser -u munge -- munged --force --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
    --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" --seed-file="$dir/munge/munged.seed" ||
    { echo "local_cluster: munged did not start; $dir/munge/munged.log:" >&2; cat "$dir/munge/munged.log" >&2; return 1; }
  for _ in $(seq 50); do [ -s "$dir/munge/munged.pid" ] && break; sleep 0.1; done
  ln -sf "$dir/munge/munged.pid" "$dir/munged.pid"
  # Ports: a pair unlikely to be in use (Slurm's defaults are 6817/6818).
  port=$((20000 + ($$ % 20000)))
  cat > "$dir/slurm.conf" <<CONF
ClusterName=penumbra-test
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
CredType=cred/munge
SlurmctldPort=$port
SlurmdPort=$((port + 1))
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SlurmctldTimeout=30
SlurmdTimeout=30
NodeName=$host CPUs=$(nproc) State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES State=UP MaxTime=INFINITE
CONF
  export SLURM_CONF=$dir/slurm.conf
  slurmctld -f "$SLURM_CONF" -i ||
    { echo "local_cluster: slurmctld did not start; $dir/slurmctld.log:" >&2; cat "$dir/slurmctld.log" >&2; return 1; }
  slurmd -f "$SLURM_CONF" ||
    { echo "local_cluster: slurmd did not start; $dir/slurmd.log:" >&2; cat "$dir/slurmd.log" >&2; return 1; }
  for _ in $(seq 150); do
    if sinfo -h -o %t 2>/dev/null | grep -qx idle; then return 0; fi
    sleep 0.2
  done
  echo "local_cluster: the node did not become idle in 30 s; sinfo says: $(sinfo 2>&1)" >&2
  tail -5 "$dir/slurmctld.log" "$dir/slurmd.log" >&2
  return 1
}
