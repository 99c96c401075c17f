#!/usr/bin/env bash
# The point LOD as the reference renderer for point scans (issue 16,
# docs/benchmarks.md "The seed systems"), in one go:
# 1. Is the point reference faithful? Simulated scans of bundled meshes
#    (`apo simulate-scan`: 8 views of 200 x 200 rays, noise 0.05% of the
#    diagonal), each point given the mesh's interpolated normal at its
#    closest point (bench/interpolated_normals.py: the field the mesh's
#    render shows), drawn as M by `apo render` through the point LOD at its
#    default threshold and at coarser ones, and as every point's disc
#    (--no-point-lod, the reference before), each against the render of the
#    mesh they were sampled from: mean angle of the normals on pixels both
#    cover, and silhouette mismatch (pixels covered by one of them / by
#    either), 14 views at 512 px.
# 2. What the LOD costs and saves: on the same renders and on real point
#    scans, primitives sent (patches or points), primitives drawn (surfels
#    emitted), ms per frame of the reference pass, and the angle between
#    the LOD's normals and every point's.
# 3. The run's figures on the real point scans the issue names (kitten,
#    table_scene_lms400, bun0) with the LOD reference and with the old one:
#    the APO's and m's mean angle against the reference and the silhouette
#    mismatch.
# Usage (after the README's setup and build):
#   bash bench/point_lod.sh [OUTDIR]
# Prints markdown tables. Takes about 15 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/point_lod}
mkdir -p "$out"
: >"$out/log.txt"
apo=build/apo

run() { "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; exit 1; }; }
json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }
render() {  # APO m DETAIL OUT [options]
  local apo_file=$1 m=$2 detail=$3 dir=$4
  shift 4
  run $apo -q render --apo "$apo_file" --coarse "$m" --detail "$detail" --size 512 --frames 3 --filter -o "$dir" "$@"
}
# Mean angle and silhouette mismatch between two renders' reference normals.
compare() {
  /usr/bin/python3 - "$1" "$2" <<'EOF'
import sys, glob, os
import numpy as np
def pfm(path):
    with open(path, 'rb') as f:
        assert f.readline().strip() == b'PF'
        w, h = map(int, f.readline().split()); f.readline()
        return np.fromfile(f, '<f4').reshape(h, w, 3)
angles, one, either = [], 0, 0
for a in sorted(glob.glob(os.path.join(sys.argv[1], 'view*_reference_normals.pfm'))):
    A = pfm(a); B = pfm(os.path.join(sys.argv[2], os.path.basename(a)))
    ca = np.linalg.norm(A, axis=2) > 0.5; cb = np.linalg.norm(B, axis=2) > 0.5
    both = ca & cb; one += int((ca ^ cb).sum()); either += int((ca | cb).sum())
    x, y = A[both], B[both]
    angles.append(np.degrees(np.arctan2(np.linalg.norm(np.cross(x, y), axis=1), (x * y).sum(1))))
a = np.concatenate(angles)
print(f'{a.mean():.3f} {100.0 * one / max(either, 1):.1f}%')
EOF
}
cost() { json "$1/render.json" "'%d | %.0f | %.1f' % (j['overall']['cost']['reference_primitives']['sent'], j['overall']['cost']['reference_primitives']['drawn'], j['overall']['cost']['reference_frame_ms'])"; }

echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty)"
echo
echo "Simulated scans against the mesh they were sampled from (14 views, 512 px):"
echo
echo "| mesh | points | reference | angle to the mesh's render, mean deg | silhouette mismatch | sent | drawn (mean per view) | ms per frame |"
echo "|---|---|---|---|---|---|---|---|"
for mesh in bunny00 armadillo elephant; do
  input=datasets/cgal/meshes/$mesh.off
  [ -f "$input" ] || continue
  dir="$out/sim_$mesh"
  run $apo -q run "$input" -o "$dir/run" --no-export
  run $apo -q simulate-scan "$input" -o "$dir/raw.ply"
  run /usr/bin/python3 bench/interpolated_normals.py "$input" "$dir/raw.ply" "$dir/scan.ply"
  points=$(head -c 400 "$dir/scan.ply" | grep -a "element vertex" | awk '{print $3}')
  render "$dir/run/scan.apo" "$dir/run/m.ply" "$input" "$dir/mesh"
  for threshold in 0.01 0.1 0.5; do
    render "$dir/run/scan.apo" "$dir/run/m.ply" "$dir/scan.ply" "$dir/lod_$threshold" --lod-threshold $threshold
    read -r angle mismatch < <(compare "$dir/lod_$threshold" "$dir/mesh")
    echo "| $mesh | $points | point LOD, --lod-threshold $threshold | $angle | $mismatch | $(cost "$dir/lod_$threshold") |"
  done
  render "$dir/run/scan.apo" "$dir/run/m.ply" "$dir/scan.ply" "$dir/all" --no-point-lod
  read -r angle mismatch < <(compare "$dir/all" "$dir/mesh")
  echo "| $mesh | $points | every point's disc (before) | $angle | $mismatch | $(cost "$dir/all") |"
  echo "| $mesh | | the mesh | | | $(cost "$dir/mesh") |"
done
echo
echo "Real point scans: the run's figures with each reference (APO and m against the reference, 512 px, 14 views):"
echo
echo "| scan | reference | APO mean deg | m mean deg | APO silhouette mismatch | sent | drawn (mean per view) | ms per frame | LOD against every point's disc, mean deg |"
echo "|---|---|---|---|---|---|---|---|---|"
for scan in datasets/cgal/points_3/kitten.xyz datasets/pcl/table_scene_lms400.pcd datasets/pcl/bun0.pcd; do
  name=$(basename "${scan%.*}")
  dir="$out/real_$name"
  run $apo -q run "$scan" -o "$dir/lod" --no-export --detail-source points
  run $apo -q run "$scan" -o "$dir/all" --no-export --detail-source points --no-point-lod
  cmp -s "$dir/lod/scan.apo" "$dir/all/scan.apo" || { echo "FAILED: $name: the two runs baked different APOs" >&2; exit 1; }
  read -r angle mismatch < <(compare "$dir/lod/render" "$dir/all/render")
  for reference in lod all; do
    r="$dir/$reference/render/render.json"
    label=$([ $reference = lod ] && echo "point LOD" || echo "every point's disc (before)")
    figures=$(json "$r" "'%.3f | %.3f | %.1f%%' % (j['overall']['apo']['mean'], j['overall']['baseline']['mean'], 100 * j['overall']['apo_image']['silhouette_mismatch'])")
    echo "| $name | $label | $figures | $(cost "$dir/$reference/render") | $([ $reference = lod ] && echo "$angle" || echo "") |"
  done
done
