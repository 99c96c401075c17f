#!/usr/bin/env bash
# The glTF export (issue 15): bunny00 onto 3,000 faces (`apo run` defaults),
# the APO itself and the exported GLB at several map sizes and gutters, each
# judged by the independent tools: ../shared/tools/normal_eval.py (200,000
# points on m by area, seed 1; truth: M's interpolated normal at the closest
# point of M), through `apo lookup --filter` for the APO and through
# ../shared/tools/glb_lookup.py (the glTF spec's decoding, as a viewer does)
# for the GLB. The peers on the same measure (docs/benchmarks.md): MeshLab's
# per-triangle transfer 0.337 degrees mean, Blender's object-space bake 0.48,
# both 1024 x 1024 (3 MB).
# Usage (after the README's setup and build): bash bench/export_bench.sh [OUTDIR]
# Prints a markdown table for docs/benchmarks.md. Takes about 3 minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/export}
mkdir -p "$out"
: >"$out/log.txt"
apo=build/apo
mesh=datasets/cgal/meshes/bunny00.off
tools=../shared/tools

run() { "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; exit 1; }; }
json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }
stats() { json "$1" "'%.3f / %.3f / %.3f' % (j['stats']['mean'], j['stats']['median'], j['stats']['p95'])"; }
eval_with() {  # FIELD LOOKUP_COMMAND OUT.json
  run /usr/bin/python3 $tools/normal_eval.py "$mesh" "$out/run/m.ply" --apo "$1" --apo-lookup "$2" --json "$3"
}

echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty)"
echo
run $apo -q run "$mesh" -o "$out/run" --no-export
run /usr/bin/python3 $tools/normal_eval.py "$mesh" "$out/run/m.ply" --baseline --json "$out/m.json"
eval_with "$out/run/scan.apo" "$apo -q lookup {apo} {points} -o {out} --filter --coarse $out/run/m.ply" "$out/apo.json"
apo_bytes=$(stat -c %s "$out/run/scan.apo")
echo "| field | bytes | texels in triangles | export seconds | degrees mean / median / p95 |"
echo "|---|---|---|---|---|"
echo "| m alone | | | | $(stats "$out/m.json") |"
echo "| the APO (filtered lookup), scan.apo | $apo_bytes | | | $(stats "$out/apo.json") |"
for gutter in 2 1; do
  for size in 1024 2048; do
    glb="$out/g${gutter}_${size}.glb"
    start=$(date +%s.%N)
    run $apo -q export "$out/run" -o "$glb" --map-size $size --gutter $gutter
    seconds=$(python3 -c "import sys; print('%.2f' % (float(sys.argv[2]) - float(sys.argv[1])))" "$start" "$(date +%s.%N)")
    eval_with "$glb" "/usr/bin/python3 $tools/glb_lookup.py {apo} {points} {out}" "$glb.json"
    share=$(python3 -c "
import json, struct, sys
b = open(sys.argv[1], 'rb').read(); n = struct.unpack_from('<I', b, 12)[0]
print('%.0f%%' % (100 * json.loads(b[20:20 + n])['asset']['extras']['apo']['used_share']))" "$glb")
    echo "| GLB, ${size}^2, gutter $gutter | $(stat -c %s "$glb") | $share | $seconds | $(stats "$glb.json") |"
  done
done
# The same patches filled straight from M (--source detail): what the APO costs.
for size in 1024 2048; do
  glb="$out/detail_${size}.glb"
  run $apo -q export "$out/run" -o "$glb" --map-size $size --source detail --detail "$mesh"
  eval_with "$glb" "/usr/bin/python3 $tools/glb_lookup.py {apo} {points} {out}" "$glb.json"
  echo "| GLB from M itself (--source detail), ${size}^2, gutter 2 | $(stat -c %s "$glb") | | | $(stats "$glb.json") |"
done
