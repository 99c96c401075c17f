#!/usr/bin/env bash
# One scan's run split as `apo slurm SCAN --tasks N` splits it (docs/cluster.md,
# "One scan across tasks"), its parts run here one after another, against
# the same run whole: each part's wall seconds and peak memory (GNU time),
# the split's total against the whole run's, and whether the outputs are the
# same bytes. On the 10M-point bunny scan of bench/big_scans.sh (noise and
# misregistration on), --all-points --detail-source points --max-scan-points
# 2000000, as bench/every_point.sh runs it. Prints the table of
# docs/benchmarks.md, "One scan across tasks".
# Usage (after the README's build): [TASKS=4] bash bench/split_scan.sh   (about 10 minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
tasks=${TASKS:-4}
scan=build/bench_data/bunny-10M.ply
# As bench/big_scans.sh makes it: 8 views of r x r rays hit bunny00 about 26% of the time.
rays=$(python3 -c "import math; print(round(math.sqrt(10e6 / 8 / 0.2606)))")
mkdir -p build/bench_data
[ -f "$scan" ] || build/apo -q simulate-scan datasets/cgal/meshes/bunny00.off --views 8 --rays "$rays" -o "$scan"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
options=(--max-scan-points 2000000 --detail-source points --all-points)
echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty), $tasks tasks a pass, load $(uptime | sed 's/.*average: //')"
# Runs apo run with --split $1 into $out/split; prints "seconds peak_MiB".
part() {
  /usr/bin/time -f '%e %M' -o "$out/time" build/apo -q run "$scan" -o "$out/split" "${options[@]}" --split "$1" >/dev/null
  awk '{printf "%s %d\n", $1, $2 / 1024}' "$out/time"
}
/usr/bin/time -f '%e %M' -o "$out/time" build/apo -q run "$scan" -o "$out/whole" "${options[@]}" >/dev/null
read -r whole_s whole_mib < <(awk '{printf "%s %d\n", $1, $2 / 1024}' "$out/time")
printf '| part | tasks | seconds: each task (sum) | peak MiB, largest task |\n|---|---|---|---|\n'
printf '| the run whole | 1 | %s | %s |\n' "$whole_s" "$whole_mib"
total=0
read -r s mib < <(part prepare)
printf '| prepare: ingest, the store, M, m | 1 | %s | %s |\n' "$s" "$mib"
total=$(python3 -c "print($total + $s)")
for pass in areas records samples; do
  seconds=() peak=0 sum=0
  for ((t = 0; t < tasks; t++)); do
    read -r s mib < <(part "$pass:$t/$tasks")
    seconds+=("$s")
    peak=$((mib > peak ? mib : peak))
    sum=$(python3 -c "print(round($sum + $s, 2))")
  done
  printf '| %s | %d | %s (%s) | %s |\n' "$pass" "$tasks" "$(printf '%s / ' "${seconds[@]}" | sed 's| / $||')" "$sum" "$peak"
  total=$(python3 -c "print($total + $sum)")
done
read -r s mib < <(part merge)
printf '| merge: the bake read back, render, export, report | 1 | %s | %s |\n' "$s" "$mib"
total=$(python3 -c "print(round($total + $s, 1))")
python3 - "$out" "$whole_s" "$total" <<'PY'
import hashlib, json, pathlib, sys
out, whole_s, total = pathlib.Path(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
same = [n for n in ("M.ply", "m.ply", "scan.apo", "texture.png", "asset.glb")
        if hashlib.sha256((out / "whole" / n).read_bytes()).digest() == hashlib.sha256((out / "split" / n).read_bytes()).digest()]
journal = json.loads((out / "split" / "manifest.json").read_text())["results"]["bake"]["bricks"]["journal"]
print(f"\nsplit parts in all {total} s against {whole_s} s whole ({total / whole_s:.2f}x); "
      f"the merge read back {journal['entries_reused']} entries and wrote {journal['entries_written']}; "
      f"the same bytes: {', '.join(same) or 'none'}")
PY
