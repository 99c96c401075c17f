#!/usr/bin/env bash
# Noise against the byte budget (issue 14, section 1): does the budget spend
# its bytes on a scan's noise? bunny00 with Gaussian noise along the vertex
# normals (sigma 0.25 and 0.5 mean edge lengths, bench/noise_budget.py), baked
# onto the clean bunny's m (3,000 faces) at three budgets, from the noisy M
# and from the noisy M Taubin-smoothed (10 steps: M smoothed at a fixed
# scale), each judged by ../shared/tools/normal_eval.py (filtered lookup,
# 200,000 points on m) against the clean bunny (the surface the scan
# measured) and against the noisy M (what the bake was given).
# Usage (after the README's setup and build): bash bench/noise_budget.sh [OUTDIR]
# Prints a markdown table for docs/benchmarks.md. Takes about 10 minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/noise}
apo=build/apo
clean=datasets/cgal/meshes/bunny00.off
mkdir -p "$out"
: >"$out/log.txt"
run() { "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; exit 1; }; }
# "mean / p95" of the APO (or of m alone with no APO) against truth mesh $1.
judge() {
  local truth=$1 apo_file=${2:-} json=$out/eval.json
  if [ -n "$apo_file" ]; then
    run /usr/bin/python3 ../shared/tools/normal_eval.py "$truth" "$out/m/m.ply" --json "$json" --apo "$apo_file" \
      --apo-lookup "$apo -q lookup {apo} {points} -o {out} --filter --coarse $out/m/m.ply"
  else
    run /usr/bin/python3 ../shared/tools/normal_eval.py "$truth" "$out/m/m.ply" --json "$json" --baseline
  fi
  python3 -c "import json; s=json.load(open('$json'))['stats']; print('%.2f / %.2f' % (s['mean'], s['p95']))"
}

echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty)"
echo
run $apo -q simplify "$clean" -o "$out/m" --faces 3000
echo "| noise (mean edges) | baked from | budget | .apo bytes | against the clean bunny (mean / p95 deg) | against the noisy M (mean / p95 deg) |"
echo "|---|---|---|---|---|---|"
for sigma in 0.25 0.5; do
  noisy=$out/noisy_$sigma.ply smoothed=$out/smoothed_$sigma.ply
  run /usr/bin/python3 bench/noise_budget.py "$clean" "$sigma" "$noisy" "$smoothed"
  echo "| $sigma | m alone | | | $(judge "$clean") | $(judge "$noisy") |"
  for source in noisy smoothed; do
    for budget in 256KiB 1MiB 3MiB; do
      bake=$out/$source-$sigma-$budget
      run $apo -q bake --detail "$out/${source}_$sigma.ply" --coarse "$out/m/m.ply" -o "$bake" --budget "$budget"
      echo "| $sigma | $source M | $budget | $(stat -c %s "$bake/scan.apo") | $(judge "$clean" "$bake/scan.apo") | $(judge "$noisy" "$bake/scan.apo") |"
    done
  done
done
