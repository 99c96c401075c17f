#!/usr/bin/env bash
# Detail source (issue 13, section 7): on point scans, what `apo run` keeps by
# default (--detail-source auto: the APO baked from M or from the points,
# whichever is closer to the scan) against the best this m allows: the
# lowest error against the scan over APOs baked from M and from the points
# at the default byte budget and at two fine --error thresholds without a
# byte limit (--budget 0). Every
# figure is the run's own against-the-scan measure (docs/render.md: 200,000
# probes on m, filtered lookup, truth from the 8 nearest scan normals); m is
# the same in every run of a scan (the bake's options do not change it).
# Usage (after the README's setup and build; the simulated scans come from
# bench/raw_acquisitions.sh, which makes them in the same OUTDIR):
#   bash bench/detail_source.sh [OUTDIR]
# Prints a markdown table for docs/benchmarks.md.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/raw}
apo=build/apo
mkdir -p "$out/detail"
json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }
against() { json "$1/manifest.json" '"%.2f" % j["results"]["render"]["against_scan"]["apo_filtered"]["mean"]'; }

scans=(datasets/cgal/points_3/kitten.xyz datasets/cgal/points_3/hippo1.ply datasets/pcl/bun0.pcd
       datasets/pcl/table_scene_lms400.pcd "$out/bunny00_soup.ply" "$out/bunny_scan_n.ply" "$out/bunny_soup_2M.ply")
for scan in "${scans[@]}"; do
  [ -f "$scan" ] || { echo "missing $scan: run bench/raw_acquisitions.sh first" >&2; exit 1; }
done

# The variants judged only against the scan: one small view is enough.
small=(--views 1 --size 64 --frames 0)
echo "| scan | points | auto kept | from M (deg, bytes) | from the points (deg, bytes) | auto s (bake stage) | best (deg, how) | auto / best |"
echo "|---|---|---|---|---|---|---|---|"
for scan in "${scans[@]}"; do
  name=$(basename "$scan"); name=${name%.*}
  run="$out/detail/$name-auto"
  $apo -q run "$scan" -o "$run" >>"$out/detail/log.txt" 2>&1
  m="$run/manifest.json"
  choice='j["results"]["bake"]["detail_source"]'
  best=$(against "$run"); how="auto"
  for source in mesh points; do
    for refinement in "" "--budget 0 --error 0.01" "--budget 0 --error 0.002"; do
      variant="$out/detail/$name-$source-$(echo "${refinement:-budget}" | tr -c 'A-Za-z0-9.\n' '_')"
      # shellcheck disable=SC2086 # the refinement options split into words
      $apo -q run "$scan" -o "$variant" --detail-source "$source" $refinement "${small[@]}" >>"$out/detail/log.txt" 2>&1
      cmp -s "$run/m.ply" "$variant/m.ply" || { echo "$name: m differs in $variant" >&2; exit 1; }
      figure=$(against "$variant")
      if python3 -c "import sys; sys.exit(0 if float('$figure') < float('$best') else 1)"; then
        best=$figure; how="$source, ${refinement:-default budget}"
      fi
    done
  done
  echo "| $name | $(json "$m" 'j["results"]["ingest"]["counts"]["points_out"]') | $(json "$m" "$choice[\"chosen\"]") |" \
       "$(json "$m" "'%.2f, %d' % ($choice['candidates']['mesh']['against_scan_mean_degrees'], $choice['candidates']['mesh']['texture_bytes'])") |" \
       "$(json "$m" "'%.2f, %d' % ($choice['candidates']['points']['against_scan_mean_degrees'], $choice['candidates']['points']['texture_bytes'])") |" \
       "$(json "$m" "'%.1f (%.1f)' % (sum(s['seconds'] for s in j['stages']), j['stages'][3]['seconds'])") |" \
       "$best ($how) | $(python3 -c "print('%.3f' % ($(against "$run") / $best))") |"
done
