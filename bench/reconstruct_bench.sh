#!/usr/bin/env bash
# Reconstruction and simplification on the real datasets: seconds and peak
# memory of each `apo` method and of Open3D's equivalents, in one run.
# Usage (after the README's setup and build): bash bench/reconstruct_bench.sh [OUTDIR]
# Prints markdown tables for docs/benchmarks.md.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/reconstruct}
apo=build/apo
baseline=build/open3d_baseline
mkdir -p "$out"

# "seconds peak_MiB" of a command (its output goes to $out/log.txt).
measure() {
  /usr/bin/time -f "%e %M" -o "$out/time.txt" "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; echo "failed -"; return; }
  awk '{printf "%.2f %d\n", $1, $2 / 1024}' "$out/time.txt"
}

json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

declare -A inputs=(
  [kitten]=datasets/cgal/points_3/kitten.xyz
  [building]=datasets/cgal/points_3/building.ply
  [table_scene_lms400]=datasets/pcl/table_scene_lms400.pcd
  [bunny00]=datasets/cgal/meshes/bunny00.off
)

echo "| input | points | method | seconds | peak MiB | triangles | components | mean dist. / diag |"
echo "|---|---|---|---|---|---|---|---|"
for name in kitten building table_scene_lms400 bunny00; do
  # Points with oriented normals: ingest for scans; the vertices (with face
  # normals) for the bunny mesh.
  $apo -q ingest "${inputs[$name]}" -o "$out/$name/ingest" >/dev/null
  points="$out/$name/ingest/scan.ply"
  if [ "$name" = bunny00 ]; then
    python3 - "$points" "$out/$name/points.ply" <<'PY'
import sys
data = open(sys.argv[1], 'rb').read()
end = data.index(b'end_header\n') + len(b'end_header\n')
lines = data[:end].decode().split('\n')
out = [l for l in lines if not l.startswith('element face') and not l.startswith('property list')]
nv = int([l for l in lines if l.startswith('element vertex')][0].split()[2])
stride = 4 * sum(1 for l in lines if l.startswith('property float'))
open(sys.argv[2], 'wb').write('\n'.join(out).encode() + data[end:end + nv * stride])
PY
    points="$out/$name/points.ply"
  fi
  n=$(json "$out/$name/ingest/ingest.json" "j['counts']['points_out']")
  for method in auto poisson advancing-front scale-space; do
    dir="$out/$name/$method"
    read -r s m < <(measure $apo -q reconstruct "$points" -o "$dir" --method $method)
    if [ -f "$dir/reconstruct.json" ]; then
      echo "| $name | $n | apo $method | $s | $m | $(json "$dir/reconstruct.json" "j['mesh']['triangles']") | $(json "$dir/reconstruct.json" "j['mesh']['components']") | $(json "$dir/reconstruct.json" "'%.5f' % j['points_to_mesh']['mean']") |"
    fi
  done
  read -r s m < <(measure $baseline poisson "$points" "$out/$name/open3d_poisson.ply" 8)
  echo "| $name | $n | Open3D Poisson depth 8 | $s | $m | $(grep -o '[0-9]* triangles' "$out/log.txt" | tail -1 | cut -d' ' -f1) | | |"
done

echo
echo "| input | faces | method | seconds | peak MiB | faces out | Hausdorff / diag | mean / diag |"
echo "|---|---|---|---|---|---|---|---|"
$baseline subdivide datasets/cgal/meshes/bunny00.off 2 "$out/bunny_1M.ply" >>"$out/log.txt"
for mesh in datasets/cgal/meshes/bunny00.off "$out/bunny_1M.ply"; do
  name=$(basename "$mesh")
  for policy in gh lt; do
    dir="$out/simplify_${name}_$policy"
    read -r s m < <(measure $apo -q simplify "$mesh" -o "$dir" --faces 3000 --policy $policy)
    echo "| $name | $(json "$dir/simplify.json" "j['faces']['in']") | apo $policy | $s | $m | $(json "$dir/simplify.json" "j['faces']['out']") | $(json "$dir/simplify.json" "'%.5f' % j['distance_to_input']['hausdorff']") | $(json "$dir/simplify.json" "'%.6f' % j['distance_to_input']['mean']") |"
  done
  read -r s m < <(measure $baseline decimate "$mesh" 3000 "$out/open3d_${name}_3000.ply")
  echo "| $name | | Open3D quadric decimation | $s | $m | $(grep -o -- '-> [0-9]* triangles' "$out/log.txt" | tail -1 | cut -d' ' -f2) | | |"
done

echo
echo "| 1M-point scan | points | method (auto) | seconds | peak MiB | points used | triangles | mean dist. / diag |"
echo "|---|---|---|---|---|---|---|---|"
# A simulated scan of the 1.2M-face bunny: closed, so auto picks Poisson.
$apo -q simulate-scan "$out/bunny_1M.ply" -o "$out/bunny_scan.ply" --views 8 --rays 700
$apo -q ingest "$out/bunny_scan.ply" -o "$out/bunny_scan/ingest"
for method in auto advancing-front; do
  dir="$out/bunny_scan/$method"
  read -r s m < <(measure $apo -q reconstruct "$out/bunny_scan/ingest/scan.ply" -o "$dir" --method $method)
  echo "| bunny_scan | $(json "$dir/reconstruct.json" "j['points']['in']") | $(json "$dir/reconstruct.json" "j['method']") | $s | $m | $(json "$dir/reconstruct.json" "j['points']['used']") | $(json "$dir/reconstruct.json" "j['mesh']['triangles']") | $(json "$dir/reconstruct.json" "'%.5f' % j['points_to_mesh']['mean']") |"
done
