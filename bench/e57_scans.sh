#!/usr/bin/env bash
# Issue 44: a multi-scan E57 made by `apo simulate-scan --e57` from a bundled
# mesh (10 scans with their poses and row/column grids, range noise and
# misregistration on), end to end, beside the same points as a PLY without
# positions (docs/benchmarks.md, "Scan positions").
# Three ways in:
#   e57        the E57: each scan's grid triangulated from its position, the
#              scans then reconstructed together (--mesh-input scans);
#   e57-points the E57 read as points (--no-grid-mesh): normals towards each
#              point's own scan position;
#   ply        the PLY: no positions, normals by propagation.
# For each: normals flipped against the scanner's true normals (apo ingest's
# scan.ply against simulate-scan --normals, matched point to nearest point),
# mean angle; then `apo run` and the APO judged against the scan's true
# normals by ../shared/tools/scan_eval.py (m alone and the filtered APO),
# with the report's own against_scan figures.
# Usage (after the README's setup and build):
#   [MESH=datasets/cgal/meshes/camel.off] [VIEWS=10] [RAYS=300] bash bench/e57_scans.sh [OUTDIR]
# About 5 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
here=$(pwd)
out=${1:-out/bench/e57_scans}
mesh=${MESH:-datasets/cgal/meshes/camel.off}
views=${VIEWS:-10}
rays=${RAYS:-300}
apo=${APO_BIN:-$here/build/apo}
py=/usr/bin/python3
mkdir -p "$out"
: >"$out/log.txt"
run() { "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; exit 1; }; }

echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty), mesh $mesh, $views scans of ${rays}x$rays rays"
# The same seed gives the same points: the truth with its normals, then the
# scan without them (an E57 would carry them as the nor: extension).
run "$apo" -q simulate-scan "$mesh" --views "$views" --rays "$rays" -o "$out/truth.ply" --normals
run "$apo" -q simulate-scan "$mesh" --views "$views" --rays "$rays" -o "$out/scan.ply" --e57 "$out/scan.e57"

declare -A input=([e57]="$out/scan.e57" [e57-points]="$out/scan.e57" [ply]="$out/scan.ply")
declare -A extra=([e57]="" [e57-points]="--no-grid-mesh" [ply]="")
echo
echo '| input | orientation | points | flipped | mean angle (deg) | ingest s | run s | m against scan | APO against scan | report: APO against scan |'
echo '|---|---|---|---|---|---|---|---|---|---|'
for way in e57 e57-points ply; do
  dir="$out/$way"
  rm -rf "$dir" "$dir-run"
  start=$(date +%s%N)
  run "$apo" -q ingest "${input[$way]}" ${extra[$way]} -o "$dir"
  ingest_s=$(( ($(date +%s%N) - start) / 1000000 ))
  start=$(date +%s%N)
  run "$apo" -q run "${input[$way]}" ${extra[$way]} --no-viewer -o "$dir-run"
  run_s=$(( ($(date +%s%N) - start) / 1000000 ))
  read -r orientation points flipped angle < <($py - "$dir/ingest.json" "$dir/scan.ply" "$out/truth.ply" <<'PY'
import json, sys
import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree
j = json.load(open(sys.argv[1]))
ours, truth = o3d.io.read_point_cloud(sys.argv[2]), o3d.io.read_point_cloud(sys.argv[3])
p, n = np.asarray(ours.points), np.asarray(ours.normals)
origin = j['origin']
p = p + np.array(origin)
tp, tn = np.asarray(truth.points), np.asarray(truth.normals)
_, nearest = cKDTree(tp).query(p)
dots = np.clip(np.sum(n * tn[nearest], axis=1), -1, 1)
print(j['normals']['orientation'], len(p), int((dots < 0).sum()), '%.2f' % np.degrees(np.arccos(dots)).mean())
PY
)
  m=$(ls "$dir-run"/m.ply)
  read -r m_mean apo_mean <<<"$($py ../shared/tools/scan_eval.py "$out/truth.ply" "$m" \
      "$apo lookup --filter --coarse $m {apo} {points} -o {out}" "$dir-run/scan.apo" 2>>"$out/log.txt" |
    awk '{print $2}' | tr '\n' ' ')"
  report=$($py -c "import json,sys; j=json.load(open(sys.argv[1])); a=j['results']['render']['against_scan']; print('%.3f' % a['apo_filtered']['mean'] if a else '-')" "$dir-run/manifest.json")
  printf '| %s | %s | %s | %s | %s | %d.%d | %d.%d | %s | %s | %s |\n' "$way" "$orientation" "$points" "$flipped" "$angle" \
    $((ingest_s / 1000)) $((ingest_s % 1000 / 100)) $((run_s / 1000)) $((run_s % 1000 / 100)) "$m_mean" "$apo_mean" "$report"
done
