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
# Also, at equal bytes: the APO baked with --budget set to the default GLB's
# bytes; and rendered: the three.js check's figures against OSMesa's render
# of M (tests/export/threejs_check.py: 14 views of 256 px, --no-mipmap, the
# map's base level), the GLB as three.js draws it beside the APO as apo draws
# it, on the same pixels.
# Usage (after the README's setup and build):
#   bash bench/export_bench.sh [OUTDIR [MESH]]     (MESH: bunny00 by default)
# Prints a markdown table for docs/benchmarks.md. Takes about 4 minutes on
# bunny00.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/export}
mesh=${2:-datasets/cgal/meshes/bunny00.off}
mkdir -p "$out"
: >"$out/log.txt"
apo=build/apo
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
# Every patch at one density (--patch-size uniform): what sizing by detail gains.
glb="$out/uniform_1024.glb"
run $apo -q export "$out/run" -o "$glb" --patch-size uniform
eval_with "$glb" "/usr/bin/python3 $tools/glb_lookup.py {apo} {points} {out}" "$glb.json"
echo "| GLB, 1024^2, gutter 2, uniform patches (--patch-size uniform) | $(stat -c %s "$glb") | | | $(stats "$glb.json") |"
# The same patches filled straight from M (--source detail): what the APO costs.
for size in 1024 2048; do
  glb="$out/detail_${size}.glb"
  run $apo -q export "$out/run" -o "$glb" --map-size $size --source detail --detail "$mesh"
  eval_with "$glb" "/usr/bin/python3 $tools/glb_lookup.py {apo} {points} {out}" "$glb.json"
  echo "| GLB from M itself (--source detail), ${size}^2, gutter 2 | $(stat -c %s "$glb") | | | $(stats "$glb.json") |"
done
# The APO at the default GLB's bytes (--budget), on the same judge.
glb_bytes=$(stat -c %s "$out/g2_1024.glb")
run $apo -q run "$mesh" -o "$out/run_equal" --no-export --budget "$glb_bytes"
run /usr/bin/python3 $tools/normal_eval.py "$mesh" "$out/run_equal/m.ply" --apo "$out/run_equal/scan.apo" \
  --apo-lookup "$apo -q lookup {apo} {points} -o {out} --filter --coarse $out/run_equal/m.ply" --json "$out/apo_equal.json"
echo "| the APO at the default GLB's bytes (--budget $glb_bytes) | $(stat -c %s "$out/run_equal/scan.apo") | | | $(stats "$out/apo_equal.json") |"
echo
# Rendered: three.js drawing the GLB and apo drawing the APO, each against M.
python3 tests/export/threejs_check.py $apo "$mesh" "$out/threejs" --faces 3000 >"$out/threejs.json" 2>>"$out/log.txt" ||
  { echo "FAILED: threejs_check.py (see $out/log.txt)" >&2; exit 1; }
json "$out/threejs.json" "'rendered against M (14 views, 256 px, base level, %d pixels): GLB in three.js %.3f, APO in apo %.3f, m alone %.3f; Draco GLB %.3f; GLB against the APO %.3f' % (j['against_M']['pixels'], j['against_M']['glb_mean_degrees'], j['against_M']['apo_mean_degrees'], j['against_M']['m_mean_degrees'], j['draco']['against_M']['glb_mean_degrees'], j['mean_degrees'])"
