#!/usr/bin/env bash
# Proves the Slurm path of `speleo campaign` on this machine: brings up a
# one-node Slurm cluster (Debian's slurm-wlm and munge, installed if missing),
# plans a tiny campaign, runs it as a job array with the shipped
# deploy/slurm/campaign.sbatch, checks that every case left its outcome.json,
# and prints `speleo campaign report`. Run as root. Everything it starts
# (munged, slurmctld, slurmd) is private to a temporary folder, with its own
# munge key, socket and ports, and is stopped on exit; /etc/slurm and any
# system munged are left alone.
#
#   SPELEO        the binary (default target/release/speleo, built by
#                 `cargo build --release`)
#   SLURM_CI_KEEP set to 1 to keep the temporary folder (kept anyway on failure)
set -euo pipefail
cd "$(dirname "$0")/.."

start=$SECONDS
say() { echo "== slurm-campaign: $* ($((SECONDS - start)) s)"; }
die() { echo "slurm-campaign: $*" >&2; exit 1; }

speleo="${SPELEO:-target/release/speleo}"
if [[ "$speleo" == */* ]]; then
  [ -x "$speleo" ] || die "no speleo binary at $speleo (cargo build --release, or set SPELEO)"
  speleo="$(cd "$(dirname "$speleo")" && pwd)/$(basename "$speleo")"
else
  speleo="$(command -v "$speleo")" || die "$SPELEO is not on PATH"
fi
export SPELEO="$speleo"

# --- Slurm and munge from Debian -------------------------------------------
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
   || ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
  say "installing slurm-wlm and munge"
  log=$(mktemp)
  if ! { timeout 300 apt-get update -qq \
         && DEBIAN_FRONTEND=noninteractive timeout 600 apt-get install -y -qq \
              --no-install-recommends slurm-wlm munge; } >"$log" 2>&1; then
    tail -n 40 "$log" >&2
    die "apt-get failed"
  fi
  rm -f "$log"
fi

# --- a private one-node cluster --------------------------------------------
work=$(mktemp -d /tmp/speleo-slurm.XXXXXX)
pids=()
status=1
cleanup() {
  set +e
  # The cluster is private, so any job left in it is this script's.
  if [ ${#pids[@]} -ge 2 ] && [ -n "$(squeue -h 2>/dev/null)" ]; then
    scancel --partition=ci 2>/dev/null
    for _ in $(seq 20); do
      [ -z "$(squeue -h 2>/dev/null)" ] && break
      sleep 0.5
    done
  fi
  # slurmd, slurmctld, munged: the reverse of their start.
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
    kill "${pids[i]}" 2>/dev/null
  done
  for pid in "${pids[@]}"; do
    for _ in $(seq 20); do kill -0 "$pid" 2>/dev/null || break; sleep 0.25; done
    kill -9 "$pid" 2>/dev/null
  done
  if [ "$status" -ne 0 ]; then
    # Lines that every start prints here, whether it works or not, are left
    # out: the PMIx plugin's library is not installed, and a new cluster has
    # no saved state.
    for f in "$work"/log/*.log "$work"/campaign/slurm/*.out; do
      [ -f "$f" ] || continue
      echo "---- ${f#"$work"/} (last 25 lines)" >&2
      grep -vE 'pmix|MPI: Cannot create context|state file|NOTE: Trying backup|^munged: Info:' "$f" \
        | tail -n 25 >&2
    done
    echo "slurm-campaign: FAILED; everything is kept in $work" >&2
  elif [ "${SLURM_CI_KEEP:-0}" = 1 ]; then
    echo "slurm-campaign: kept $work"
  else
    rm -rf "$work"
  fi
}
trap 'status=$?; cleanup; exit $status' EXIT
trap 'exit 130' INT TERM

# munged wants every directory above its socket searchable by all, and its
# key readable by its own user only.
chmod 755 "$work"
mkdir -m 700 "$work/munge"
mkdir -p "$work/state" "$work/spool" "$work/log"
dd if=/dev/urandom of="$work/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$work/munge/munge.key"

host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(awk '/^MemTotal:/ { print int($2 / 1024) }' /proc/meminfo)
# Declared memory must not exceed what slurmd finds, or the node is drained;
# 2 GiB a CPU is what campaign.sbatch asks for.
real_mb=$(( mem_mb * 9 / 10 ))
if [ "$real_mb" -gt $(( cpus * 2048 )) ]; then real_mb=$(( cpus * 2048 )); fi
[ "$real_mb" -ge 2048 ] || die "this machine has ${mem_mb} MB of memory; a case asks for 2 GiB"

# What a one-node cluster without systemd needs here (Slurm 22.05):
# - ClusterName, SlurmctldHost, a node and a partition: slurmctld will not
#   start without them. Addresses are 127.0.0.1, whatever the host name
#   resolves to.
# - AuthInfo: the private munged's socket (cred/munge uses it too).
# - StateSaveLocation: slurmctld recovers whatever state it finds there (the
#   default is /var/spool), and stops at a state of another cluster name.
# - ProctrackType=proctrack/linuxproc: the default, proctrack/cgroup, cannot
#   start a job step without a usable cgroup setup; slurmd then drains the
#   node and the task leaves no output (sbatch --wait still exits 0).
# - RealMemory: the default is 1 MB, and campaign.sbatch asks for 2 GiB.
# - select/cons_tres with CR_Core: a task takes one CPU, not the whole node
#   (select/linear, the default), so cases run side by side.
# - Ports other than 6817/6818, and every file under $work, so that a
#   system Slurm or a previous run is not in the way; MailProg silences an
#   error about the absent default mail program.
export SLURM_CONF="$work/slurm.conf"
cat >"$SLURM_CONF" <<EOF
ClusterName=speleo-ci
SlurmctldHost=${host}(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$work/munge.sock
SlurmUser=root
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
MailProg=/bin/true
NodeName=${host} NodeAddr=127.0.0.1 CPUs=${cpus} RealMemory=${real_mb} State=UNKNOWN
PartitionName=ci Nodes=${host} Default=YES MaxTime=INFINITE State=UP
EOF


say "starting munged, slurmctld and slurmd on $host ($cpus CPUs)"
munged -F --key-file="$work/munge/munge.key" --socket="$work/munge.sock" \
  --pid-file="$work/munge/munged.pid" --seed-file="$work/munge/munged.seed" \
  >"$work/log/munged.log" 2>&1 &
pids+=($!)
for _ in $(seq 40); do [ -S "$work/munge.sock" ] && break; sleep 0.25; done
[ -S "$work/munge.sock" ] || die "munged did not start"
slurmctld -D -f "$SLURM_CONF" >"$work/log/slurmctld.log" 2>&1 &
pids+=($!)
slurmd -D -N "$host" -f "$SLURM_CONF" >"$work/log/slurmd.log" 2>&1 &
pids+=($!)

names=(munged slurmctld slurmd)
state=""
for _ in $(seq 120); do
  state=$(sinfo -h -n "$host" -o %T 2>/dev/null || true)
  [ "$state" = idle ] && break
  for i in "${!pids[@]}"; do
    kill -0 "${pids[i]}" 2>/dev/null || die "${names[i]} exited during start-up"
  done
  sleep 0.5
done
[ "$state" = idle ] || die "node $host is '${state:-unknown}', not idle, after 60 s"

# --- a tiny campaign through sbatch ----------------------------------------
say "planning a tiny campaign"
cat >"$work/matrix.toml" <<'EOF'
name = "tiny"
timeout_s = 300
[[group]]
worlds = ["flat"]
world_seeds = [1]
noise_seeds = [1, 2]
duration_s = 5
EOF
dir="$work/campaign"
"$speleo" campaign plan "$work/matrix.toml" --out "$dir" >/dev/null
n=$(sed -n 's/^case_count *= *//p' "$dir/manifest.toml")
[[ "$n" =~ ^[1-9][0-9]*$ ]] || die "no case_count in $dir/manifest.toml"
mkdir -p "$dir/slurm"

say "sbatch --wait --array=0-$((n - 1)) deploy/slurm/campaign.sbatch"
wait_s=900
rc=0
timeout "$wait_s" sbatch --wait --parsable --array=0-$((n - 1)) --time=00:10:00 \
  --output="$dir/slurm/%A_%a.out" deploy/slurm/campaign.sbatch "$dir" \
  >"$work/sbatch.out" 2>&1 || rc=$?
jobid=$(head -n 1 "$work/sbatch.out" | cut -d';' -f1)
[ "$rc" -ne 124 ] || die "the job array had not ended after $wait_s s"
[ "$rc" -eq 0 ] || { cat "$work/sbatch.out" >&2; die "sbatch exited with $rc"; }

# sbatch --wait exits 0, and the tasks may read COMPLETED, even when Slurm
# could not start them at all: what counts is each case's outcome.json and
# each task's output.
states=$(scontrol -o show job "$jobid" | grep -o 'JobState=[A-Z_]*' | sort | uniq -c | xargs || true)
[ "$states" = "$n JobState=COMPLETED" ] || die "job $jobid: expected $n tasks COMPLETED, got: $states"
missing=0
for ((k = 0; k < n; k++)); do
  case_dir=$(printf '%s/cases/%04d' "$dir" "$k")
  if [ ! -f "$case_dir/outcome.json" ]; then
    echo "slurm-campaign: case $k has no outcome.json" >&2
    missing=$((missing + 1))
  elif ! grep -q '"status": "ran"' "$case_dir/outcome.json"; then
    echo "slurm-campaign: case $k did not run its mission:" >&2
    cat "$case_dir/outcome.json" >&2
    missing=$((missing + 1))
  fi
  grep -qs "^campaign.sbatch: case $k of " "$dir/slurm/${jobid}_${k}.out" \
    || { echo "slurm-campaign: no Slurm output for case $k" >&2; missing=$((missing + 1)); }
done
[ "$missing" -eq 0 ] || die "$missing problem(s) with the cases' outputs"
say "all $n cases ran as Slurm array job $jobid"

"$speleo" campaign report "$dir"
say "passed"
