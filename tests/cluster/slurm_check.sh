#!/usr/bin/env bash
# `apo slurm` on a real one-node Slurm cluster, run by the installed package
# (docs/cluster.md, "The test"):
# 1. packages the build (cpack: apo_VERSION_ARCH.deb), installs it with
#    apt-get, checks `apo --version`, a small `apo run` and an ingest that
#    loads PCL's module (apo-pcl.so), from /usr/bin/apo;
# 2. starts munged, slurmctld and slurmd in a temporary folder (a one-node
#    cluster, proctrack/linuxproc, no cgroups, ports chosen free);
# 3. a folder of 4 small scans, one of them broken: `apo batch` on one
#    machine as the reference, then `apo slurm --tasks 3` (a job array and a
#    merge job after it), waited for; checks that the merged index lists every
#    scan, that the broken scan is reported once, and that every scan's
#    outputs are byte-identical to the reference's;
# 4. again, cancelling one task as it runs (scancel) and requeueing it
#    (scontrol requeue): the same checks, the same bytes;
# 5. one scan split across the tasks (`apo slurm SCAN --tasks 3`: a prepare
#    job, the bake's three passes as job arrays, a merge), a task of the
#    last pass cancelled and requeued: the one-machine run's bytes;
# 6. prints the measured times (submission to merged index, each task's own
#    seconds, the one-machine batch's) for docs/cluster.md.
# Every daemon it started is stopped by process id, the package removed, the
# folder deleted, whatever happens.
# Usage (as root, after setup.sh and the build): tests/cluster/slurm_check.sh BUILD_DIR
set -euo pipefail
build=$(realpath "$1")
source_dir=$(realpath "$(dirname "$0")/../..")
work=$(mktemp -d /tmp/apo-slurm-check.XXXXXX)
chmod 755 "$work"  # munged checks the folders above its socket
pids=()
installed=no

say() { echo "slurm_check: $*"; }
fail() { echo "slurm_check: FAILED: $*" >&2; exit 1; }

cleanup() {
  local status=$?
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null || true
  done
  if [ "$installed" = yes ]; then
    DEBIAN_FRONTEND=noninteractive apt-get remove -y -q apo >"$work/remove.log" 2>&1 || cat "$work/remove.log" >&2
    for file in /usr/bin/apo /usr/lib/apo/apo-engine /usr/lib/apo/apo-pcl.so; do
      if [ -e $file ]; then echo "slurm_check: FAILED: $file left after apt-get remove" >&2; status=1; fi
    done
  fi
  if [ $status -ne 0 ]; then
    for log in "$work"/*.log "$work"/out*/slurm/*.log; do
      [ -f "$log" ] && { echo "== $log"; tail -n 20 "$log"; } >&2
    done
  fi
  rm -rf "$work"
  exit $status
}
trap cleanup EXIT

if [ "$(id -u)" -ne 0 ]; then
  echo "slurm_check: skipped: run as root (it installs the package and starts Slurm's daemons)"
  exit 77  # ctest's SKIP_RETURN_CODE; CI runs as root
fi
for tool in cpack munged mungekey slurmctld slurmd sbatch squeue scontrol scancel; do
  command -v "$tool" >/dev/null || fail "$tool not found: run setup.sh (slurm-wlm, munge, dpkg-dev)"
done

# ---- 1. The package ---------------------------------------------------------
(cd "$build" && cpack -G DEB -B "$work/package" >"$work/cpack.log" 2>&1) || fail "cpack (see $work/cpack.log)"
deb=$(ls "$work"/package/apo_*.deb)
say "package $(basename "$deb"): $(dpkg-deb -f "$deb" Depends)"
DEBIAN_FRONTEND=noninteractive apt-get install -y -q "$deb" >"$work/install.log" 2>&1 || fail "apt-get install $deb"
installed=yes
apo=/usr/bin/apo
version=$($apo --version)
[ "$version" = "$(sed -n 's/^project(apo VERSION \([0-9.]*\).*/\1/p' "$source_dir/CMakeLists.txt")" ] ||
  fail "the installed apo says version '$version'"
quick=(--faces 300 --size 64 --views 2 --frames 1 --map-size 128)
$apo -q run "$source_dir/tests/golden/input.ply" -o "$work/installed_run" "${quick[@]}" || fail "apo run from the package"
[ -f "$work/installed_run/report.html" ] || fail "the package's apo run wrote no report"
# PCL's module (loaded from beside the engine, adapters/pcl/pcl_module.h):
# outlier removal and the normals' neighbour search on a simulated scan.
$apo -q simulate-scan "$source_dir/tests/golden/input.ply" -o "$work/points.ply" --views 2 --rays 60 ||
  fail "apo simulate-scan from the package"
$apo -q ingest "$work/points.ply" -o "$work/installed_ingest" --remove-outliers ||
  fail "apo ingest --remove-outliers from the package (PCL's module /usr/lib/apo/apo-pcl.so)"
say "installed: /usr/bin/apo $version runs"

# ---- 2. A one-node cluster ----------------------------------------------------
free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
host=$(hostname -s)
mkdir -p "$work/munge" "$work/state" "$work/spool"
chmod 700 "$work/munge"
mungekey -c -k "$work/munge/munge.key" >/dev/null 2>&1
munged -F -f --key-file="$work/munge/munge.key" --socket="$work/munge/munge.socket" \
  --pid-file="$work/munge/munged.pid" --log-file="$work/munged.log" --seed-file="$work/munge/munged.seed" \
  >"$work/munged.out" 2>&1 &
pids+=($!)
cat >"$work/slurm.conf" <<CONF
ClusterName=apocheck
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=apo Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF=$work/slurm.conf
for _ in $(seq 50); do [ -S "$work/munge/munge.socket" ] && break; sleep 0.1; done
slurmctld -D -f "$SLURM_CONF" >"$work/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" >"$work/slurmd.out" 2>&1 &
pids+=($!)
for _ in $(seq 100); do sinfo -h -o %t 2>/dev/null | grep -q idle && break; sleep 0.2; done
sinfo -h -o %t | grep -q idle || fail "the node did not come up: $(sinfo 2>&1)"
say "one-node cluster up on $host ($(nproc) CPUs)"

# ---- 3. A batch on the array ----------------------------------------------------
scans=$work/scans
mkdir -p "$scans/lab 1" "$scans/site b"
cp "$source_dir/tests/golden/input.ply" "$scans/a.ply"
cp "$source_dir/datasets/cgal/meshes/blob.off" "$scans/lab 1/blob.off"
# Named so that each of the 3 tasks gets a scan (shards 1, 0 and 2; broken.ply 0).
cp "$source_dir/datasets/cgal/meshes/anchor.off" "$scans/site b/anchor.off"
printf 'ply\nformat ascii 1.0\nelement vertex 99999999999\nend_header\n1 2\n' >"$scans/broken.ply"
count=$(find "$scans" -type f | wc -l)

start=$(date +%s.%N)
$apo -q batch "$scans" -o "$work/reference" "${quick[@]}" && fail "the reference batch ignored the broken scan"
one_machine=$(python3 -c "import time; print(f'{time.time() - $start:.1f}')")

# Waits for a job to leave the queue; prints its final state.
wait_for() {
  local job=$1
  for _ in $(seq 1500); do
    if ! squeue -h -j "$job" 2>/dev/null | grep -q .; then
      scontrol show job "$job" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -n 1
      return
    fi
    sleep 0.2
  done
  fail "job $job still queued after 300 s: $(squeue)"
}

# Slurm holds a requeued job back two minutes (its BeginTime); an update
# made before the requeue has settled can be lost, so it is made again
# until the job no longer waits for its BeginTime.
start_now() {
  local job=$1
  for _ in $(seq 50); do
    scontrol update JobId="$job" StartTime=now >/dev/null 2>&1 || true
    squeue -h -j "$job" -t PENDING -o %r 2>/dev/null | grep -q BeginTime || return 0
    sleep 0.2
  done
}

# Cancels a task of array job $1 as it runs and requeues it; job $2, which
# waits on the array (afterany), is held until the requeued task has run
# again: Slurm counts the cancelled task as ended, and a job released
# before the task's second run ends could start without its work. $3:
# seconds to let the task work first. Sets `victim`.
requeue_a_running_task() {
  local array=$1 held=$2 settle=$3
  scontrol hold "$held"
  victim=
  for _ in $(seq 3000); do
    victim=$(squeue -h -r -j "$array" -t RUNNING -o %i | head -n 1)
    [ -n "$victim" ] && break
    sleep 0.02
  done
  [ -n "$victim" ] || fail "no task of job $array was seen running"
  sleep "$settle"
  scancel "$victim"
  for _ in $(seq 100); do squeue -h -j "$victim" -t RUNNING | grep -q . || break; sleep 0.1; done
  scontrol requeue "$victim" || fail "scontrol requeue $victim"
  start_now "$victim"
  for _ in $(seq 1500); do squeue -h -j "$victim" 2>/dev/null | grep -q . || break; sleep 0.2; done
  scontrol release "$held"
}

# The merged outputs against the reference: every scan listed, the broken one
# reported once, every scan's outputs byte-identical.
check_outputs() {
  local out=$1
  python3 - "$out" "$work/reference" "$count" <<'PY' || fail "$out differs from the one-machine batch"
import hashlib, json, pathlib, sys
out, reference, count = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]), int(sys.argv[3])
summary = json.loads((out / "summary.json").read_text())
problems = []
if (summary["scans"], summary["succeeded"], summary["failed"]) != (count, count - 1, 1):
    problems.append(f"summary {summary['scans']} scans, {summary['succeeded']} succeeded, {summary['failed']} failed")
index = (out / "index.html").read_text()
for name in ("a.ply", "blob.off", "anchor.off", "broken.ply"):
    if name not in index:
        problems.append(f"index.html does not list {name}")
shards = sorted(p.name for p in (out / ".apo-shards").glob("*.json"))
if shards != ["0-of-3.json", "1-of-3.json", "2-of-3.json"]:
    problems.append(f"shard summaries {shards}, not one per task")
if index.count("FAILED") != 1:
    problems.append(f"index.html reports {index.count('FAILED')} failures, not the broken scan once")
digest = lambda p: hashlib.sha256(p.read_bytes()).hexdigest()
compared = 0
for manifest in reference.rglob("manifest.json"):
    scan = manifest.parent.relative_to(reference)
    if json.loads(manifest.read_text())["status"] != "succeeded":
        continue
    for name in ("m.ply", "scan.apo", "texture.png", "asset.glb", "viewer.html"):
        a, b = reference / scan / name, out / scan / name
        compared += 1
        if not b.exists() or digest(a) != digest(b):
            problems.append(f"{scan}/{name} differs from the one-machine batch")
print(f"slurm_check: {out.name}: {summary['scans']} scans listed, 1 failure reported, {compared} outputs byte-identical")
sys.exit("\n".join(problems) if problems else 0)
PY
}

submit() {  # OUTDIR: submits; sets array and merge
  local line
  line=$($apo -q slurm "$scans" -o "$1" --tasks 3 "${quick[@]}") || fail "apo slurm: $line"
  array=$(echo "$line" | sed -n 's/^array job \([0-9]*\) .*merge job \([0-9]*\);.*/\1/p')
  merge=$(echo "$line" | sed -n 's/^array job \([0-9]*\) .*merge job \([0-9]*\);.*/\2/p')
  [ -n "$array" ] && [ -n "$merge" ] || fail "apo slurm printed no job ids: $line"
}

start=$(date +%s.%N)
submit "$work/out"
state=$(wait_for "$merge")
[ "$state" = COMPLETED ] || [ "$state" = FAILED ] || fail "the merge job ended $state"
on_cluster=$(python3 -c "import time; print(f'{time.time() - $start:.1f}')")
check_outputs "$work/out"
tasks=$(python3 -c "
import json, pathlib
for p in sorted(pathlib.Path('$work/out/.apo-shards').glob('*.json')):
    s = json.loads(p.read_text()); print(f\"shard {s['shard']}: {s['scans']} scan{'s' if s['scans'] != 1 else ''} in {s['seconds']:.1f} s\")")
# Slurm's own clock (whole seconds): when each job was submitted, started, ended.
timeline=$( (scontrol -o show job "$array"; scontrol -o show job "$merge") | python3 -c "
import re, sys
from datetime import datetime
jobs = [dict(re.findall(r'(\w+)=(\S+)', line)) for line in sys.stdin if line.strip()]
t = lambda j, k: datetime.fromisoformat(j[k]).timestamp()
t0 = min(t(j, 'SubmitTime') for j in jobs)
for j in sorted(jobs, key=lambda j: t(j, 'StartTime')):
    name = 'task ' + j['ArrayTaskId'] if 'ArrayTaskId' in j else 'merge'
    print(f\"{name} started +{t(j, 'StartTime') - t0:.0f} s, ended +{t(j, 'EndTime') - t0:.0f} s\")")
say "measured: one machine $one_machine s; on the cluster, submission to merged index $on_cluster s"
say "apo's own time per task: $(echo "$tasks" | paste -sd ';' -)"
say "Slurm's timeline: $(echo "$timeline" | paste -sd ';' -)"

# ---- 4. A task cancelled as it runs, then requeued -----------------------------
start=$(date +%s.%N)
submit "$work/out_requeued"
requeue_a_running_task "$array" "$merge" 0.5
state=$(wait_for "$merge")
[ "$state" = COMPLETED ] || [ "$state" = FAILED ] || fail "the merge job after the requeue ended $state"
restarts=$(scontrol show job "$victim" | sed -n 's/.*Restarts=\([0-9]*\).*/\1/p')
[ "${restarts:-0}" -ge 1 ] || fail "task $victim was not restarted"
check_outputs "$work/out_requeued"
with_requeue=$(python3 -c "import time; print(f'{time.time() - $start:.1f}')")
say "task $victim cancelled as it ran and requeued ($restarts restart): the same bytes; submission to merged index $with_requeue s"
# ---- 5. One scan's bake across the tasks ----------------------------------------
# `apo slurm SCAN --tasks 3`: a prepare job, the bake's three passes as job
# arrays, a merge; a task of the last pass cancelled as it runs and
# requeued. The merge must read every brick's work back from the journal
# and write the one-machine run's bytes.
$apo -q simulate-scan "$source_dir/datasets/cgal/meshes/blob.off" -o "$work/big.ply" --views 6 --rays 120 ||
  fail "apo simulate-scan for the split scan"
split=(--max-scan-points 5000 --all-points --detail-source points)
start=$(date +%s.%N)
$apo -q run "$work/big.ply" -o "$work/split_reference" "${quick[@]}" "${split[@]}" || fail "the one-machine run of big.ply"
one_machine=$(python3 -c "import time; print(f'{time.time() - $start:.1f}')")
start=$(date +%s.%N)
line=$($apo -q slurm "$work/big.ply" -o "$work/split" --tasks 3 "${quick[@]}" "${split[@]}") || fail "apo slurm big.ply: $line"
read -r samples merge < <(echo "$line" | sed -n 's/^prepare job [0-9]*, pass jobs [0-9]* [0-9]* \([0-9]*\) .*merge job \([0-9]*\);.*/\1 \2/p')
[ -n "$samples" ] && [ -n "$merge" ] || fail "apo slurm on one scan printed no job ids: $line"
requeue_a_running_task "$samples" "$merge" 0
state=$(wait_for "$merge")
[ "$state" = COMPLETED ] || fail "the split scan's merge job ended $state"
restarts=$(scontrol show job "$victim" | sed -n 's/.*Restarts=\([0-9]*\).*/\1/p')
[ "${restarts:-0}" -ge 1 ] || fail "task $victim was not restarted"
on_cluster=$(python3 -c "import time; print(f'{time.time() - $start:.1f}')")
python3 - "$work/split" "$work/split_reference" <<'PY' || fail "the split scan differs from the one-machine run"
import hashlib, json, pathlib, sys
out, reference = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
manifest = json.loads((out / "manifest.json").read_text())
bricks = manifest["results"]["bake"]["bricks"]
problems = []
if manifest["status"] != "succeeded":
    problems.append(f"the merge's status is {manifest['status']}")
if bricks["journal"]["entries_written"] != 0 or bricks["journal"]["entries_reused"] == 0:
    problems.append(f"the merge did bricks' work itself: {bricks['journal']}")
if manifest.get("split", {}).get("prepared_stages") != ["ingest", "reconstruct", "simplify"]:
    problems.append(f"the merge did not take ingest, M and m from the prepare job: {manifest.get('split')}")
for name in ("m.ply", "M.ply", "scan.apo", "texture.png", "asset.glb"):
    a, b = reference / name, out / name
    if not b.exists() or hashlib.sha256(a.read_bytes()).digest() != hashlib.sha256(b.read_bytes()).digest():
        problems.append(f"{name} differs from the one-machine run")
logs = sorted(p.name for p in (out / "slurm").glob("*.log"))
if len([n for n in logs if n.startswith("samples-")]) != 3:
    problems.append(f"logs {logs}: not one per samples task")
print(f"slurm_check: split scan: {bricks['bricks']} bricks, {bricks['journal']['entries_reused']} journal entries read back by the merge, ingest, M and m from the prepare job, 5 outputs byte-identical")
sys.exit("\n".join(problems) if problems else 0)
PY
jobs=$(echo "$line" | sed -n 's/^prepare job \([0-9]*\), pass jobs \([0-9]*\) \([0-9]*\) \([0-9]*\) .*merge job \([0-9]*\);.*/\1 \2 \3 \4 \5/p')
timeline=$(for job in $jobs; do scontrol -o show job "$job"; done | python3 -c "
import re, sys
from datetime import datetime
jobs = [dict(re.findall(r'(\w+)=(\S+)', line)) for line in sys.stdin if line.strip()]
t = lambda j, k: datetime.fromisoformat(j[k]).timestamp()
t0 = min(t(j, 'SubmitTime') for j in jobs)
for j in sorted(jobs, key=lambda j: (t(j, 'StartTime'), j['JobId'])):
    name = j['JobName'] + ('.' + j['ArrayTaskId'] if 'ArrayTaskId' in j else '')
    print(f\"{name} +{t(j, 'StartTime') - t0:.0f}..+{t(j, 'EndTime') - t0:.0f} s\")")
say "one scan split across 3 tasks per pass, task $victim cancelled and requeued: the same bytes; one machine $one_machine s, submission to merged run $on_cluster s"
say "Slurm's timeline of the split scan: $(echo "$timeline" | paste -sd ';' -)"
say "passed"
