#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, brought up from Debian's packages (slurmctld, slurmd,
# slurm-client, munge) with everything in a temporary directory: its own munge key and munged, a
# minimal slurm.conf, slurmctld and slurmd on free ports. It submits the job scripts that
# docs/sweeps.md and docs/basin.md show (docs/examples/sweep.sbatch, basin.sbatch) as 3-task job
# arrays with `sbatch --wait`, merges the shards, and checks that results.csv and basin.csv are
# byte-identical to the same sweep and basin run in one process. Everything is torn down on exit.
# Exit 77 (ctest: skipped) when the cluster cannot be brought up: not root, a binary missing, a
# daemon exiting, or the node not idle within 30 s.
#   usage: slurm.sh AMBLER SOURCE_DIR
set -uo pipefail
ambler=$(realpath "$1")
src=$(realpath "$2")
here=$src/tests/cluster
source "$here/lib.sh"
t0=$(date +%s.%N)

skip() { echo "SKIPPED: slurm: $*"; exit 77; }
[[ $(id -u) -eq 0 ]] || skip "needs root (runs munged, slurmctld and slurmd, and jobs as root)"
for b in munged munge slurmctld slurmd sbatch sinfo squeue scancel; do
  command -v "$b" >/dev/null || skip "$b not found (bash scripts/setup.sh installs it)"
done

tmp=$(mktemp -d /tmp/ambler-slurm.XXXXXX)
chmod 711 "$tmp"  # munged wants the socket's directory searchable
pids=()
teardown() {
  if [[ -f $tmp/slurm.conf ]] && SLURM_CONF=$tmp/slurm.conf timeout 5 scancel --quiet --partition=test 2>/dev/null; then
    # let slurmd end the job steps before it goes
    for _ in $(seq 50); do
      [[ -z $(SLURM_CONF=$tmp/slurm.conf timeout 5 squeue --noheader 2>/dev/null) ]] && break
      sleep 0.2
    done
  fi
  local p
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null; done
  rm -rf "$tmp"
}
trap teardown EXIT
trap 'exit 1' INT TERM HUP

# munge: a key of our own and a daemon on our own socket
dd if=/dev/urandom of="$tmp/munge.key" bs=1024 count=1 status=none
chmod 600 "$tmp/munge.key"
munged --foreground --force --socket="$tmp/munge.sock" --key-file="$tmp/munge.key" \
  --pid-file="$tmp/munged.pid" --log-file="$tmp/munged.log" --seed-file="$tmp/munged.seed" \
  >"$tmp/munged.out" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [[ -S $tmp/munge.sock ]] && break; sleep 0.1; done
munge -S "$tmp/munge.sock" -n >/dev/null 2>&1 || skip "munged did not start: $(tail -n 1 "$tmp/munged.log" 2>/dev/null)"

# two free TCP ports for slurmctld and slurmd
free_port() {
  local p
  while :; do
    p=$((20000 + RANDOM % 20000))
    (: <"/dev/tcp/127.0.0.1/$p") 2>/dev/null || { echo "$p"; return; }
  done
}
ctld_port=$(free_port)
slurmd_port=$(free_port)
[[ $slurmd_port != "$ctld_port" ]] || slurmd_port=$((ctld_port + 1))

# the node as slurmd sees it (NodeName=<hostname -s> CPUs=... RealMemory=...)
node_line=$(slurmd -C 2>/dev/null | head -n 1)
[[ $node_line == NodeName=* ]] || skip "slurmd -C printed no node line"
node=${node_line#NodeName=}
node=${node%% *}
mkdir -p "$tmp/state" "$tmp/spool"
cat >"$tmp/slurm.conf" <<EOF
ClusterName=ambler-test
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge.sock
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
# sbatch --wait polls every 2 s only while MinJobAge/2 is not above that (else every 8-10 s);
# a finished job is kept 4 s, seen by the next poll
MinJobAge=4
$node_line NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=test Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$tmp/slurm.conf
slurmctld -D -i -f "$SLURM_CONF" >"$tmp/slurmctld.out" 2>&1 &
ctld_pid=$!
pids+=($ctld_pid)
slurmd -D -f "$SLURM_CONF" >"$tmp/slurmd.out" 2>&1 &
slurmd_pid=$!
pids+=($slurmd_pid)
# a daemon that exits is not coming up (slurmd needs /sys/fs/cgroup even without cgroup plugins:
# in a chroot without /sys it says "Unable to initialize cgroup plugin")
gone() {  # name pid log: skips when the daemon has exited
  kill -0 "$2" 2>/dev/null && return
  skip "$1 exited: $(grep -h 'error:' "$3" "$tmp/$1.out" 2>/dev/null | sed 's/^\[[^]]*\] //' | head -n 2 | tr '\n' ' ')"
}
up=0
deadline=$((SECONDS + 30))
while ((SECONDS < deadline)); do
  if [[ $(timeout 5 sinfo --noheader --nodes="$node" --format=%t 2>/dev/null) == idle ]]; then up=1; break; fi
  gone slurmctld "$ctld_pid" "$tmp/slurmctld.log"
  gone slurmd "$slurmd_pid" "$tmp/slurmd.log"
  sleep 0.2
done
if ((!up)); then
  skip "node $node not idle within 30 s (sinfo: $(timeout 5 sinfo --noheader 2>&1 | head -n 1);" \
    "slurmctld: $(tail -n 1 "$tmp/slurmctld.log" 2>/dev/null); slurmd: $(tail -n 1 "$tmp/slurmd.log" 2>/dev/null))"
fi
echo "slurm: node $node idle after $(elapsed): $(sinfo --noheader --format='%P %D %c %t')"

fail=0
check_doc_shows "$src/docs/sweeps.md" "$src/docs/examples/sweep.sbatch" || fail=1
check_doc_shows "$src/docs/basin.md" "$src/docs/examples/basin.sbatch" || fail=1

# submit WHAT SCRIPT ARGS...: submits SCRIPT from $tmp/WHAT as a 3-task array and waits; prints the
# tasks' output on failure.
submit() {
  local what=$1
  shift
  if ! (cd "$tmp/$what" && AMBLER=$ambler timeout 120 sbatch --array=1-3 --wait --quiet "$@"); then
    echo "FAIL $what: the job array failed"
    cat "$tmp/$what"/slurm-*.out 2>/dev/null
    tail -n 20 "$tmp/slurmd.log" 2>/dev/null
    return 1
  fi
  local outs
  outs=$(ls "$tmp/$what"/slurm-*_[123].out 2>/dev/null | wc -l)
  if [[ $outs -ne 3 ]]; then echo "FAIL $what: $outs of 3 array tasks left their slurm-JOB_TASK.out"; return 1; fi
}

# A sweep as docs/sweeps.md says: submit NAME's job array, wait, merge; then the same sweep in one
# process, whose results.csv the merge must equal byte for byte.
sweep_on_slurm() {
  local name=$1 file=$2
  mkdir -p "$tmp/$name"
  if submit "$name" "$src/docs/examples/sweep.sbatch" "$file" runs; then  # DIR relative to the submit directory
    echo "slurm: $name job array done after $(elapsed)"
    "$ambler" sweep "$file" --out "$tmp/$name/runs" --merge --quiet || return 1
    "$ambler" sweep "$file" --out "$tmp/$name/whole" --quiet || return 1
    same_bytes "$name" "$tmp/$name/whole/results.csv" "$tmp/$name/runs/results.csv" || return 1
  else
    return 1
  fi
}
sweep_on_slurm sweep "$here/sweep.yaml" || fail=1
sweep_on_slurm traverse "$here/traverse.yaml" || fail=1  # a sweep of traverses, sharded the same way

# The basin, as docs/basin.md says.
mkdir -p "$tmp/basin"
scenario=$here/basin.yaml
grid=(--translation-m 0,0.5 --rotation-deg 0,5 --trials 2)
if submit basin "$src/docs/examples/basin.sbatch" "$scenario" runs "${grid[@]}"; then
  echo "slurm: basin job array done after $(elapsed)"
  "$ambler" basin "$scenario" --out "$tmp/basin/runs" --merge --quiet "${grid[@]}" || fail=1
  "$ambler" basin "$scenario" --out "$tmp/basin/whole" --quiet "${grid[@]}" || fail=1
  same_bytes basin "$tmp/basin/whole/basin.csv" "$tmp/basin/runs/basin.csv" || fail=1
else
  fail=1
fi

if ((fail)); then echo "slurm: FAILED"; exit 1; fi
echo "slurm: all passed in $(elapsed)"
