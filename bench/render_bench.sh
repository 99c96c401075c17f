#!/usr/bin/env bash
# `apo render` (issue 5) under OSMesa llvmpipe on this machine's cores:
#   - the crossover: the median frame time of m (15,000 triangles) with the
#     APO against drawing M directly, for bumpy tori M of 100K, 1M and 4M
#     triangles (build/make_detail_mesh torus), at 512 and 1024 px;
#   - the speed-ups from the completion grid (bake --complete-depth 0 against
#     the default 5) and from volumetric mip-mapping (--no-mipmap), and the
#     texel reads per fragment of each, on the 1M torus and on bunny00 (3K m
#     of its 1.2M-face bumpy subdivision, as in bench/bake_bench.sh);
#   - filtering's cost and the angular error of each variant.
# Frame time = median over --frames frames of clear + draw + glFinish, per
# view; the tables give the mean over the views. Every variant of a table
# runs in the same go, so read the ratios rather than the milliseconds.
# Usage (after the README's setup and build, plus
# `cmake --build build -j2 --target make_detail_mesh open3d_baseline`):
#   bash bench/render_bench.sh [OUTDIR]
# Prints markdown tables for docs/benchmarks.md. Takes about 20 minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/render}
in=$out/inputs
views=${VIEWS:-3}
frames=${FRAMES:-9}
mkdir -p "$in" "$out/bin"
: >"$out/log.txt"
cp build/apo build/apo-engine build/apo-pcl.so build/make_detail_mesh build/open3d_baseline "$out/bin/"
apo=$out/bin/apo
tool=$out/bin/make_detail_mesh
baseline=$out/bin/open3d_baseline

run() { "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; exit 1; }; }
json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty); $views views, median of $frames frames each"
echo

# ---- Inputs ---------------------------------------------------------------
# Tori of 2 nu nv triangles, each with its m (a 150 x 50 grid, 15,000
# triangles, shifted off M's grid lines by make_detail_mesh, so one m per M).
declare -A grid=([30K]="150 100" [100K]="250 200" [1M]="1000 500" [4M]="2000 1000")
for size in 30K 100K 1M 4M; do
  read -r nu nv <<<"${grid[$size]}"
  [ -f "$in/torus_$size.ply" ] || run $tool torus "$in/torus_$size.ply" "$in/torus_m_$size.ply" --nu "$nu" --nv "$nv" \
    --coarse-nu 150 --coarse-nv 50 --amplitude 0.001 --period-edges 50
  [ -f "$in/torus_$size/scan.apo" ] || run $apo -q bake --detail "$in/torus_$size.ply" --coarse "$in/torus_m_$size.ply" -o "$in/torus_$size"
done
[ -f "$in/torus_1M_grid0/scan.apo" ] || run $apo -q bake --detail "$in/torus_1M.ply" --coarse "$in/torus_m_1M.ply" \
  -o "$in/torus_1M_grid0" --complete-depth 0
if [ ! -f "$in/bunny/scan.apo" ]; then
  run $baseline subdivide datasets/cgal/meshes/bunny00.off 2 "$in/bunny_1M.ply"
  run $tool displace "$in/bunny_1M.ply" "$in/bunny_1M_bumpy.ply" --amplitude 0.001 --period-edges 50
  run $apo -q simplify "$in/bunny_1M_bumpy.ply" -o "$in/bunny_m" --faces 3000
  run $apo -q bake --detail "$in/bunny_1M_bumpy.ply" --coarse "$in/bunny_m/m.ply" -o "$in/bunny"
  run $apo -q bake --detail "$in/bunny_1M_bumpy.ply" --coarse "$in/bunny_m/m.ply" -o "$in/bunny_grid0" --complete-depth 0
fi
[ -f "$in/bunny_fine/scan.apo" ] || run $apo -q bake --detail "$in/bunny_1M_bumpy.ply" --coarse "$in/bunny_m/m.ply" \
  -o "$in/bunny_fine" --error 0.0003

# render APO COARSE DETAIL SIZE NAME [options]: render.json in $out/NAME.
render() {
  local apo_file=$1 coarse=$2 detail=$3 size=$4 name=$5
  shift 5
  run $apo -q render --apo "$apo_file" --coarse "$coarse" --detail "$detail" -o "$out/$name" --size "$size" \
    --views "$views" --frames "$frames" "$@"
  echo "$out/$name/render.json"
}

# ---- Crossover ------------------------------------------------------------
echo "Crossover: m (15,000 triangles) with the APO against M drawn directly (ms per frame)"
echo
echo "| M | size | M directly | m with the APO | m alone | APO / direct | APO texture |"
echo "|---|---|---|---|---|---|---|"
for size in 30K 100K 1M 4M; do
  for px in 512 1024; do
    j=$(render "$in/torus_$size/scan.apo" "$in/torus_m_$size.ply" "$in/torus_$size.ply" $px "torus_${size}_$px")
    read -r direct_ms apo_ms alone_ms < <(json "$j" "'%.1f %.1f %.1f' % (j['overall']['cost']['reference_frame_ms'], j['overall']['cost']['apo_frame_ms'], j['overall']['cost']['baseline_frame_ms'])")
    bytes=$(stat -c %s "$in/torus_$size/scan.apo")
    echo "| torus $size | $px | $direct_ms | $apo_ms | $alone_ms | $(python3 -c "print(f'{$apo_ms / $direct_ms:.2f}')") | $((bytes / 1024)) KiB |"
  done
done
echo

# ---- Completion, mip-mapping, filtering -----------------------------------
# variant NAME APO COARSE DETAIL SIZE [render options]: one table row.
variant() {
  local name=$1 apo_file=$2 coarse=$3 detail=$4 px=$5
  shift 5
  local j
  j=$(render "$apo_file" "$coarse" "$detail" "$px" "variant_$(basename "$(dirname "$apo_file")")_${px}_$#$*" "$@")
  json "$j" "'| $name | $px | %.1f | %.2f | %d | %.3f |' % (j['overall']['cost']['apo_frame_ms'], j['overall']['cost']['apo_texel_fetches']['mean'], j['overall']['cost']['apo_texel_fetches']['max'], j['overall']['apo']['mean'])"
}
for model in torus bunny; do
  if [ $model = torus ]; then
    apo_default=$in/torus_1M/scan.apo apo_grid0=$in/torus_1M_grid0/scan.apo coarse=$in/torus_m_1M.ply detail=$in/torus_1M.ply
    echo "Variants of the APO pass on the 1M torus (m 15,000 triangles)"
  else
    apo_default=$in/bunny/scan.apo apo_grid0=$in/bunny_grid0/scan.apo coarse=$in/bunny_m/m.ply detail=$in/bunny_1M_bumpy.ply
    echo "Variants of the APO pass on the bumpy 1.2M bunny (m 3,000 triangles)"
  fi
  echo
  echo "| variant | size | ms per frame | texel reads per fragment (mean) | (max) | angular error (deg) |"
  echo "|---|---|---|---|---|---|"
  for px in 512 1024; do
    variant "grid of depth 5, mip-mapping (default)" "$apo_default" "$coarse" "$detail" $px
    variant "grid of depth 5, no mip-mapping" "$apo_default" "$coarse" "$detail" $px --no-mipmap
    variant "from the root, mip-mapping" "$apo_grid0" "$coarse" "$detail" $px
    variant "from the root, no mip-mapping" "$apo_grid0" "$coarse" "$detail" $px --no-mipmap
    variant "grid of depth 5, mip-mapping, filtering" "$apo_default" "$coarse" "$detail" $px --filter
  done
  echo
done

# ---- Mip-mapping where cells get smaller than pixels --------------------------
echo "Mip-mapping on a fine bake of the bumpy bunny (--error 0.0003), small and large images"
echo
echo "| variant | size | ms per frame | texel reads per fragment (mean) | (max) | angular error (deg) |"
echo "|---|---|---|---|---|---|"
for px in 128 256 1024; do
  variant "mip-mapping (default)" "$in/bunny_fine/scan.apo" "$in/bunny_m/m.ply" "$in/bunny_1M_bumpy.ply" $px
  variant "no mip-mapping" "$in/bunny_fine/scan.apo" "$in/bunny_m/m.ply" "$in/bunny_1M_bumpy.ply" $px --no-mipmap
done
echo
