#!/usr/bin/env bash
# Simulated multi-scan soups of bundled meshes, in both windings (issue 13,
# section 8): each mesh scanned from 10 views as range grids (`apo
# simulate-scan --mesh`: each view's grid triangulated, all in one file, as
# range-scan sets are stored), the same soup with every face wound inward,
# and `apo run` with the defaults on both. Must show: read as scans, M
# reconstructed, and the report's APO error at most 1/2.5 of m alone's
# (baseline / APO >= 2.5). Also shown: what the APO was baked from
# (--detail-source auto) and the figures against the soup's own points.
# Usage (after the README's setup and build):
#   bash bench/soups.sh [OUTDIR [apo run options, e.g. --error 0.01]]
# Prints a markdown table for docs/benchmarks.md.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/soups}
shift || true
options=("$@")
tag=$(echo "${options[*]:-defaults}" | tr -c 'A-Za-z0-9.\n' '_')
apo=build/apo
mkdir -p "$out"
json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

meshes=(bunny00 armadillo refined_elephant diplodocus man bear lion-head camel)
echo "| mesh | winding | soup triangles | read as | faces flipped | M triangles | baked from | APO / m against M (deg) | m / APO | m / APO against the soup (deg) | seconds | peak MiB |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for mesh in "${meshes[@]}"; do
  soup="$out/$mesh-soup.ply"
  [ -f "$soup" ] || $apo -q simulate-scan "datasets/cgal/meshes/$mesh.off" -o "$soup" --mesh --views 10 --rays 300 >>"$out/log.txt" 2>&1
  [ -f "$out/$mesh-inward.ply" ] || python3 bench/flip_winding.py "$soup" "$out/$mesh-inward.ply"
  for winding in soup inward; do
    run="$out/run-$mesh-$winding-$tag"
    /usr/bin/time -f "%e %M" -o "$out/time.txt" $apo -q run "$out/$mesh-$winding.ply" -o "$run" "${options[@]}" >>"$out/log.txt" 2>&1
    read -r s mem < "$out/time.txt"
    m="$run/manifest.json"
    echo "| $mesh | $winding | $(json "$m" 'j["results"]["ingest"]["counts"]["triangles_in"]') |" \
         "$(json "$m" 'j["results"]["ingest"]["mesh_input"]["decision"]') |" \
         "$(json "$m" '(j["results"]["ingest"].get("face_orientation") or {}).get("flipped_triangles", 0)') |" \
         "$(json "$m" 'j["results"]["reconstruct"]["mesh"]["triangles"]') |" \
         "$(json "$m" 'j["results"]["bake"]["detail_source"]["chosen"]') |" \
         "$(json "$m" '"%.2f / %.2f" % (j["results"]["render"]["overall"]["apo"]["mean"], j["results"]["render"]["overall"]["baseline"]["mean"])') |" \
         "$(json "$m" '"%.2f" % j["results"]["render"]["overall"]["baseline_over_apo"]') |" \
         "$(json "$m" '"%.2f / %.2f" % (j["results"]["render"]["against_scan"]["m"]["mean"], j["results"]["render"]["against_scan"]["apo_filtered"]["mean"])') |" \
         "$s | $((mem / 1024)) |"
  done
done
