#!/usr/bin/env bash
# Two-sided leaves (issue 14, section 3): meshes with thin parts (and
# bunny00 beside them) simplified to 3,000 faces, baked with the defaults and
# with --one-sided at 3 MiB and 256 KiB, judged by the independent
# ../shared/tools/normal_eval.py through `apo lookup --filter --coarse m.ply`
# (200,000 points on m, seed 1; truth: M's interpolated normal at M's
# closest point). Prints a markdown table for docs/benchmarks.md.
# Usage (after the README's setup and build): bash bench/two_sided_bench.sh [OUTDIR]
# Takes about 12 minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/two_sided}
mkdir -p "$out/bin"
: >"$out/log.txt"
cp build/apo build/apo-engine build/apo-pcl.so "$out/bin/"
apo=$out/bin/apo

run() { "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; exit 1; }; }
json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }
stats() { json "$1" "'%.3f / %.3f' % (j['stats']['mean'], j['stats']['p95'])"; }
# judge MESH M APO: "mean / p95" of the APO's filtered lookup.
judge() {
  run /usr/bin/python3 ../shared/tools/normal_eval.py "$1" "$2" \
    --apo-lookup "$apo -q lookup {apo} {points} -o {out} --filter --coarse $2" --apo "$3" --json "$3.eval.json"
  stats "$3.eval.json"
}

echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty)"
echo
echo "| mesh | budget | m alone mean / p95 | one-sided mean / p95 | two-sided mean / p95 | two-sided leaves |"
echo "|---|---|---|---|---|---|"
for budget in 3MiB 256KiB; do
  for name in blade camel armadillo turbine bunny00; do
    mesh=datasets/cgal/meshes/$name.off
    d=$out/$name
    if [ ! -f "$d/m/m.ply" ]; then
      run $apo -q simplify "$mesh" -o "$d/m" --faces 3000
      run /usr/bin/python3 ../shared/tools/normal_eval.py "$mesh" "$d/m/m.ply" --baseline --json "$d/m.eval.json"
    fi
    run $apo -q bake --detail "$mesh" --coarse "$d/m/m.ply" -o "$d/one_$budget" --budget "$budget" --one-sided
    run $apo -q bake --detail "$mesh" --coarse "$d/m/m.ply" -o "$d/two_$budget" --budget "$budget"
    echo "| $name.off | $budget | $(stats "$d/m.eval.json") | $(judge "$mesh" "$d/m/m.ply" "$d/one_$budget/scan.apo") |" \
      "$(judge "$mesh" "$d/m/m.ply" "$d/two_$budget/scan.apo") | $(json "$d/two_$budget/bake.json" "j['refinement']['two_sided_leaves']") |"
  done
done
