#!/usr/bin/env bash
# The seed systems side by side (issue 16, docs/benchmarks.md "The seed
# systems"): the same octree stored as the APO's texture and as GPU Gems 2's
# N^3-tree of N = 2 and N = 4, on bunny00 onto 3,000 faces, the 1.2M-triangle
# bunny (bunny00 subdivided twice by Open3D), and two real point scans
# (bun0.pcd, table_scene_lms400.pcd).
#
# Per scan: `apo run --layout n3tree --n3-size 2` and `--n3-size 4` (their
# scan.apo must be byte-identical: one octree); then for each stored form:
# - bytes of its file;
# - `apo render` at 512 and 1024 px (14 views, filtered, mip-mapped, 3 timed
#   frames): median ms per frame of the pass, texel reads per fragment (mean,
#   max; the filter's 8 extra walks included), the rendered angle against M;
# - the angle on probe points by the independent tools, through `apo lookup
#   --filter`: ../shared/tools/normal_eval.py against M (meshes), or
#   ../shared/tools/scan_eval.py against the scan's own points (point scans,
#   ingested by `apo ingest` for their normals).
# Usage (after the README's setup and build):
#   bash bench/seed_systems.sh [OUTDIR]
# Prints markdown tables. Takes about 20 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/seed_systems}
mkdir -p "$out"
: >"$out/log.txt"
apo=build/apo
tools=../shared/tools

run() { "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; exit 1; }; }
json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

big="$out/bunny_1M.ply"
[ -f "$big" ] || run build/open3d_baseline subdivide datasets/cgal/meshes/bunny00.off 2 "$big"

declare -A inputs=(
  [bunny00]=datasets/cgal/meshes/bunny00.off
  [bunny_1M]=$big
  [bun0]=datasets/pcl/bun0.pcd
  [table_scene_lms400]=datasets/pcl/table_scene_lms400.pcd
)
order=(bunny00 bunny_1M bun0 table_scene_lms400)

echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty)"
echo
echo "| scan | stored as | bytes | bytes per node | reads per fragment, mean / max (512 px) | ms per frame 512 px | ms per frame 1024 px | rendered vs M, mean deg (512 px) | probes, mean / median / p95 deg |"
echo "|---|---|---|---|---|---|---|---|---|"
for name in "${order[@]}"; do
  input=${inputs[$name]}
  dir="$out/$name"
  run $apo -q run "$input" -o "$dir/n2" --layout n3tree --n3-size 2 --no-export
  run $apo -q run "$input" -o "$dir/n4" --layout n3tree --n3-size 4 --no-export
  cmp -s "$dir/n2/scan.apo" "$dir/n4/scan.apo" || { echo "FAILED: $name: the two runs baked different octrees" >&2; exit 1; }
  m="$dir/n2/m.ply"
  if [ -f "$dir/n2/M.ply" ]; then reference="$dir/n2/M.ply"; else reference="$input"; fi
  nodes=$(json "$dir/n2/manifest.json" "j['results']['bake']['nodes']['leaves'] + j['results']['bake']['nodes']['internal']")
  files=("$dir/n2/scan.apo" "$dir/n2/scan.n3t" "$dir/n4/scan.n3t")
  labels=("APO texture" "N^3-tree, N = 2" "N^3-tree, N = 4")
  lookup="$apo -q lookup {apo} {points} -o {out} --filter --coarse $m"
  declare -A probes=()
  if [ -f "$dir/n2/M.ply" ]; then
    # A point scan: judged against its own points.
    run $apo -q ingest "$input" -o "$dir/ingest"
    /usr/bin/python3 $tools/scan_eval.py "$dir/ingest/scan.ply" "$m" "$lookup" "${files[@]}" >"$dir/scan_eval.txt" 2>>"$out/log.txt"
    i=0
    while read -r field mean median p95; do
      [ "$field" = m ] && { probes[m]="$mean / $median / $p95"; continue; }
      probes[$i]="$mean / $median / $p95"; i=$((i + 1))
    done <"$dir/scan_eval.txt"
  else
    run /usr/bin/python3 $tools/normal_eval.py "$input" "$m" --baseline --json "$dir/m_eval.json"
    probes[m]=$(json "$dir/m_eval.json" "'%.3f / %.3f / %.3f' % (j['stats']['mean'], j['stats']['median'], j['stats']['p95'])")
    for i in 0 1 2; do
      run /usr/bin/python3 $tools/normal_eval.py "$input" "$m" --apo "${files[$i]}" --apo-lookup "$lookup" --json "$dir/eval_$i.json"
      probes[$i]=$(json "$dir/eval_$i.json" "'%.3f / %.3f / %.3f' % (j['stats']['mean'], j['stats']['median'], j['stats']['p95'])")
    done
  fi
  for i in 0 1 2; do
    for size in 512 1024; do
      run $apo -q render --apo "${files[$i]}" --coarse "$m" --detail "$reference" --size $size --filter --frames 3 \
        -o "$dir/render_${i}_$size"
    done
    r512="$dir/render_${i}_512/render.json"
    bytes=$(stat -c %s "${files[$i]}")
    per_node=$(python3 -c "print('%.1f' % ($bytes / $nodes))")
    reads=$(json "$r512" "'%.1f / %d' % (j['overall']['cost']['apo_texel_fetches']['mean'], j['overall']['cost']['apo_texel_fetches']['max'])")
    ms512=$(json "$r512" "'%.1f' % j['overall']['cost']['apo_frame_ms']")
    ms1024=$(json "$dir/render_${i}_1024/render.json" "'%.1f' % j['overall']['cost']['apo_frame_ms']")
    rendered=$(json "$r512" "'%.3f' % j['overall']['apo']['mean']")
    echo "| $name | ${labels[$i]} | $bytes | $per_node | $reads | $ms512 | $ms1024 | $rendered | ${probes[$i]} |"
  done
  m512=$(json "$dir/render_0_512/render.json" "'%.1f' % j['overall']['cost']['baseline_frame_ms']")
  m1024=$(json "$dir/render_0_1024/render.json" "'%.1f' % j['overall']['cost']['baseline_frame_ms']")
  mrendered=$(json "$dir/render_0_512/render.json" "'%.3f' % j['overall']['baseline']['mean']")
  echo "| $name | m alone | | | | $m512 | $m1024 | $mrendered | ${probes[m]} |"
  unset probes
done
echo
echo "Nodes (leaves + internal) per scan: bytes per node divides each file by the octree's node count."
