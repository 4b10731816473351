#!/usr/bin/env bash
# The Slurm test (ctest: slurm_cluster): starts a throw-away single-node Slurm cluster on loopback
# (its own munge key, slurm.conf and state folders in a temporary folder; slurmctld + slurmd),
# submits a 3-window run of a small synthetic scene with `retimegs slurm --submit` into a run folder
# whose name holds shell and Slurm syntax (quotes, `$(...)`, `;`, `#`, `%`, spaces), waits for the
# merge job with a bounded timeout and checks the merged model, the logs' names, and that no part
# of the name ran as a command. Everything it started is stopped
# and its folder removed whatever the outcome. Exits 77 (skipped) with the reason when the
# daemons cannot start (no slurm-wlm / munge, or a machine that refuses them).
#   scripts/test_slurm.sh RETIMEGS_BINARY [TIMEOUT_SECONDS]
# For measurements (README "Long clips and Slurm"), the environment may change the job:
#   SLURM_TEST_SCENE=DIR (an existing scene instead of the synthetic one), SLURM_TEST_WINDOWS (3),
#   SLURM_TEST_ITERS (150, per window), SLURM_TEST_CAP (5000), SLURM_TEST_CPUS (CPUs per task, 1),
#   SLURM_TEST_KEEP=DIR (the run folder is moved there at the end).
set -uo pipefail
binary=$(realpath "${1:?usage: test_slurm.sh RETIMEGS_BINARY [TIMEOUT_SECONDS]}")
timeout_s=${2:-480}

skip() { echo "SKIPPED: $*"; exit 77; }
for tool in munged slurmctld slurmd sbatch squeue sinfo scontrol; do
  command -v "$tool" >/dev/null || skip "$tool not found (scripts/setup.sh installs slurm-wlm and munge)"
done
[ "$(id -u)" -eq 0 ] || skip "the throw-away cluster runs its daemons as root; run as root"

tmp=$(mktemp -d /tmp/retimegs-slurm.XXXXXX)
# The run folder: every character here is syntax to a shell or to sbatch's #SBATCH reader.
run="$tmp/run it's \"\$(touch PWNED1)\";touch PWNED2 #50%j"
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null
  done
  rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM

show_logs() {
  for f in "$tmp"/*.log "$run"/slurm/logs/*; do
    [ -f "$f" ] && { echo "---- $f"; tail -n 40 "$f"; }
  done
}
fail() { echo "FAILED: $*"; show_logs; exit 1; }

# munge, with its own key and socket.
mkdir -p "$tmp/munge" && chmod 700 "$tmp/munge"
head -c 1024 /dev/urandom > "$tmp/munge/munge.key" && chmod 400 "$tmp/munge/munge.key"
socket="$tmp/munge/munge.socket"
munged --foreground --force --key-file="$tmp/munge/munge.key" --socket="$socket" \
  --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/munged.log" \
  --seed-file="$tmp/munge/munged.seed" >/dev/null 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$socket" ] && break; sleep 0.1; done
[ -S "$socket" ] || { show_logs; skip "munged did not start"; }

# Ports: the first free pair from a random start, so that parallel runs do not collide.
port=$((20000 + RANDOM % 20000))
while (echo >/dev/tcp/127.0.0.1/$port) 2>/dev/null || (echo >/dev/tcp/127.0.0.1/$((port + 1))) 2>/dev/null; do
  port=$((port + 2))
done
cpus=$(nproc)
mkdir -p "$tmp/state" "$tmp/spool"
export SLURM_CONF="$tmp/slurm.conf"
cat > "$SLURM_CONF" <<CONF
ClusterName=retimegs-test
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
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
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
NodeName=retimegs-node NodeAddr=127.0.0.1 NodeHostname=$(hostname -s) CPUs=$cpus State=UNKNOWN
PartitionName=test Nodes=retimegs-node Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -D -i -f "$SLURM_CONF" >/dev/null 2>&1 &
pids+=($!)
slurmd -D -N retimegs-node -f "$SLURM_CONF" >/dev/null 2>&1 &
pids+=($!)
up=""
for _ in $(seq 60); do
  state=$(sinfo -h -N -o %T 2>/dev/null | head -n 1)
  case "$state" in idle*|mixed*|allocated*) up=1; break ;; esac
  sleep 0.5
done
[ -n "$up" ] || { show_logs; skip "slurmctld/slurmd did not bring the node up (state '${state:-none}')"; }
echo "cluster up: node retimegs-node, $cpus CPUs, ports $port-$((port + 1))"

# A 13-frame scene trained on frames 0, 2, ..., 12: three windows of two intervals.
scene=${SLURM_TEST_SCENE:-$tmp/scene}
windows=${SLURM_TEST_WINDOWS:-3}
if [ -z "${SLURM_TEST_SCENE:-}" ]; then
  "$binary" synth --preset minimal --cameras 3 --frames 13 --size 48x32 --out "$scene" \
    >"$tmp/synth.log" 2>&1 || fail "synth"
fi
start=$(date +%s.%N)
"$binary" slurm --scene "$scene" --out "$run" --windows "$windows" \
  --iters "${SLURM_TEST_ITERS:-150}" --cap "${SLURM_TEST_CAP:-5000}" \
  --sbatch-arg=--cpus-per-task="${SLURM_TEST_CPUS:-1}" --sbatch-arg=--partition=test --submit \
  >"$tmp/submit.log" 2>&1 ||
  fail "retimegs slurm --submit: $(cat "$tmp/submit.log")"
train_job=$(awk '$1 == "train" {print $2}' "$tmp/submit.log")
merge_job=$(awk '$1 == "merge" {print $2}' "$tmp/submit.log")
[ -n "$train_job" ] && [ -n "$merge_job" ] || fail "no job ids printed: $(cat "$tmp/submit.log")"
echo "submitted: train array $train_job, merge $merge_job"
scontrol show job "$merge_job" | grep -q "Dependency=afterok:${train_job}" ||
  fail "merge job $merge_job does not depend on afterok:$train_job"

deadline=$(($(date +%s) + timeout_s))
while squeue -h -j "$train_job,$merge_job" 2>/dev/null | grep -q .; do
  if squeue -h -j "$merge_job" -o %r 2>/dev/null | grep -q DependencyNeverSatisfied; then
    fail "a window's task failed (the merge waits for nothing)"
  fi
  [ "$(date +%s)" -lt "$deadline" ] || fail "jobs still queued or running after ${timeout_s} s"
  sleep 1
done

model="$run/model.rgs"
[ -f "$model" ] || fail "the merge job wrote no $model"
end=$(stat -c %.9Y "$model")  # when the merged model appeared
for k in $(seq 0 $((windows - 1))); do
  [ -f "$run/windows/$k/model.rgs" ] || fail "window $k wrote no model"
  [ -f "$run/slurm/logs/train_${train_job}_$k.out" ] || fail "window $k left no log"
done
[ -f "$run/slurm/logs/merge_${merge_job}.out" ] || fail "the merge left no log"
# A command would run in the job's working folder (the submitting one) or the daemons'.
pwned=$( (find "$tmp" -name 'PWNED*'; find "$PWD" / /tmp -maxdepth 1 -name 'PWNED*') 2>/dev/null)
[ -z "$pwned" ] || fail "a part of the run folder's name ran as a command: $pwned"
# The merged model covers the whole clip: eval scores it on the held-out odd frames (about 20 dB
# after 150 iterations per window; a model that lost a window scores far less).
"$binary" eval --scene "$scene" --model "$model" --out "$tmp/metrics.json" >"$tmp/eval.log" 2>&1 ||
  fail "eval of the merged model: $(tail -n 3 "$tmp/eval.log")"
psnr=$(sed -n 's/^  "psnr": \([0-9.]*\),$/\1/p' "$tmp/metrics.json")  # the mean over every view
awk -v p="$psnr" 'BEGIN { exit !(p > 18) }' || fail "merged model's held-out PSNR is '$psnr'"
# Scheduler overhead: submit to merged model, minus the span in which windows trained (first
# task's start to last task's end, as window.sh logs them).
span=$(cat "$run"/slurm/logs/train_*.out | awk '$4 == "start" {if (!s || $5 < s) s = $5}
  $4 == "end" {if ($5 > e) e = $5} END {printf "%.3f %.3f", s, e}')
read -r first_start last_end <<<"$span"
awk -v a="$start" -v b="$end" -v s="$first_start" -v e="$last_end" -v p="$psnr" 'BEGIN {
  printf "merged model: held-out PSNR %s dB; submit to merged model %.1f s, windows training %.1f s, scheduler overhead %.1f s (submit to first task %.1f s, last task to merged model %.1f s)\n",
    p, b - a, e - s, (b - a) - (e - s), s - a, b - e }'
if [ -n "${SLURM_TEST_KEEP:-}" ]; then
  cp "$tmp/metrics.json" "$run/metrics.json" && mv "$run" "$SLURM_TEST_KEEP"
fi
echo "PASSED"
