#!/usr/bin/env bash
# The report's interactive viewer (issue 17; docs/benchmarks.md "The
# report's viewer"): `apo run` with its defaults on four scans that take the
# viewer's four paths for M (a mesh small enough to travel whole; a mesh
# previewed at 100,000 triangles; a point scan baked from its points, drawn
# as points; the README's one-sided lidar scan), then per scan the bytes
# viewer.html adds and its frame time per mode at 1024 x 768 in headless
# Chromium's SwiftShader (bench/viewer_frames.py).
# Usage (after the README's setup and build):
#   bash bench/viewer.sh [OUTDIR]
# Takes about 5 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/viewer}
mkdir -p "$out"
: >"$out/log.txt"
apo=build/apo

run() { "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; exit 1; }; }
json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

[ -f "$out/bunny_1M.ply" ] || run build/open3d_baseline subdivide datasets/cgal/meshes/bunny00.off 2 "$out/bunny_1M.ply"

scan() {  # NAME INPUT [options]
  local name=$1 input=$2
  shift 2
  run $apo -q run "$input" -o "$out/$name" "$@"
  local m=$out/$name/manifest.json
  echo "## $name: $(json "$m" "j['results']['viewer']['detail']"), viewer.html $(json "$m" "j['results']['viewer']['bytes']") bytes (APO texture $(json "$m" "j['results']['viewer']['texture_bytes']")), made in $(json "$m" "round(j['results']['viewer']['seconds'], 2)") s"
  python3 bench/viewer_frames.py "$out/$name/viewer.html" 5
  echo
}

scan bunny00 datasets/cgal/meshes/bunny00.off
scan bunny_1M "$out/bunny_1M.ply"
scan kitten_points datasets/cgal/points_3/kitten.xyz --detail-source points
scan table_scene_lms400 datasets/pcl/table_scene_lms400.pcd
