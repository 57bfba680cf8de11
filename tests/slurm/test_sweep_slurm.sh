#!/usr/bin/env bash
# capsflow sweep under a real Slurm (ctest label 'slurm'; docs/sweeps.md): a single-node cluster (slurmctld + slurmd
# + munged) started in a folder of its own (configuration, spool and logs under it, no system service touched),
# runs a sweep of two short runs with the job-array script that `capsflow sweep --slurm` writes. One task is
# cancelled mid-run (scancel: the
# run gets SIGTERM and checkpoints) and submitted again; the other gets SIGUSR1, the time-limit warning of the
# script's --signal line, checkpoints and requeues itself. Each run's series must equal, bit for bit, those of an
# uninterrupted run of the same point. The daemons started here are stopped whatever happens.
#
# Usage: test_sweep_slurm.sh CAPSFLOW_BINARY
# Needs root (or sudo) to install slurm-wlm, munge and hdf5-tools when they are missing; exits 77 (skipped) when
# it cannot.
set -euo pipefail
capsflow=$(readlink -f "$1")
say() { echo "slurm test: $*"; }
fail() { echo "slurm test: FAILED: $*" >&2; exit 1; }

sudo=""
if [ "$(id -u)" -ne 0 ]; then
  if sudo -n true 2>/dev/null; then sudo="sudo -n"; else say "not root and no sudo: skipped"; exit 77; fi
fi
missing=()
for p in slurm-wlm munge hdf5-tools; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  say "installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null 2>&1 ||
    { $sudo apt-get update -qq && $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null; } ||
    { say "cannot install ${missing[*]}: skipped"; exit 77; }
fi

t_start=$(date +%s)
work=$(mktemp -d "${TMPDIR:-/tmp}/capsflow-slurm-XXXXXX")
chmod 755 "$work"
host=$(hostname)
jobs_submitted=()

cleanup() {
  set +e
  if [ -n "${SLURM_CONF:-}" ] && [ -f "$work/slurmctld.pid" ]; then
    for j in "${jobs_submitted[@]}"; do scancel "$j" 2>/dev/null; done
    for _ in $(seq 1 30); do [ -z "$(squeue -h 2>/dev/null)" ] && break; sleep 1; done
  fi
  for pidfile in "$work/slurmd.pid" "$work/slurmctld.pid" "$work/munge/munged.pid"; do
    if [ -f "$pidfile" ]; then
      pid=$(cat "$pidfile")
      $sudo kill "$pid" 2>/dev/null
      for _ in $(seq 1 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
      kill -0 "$pid" 2>/dev/null && $sudo kill -9 "$pid" 2>/dev/null
    fi
  done
  if [ "${keep_work:-0}" = 1 ]; then say "work folder kept: $work"; else rm -rf "$work"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# --- munge, with its socket in the work folder -----------------------------------------------------------------
mkdir -p "$work/munge"
$sudo chown munge: "$work/munge"
$sudo chmod 755 "$work/munge"
$sudo su -s /bin/sh munge -c "munged --socket=$work/munge/socket --pid-file=$work/munge/munged.pid \
  --log-file=$work/munge/munged.log --seed-file=$work/munge/seed" || fail "munged did not start"
for _ in $(seq 1 50); do [ -S "$work/munge/socket" ] && break; sleep 0.1; done

# --- slurm.conf, ports chosen per run so that two clusters on one host do not meet ------------------------------
port=$((20000 + RANDOM % 20000))
mkdir -p "$work/spool" "$work/state"
cat > "$work/slurm.conf" <<CONF
ClusterName=capsflowtest
SlurmctldHost=$host
SlurmctldPort=$port
SlurmdPort=$((port + 1))
AuthType=auth/munge
AuthInfo=socket=$work/munge/socket
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SlurmUser=root
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmdSpoolDir=$work/spool
StateSaveLocation=$work/state
SlurmctldLogFile=$work/ctld.log
SlurmdLogFile=$work/d.log
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
KillWait=30
NodeName=$host CPUs=$(nproc) RealMemory=2000 State=UNKNOWN
PartitionName=main Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
$sudo env SLURM_CONF="$SLURM_CONF" slurmctld -c || fail "slurmctld did not start ($(tail -3 "$work/ctld.log" 2>/dev/null))"
$sudo env SLURM_CONF="$SLURM_CONF" slurmd || fail "slurmd did not start ($(tail -3 "$work/d.log" 2>/dev/null))"
for _ in $(seq 1 60); do sinfo -h -o %T 2>/dev/null | grep -q idle && break; sleep 0.5; done
sinfo -h -o %T | grep -q idle || fail "the node did not become idle: $(sinfo 2>&1; tail -5 "$work/ctld.log")"
say "cluster up on $host (ports $port, $((port + 1))) after $(( $(date +%s) - t_start )) s"

# --- the sweep: the embedded demo (8 capsules) on the serial backend, two floppy Ca -----------------------------
# To strain 2 (about 6 s a run here): the run marker's strain is refreshed once a second, and the signals below must
# reach each run well before its end.
cd "$work"
"$capsflow" run --print-demo-config > base.toml
cat > sweep.toml <<SWEEP
base = "base.toml"
root = "runs"
name = "capsflow-test"
[set]
run.backend = "serial"
time.end = 2.0
output.every = 0.05
output.checkpoint_every = 0.1
[[product]]
species.floppy.ca = [1.0, 0.8]
SWEEP
"$capsflow" sweep sweep.toml --slurm --time 00:10:00 --signal-seconds 60 > slurm.txt
script=runs/slurm/capsflow-test.sbatch
[ -f "$script" ] || fail "no script: $(cat slurm.txt)"
grep -q -- "--signal=B:USR1@60" "$script" || fail "the script has no --signal line"
grep -q -- "--requeue" "$script" || fail "the script has no --requeue line"
mapfile -t dirs < <(find runs -mindepth 1 -maxdepth 1 -type d ! -name slurm | sort)

wait_jobs() {  # wait until job $1 has left the queue (at most $2 s)
  for _ in $(seq 1 "$2"); do [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0; sleep 1; done
  fail "job $1 still queued after $2 s: $(squeue)"
}
# The marker is JSON, one key per line ("strain": 0.25,).
marker_strain() { sed -n 's/^ *"strain": *\([^,]*\),\{0,1\}$/\1/p' "$1" 2>/dev/null || true; }

job=$(sbatch --parsable "$script") || fail "sbatch failed"
jobs_submitted+=("$job")
say "submitted job array $job"
wait_strain() {  # until the run of directory $1 has passed strain 0.2 (checkpoints at 0.1 and 0.2 behind it)
  local s
  for _ in $(seq 1 1200); do
    s=$(marker_strain "$1/output.lock")
    [ -n "$s" ] && awk -v s="$s" 'BEGIN { exit !(s >= 0.2) }' && return 0
    sleep 0.1
  done
  fail "$1 never ran: $(squeue; cat runs/slurm/*.out 2>/dev/null)"
}
d0=runs/ca-1 d1=runs/ca-0.8
wait_strain "$d0"
scancel --batch --signal=USR1 "${job}_0"
say "sent SIGUSR1 (time-limit warning) to task ${job}_0 at strain $(marker_strain "$d0/output.lock")"
wait_strain "$d1"
scancel "${job}_1"
say "cancelled task ${job}_1 at strain $(marker_strain "$d1/output.lock")"
for _ in $(seq 1 300); do grep -q SIGTERM "$d1/result" 2>/dev/null && break; sleep 0.2; done
"$capsflow" sweep sweep.toml --status | tee status1.txt
grep -E "^  1 +interrupted" status1.txt >/dev/null || fail "task 1 is not interrupted after scancel"
grep -q "SIGTERM" "$d1/result" || fail "task 1 did not checkpoint on SIGTERM: $(cat "$d1/result")"
# A cancelled task is continued as a task (its array index), not as a bare run (issue 25).
grep -q "continue with: sbatch --array=1 " status1.txt || fail "task 1's status does not say how to resubmit it"
grep -q "capsflow run --restart" status1.txt && fail "task 1's status names a bare run --restart"
# Slurm holds a requeued job back for a while (BeginTime); the test lets it start at once.
for _ in $(seq 1 300); do
  [ "$(squeue -h -j "${job}_0" -o %T 2>/dev/null)" = PENDING ] && grep -q "scontrol requeue" runs/slurm/"${job}"_0.out &&
    break
  sleep 0.2
done
# While it waits in the queue, its status says it was requeued, not merely interrupted.
"$capsflow" sweep sweep.toml --status | grep -A1 -E "^  0 " | grep -q "requeued" ||
  fail "the requeued task 0's status does not say it was requeued"
# slurmd refuses a batch job whose credential was issued in the same second as the requeue revoked the old one
# ("Job credential revoked", compared in whole seconds): let the clock pass the requeue's second before starting it.
sleep 2
scontrol update JobId="${job}_0" StartTime=now || true
wait_jobs "$job" 300
grep -q "SIGUSR1" "$d0/run.log" || fail "task 0 did not checkpoint on SIGUSR1: $(cat "$d0/run.log")"
grep -q "scontrol requeue" runs/slurm/"${job}"_0.out || fail "task 0 did not requeue itself: $(cat runs/slurm/"${job}"_0.out)"
[ "$(grep -c "continue from checkpoint" "$d0/run.log")" = 1 ] || fail "the requeued task 0 did not continue from its checkpoint"
grep -E "^  0 +done" <("$capsflow" sweep sweep.toml --status) >/dev/null || fail "task 0 is not done after its requeue"
[ ! -e "$d1/output.lock" ] || fail "the cancelled run left its marker"
h0=$(sha256sum "$d0/output.h5")

job2=$(sbatch --parsable --array=1 "$script") || fail "sbatch (resubmit) failed"
jobs_submitted+=("$job2")
say "resubmitted task 1 as $job2"
wait_jobs "$job2" 300
"$capsflow" sweep sweep.toml --status | tee status2.txt
[ "$(grep -cE '^  [01] +done' status2.txt)" = 2 ] || fail "not every run is done: $(cat runs/*/run.log)"
grep -q "continue from checkpoint" "$d1/run.log" || fail "task 1 did not continue from its checkpoint"
[ "$h0" = "$(sha256sum "$d0/output.h5")" ] || fail "task 0's finished output changed"

# The same points without interruption, here.
for d in "$d0" "$d1"; do
  ref="ref/$(basename "$d")"
  mkdir -p "$ref"
  "$capsflow" run "$d/config.toml" --output "$ref/ref.h5" --progress 0 -q || fail "reference run of $d failed"
  for g in /series /events; do
    h5diff "$ref/ref.h5" "$d/output.h5" "$g" "$g" > diff.txt ||
      fail "the continued run's $g differ from the uninterrupted run's ($d): $(head -20 diff.txt)"
  done
  n=$(h5dump -H -d /series/time "$d/output.h5" | sed -n 's/.*DATASPACE  SIMPLE { ( \([0-9]*\) ).*/\1/p')
  say "$d: continued run equals the uninterrupted one bit for bit (/series, /events; $n records)"
done
say "passed in $(( $(date +%s) - t_start )) s"
