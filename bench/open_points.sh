#!/usr/bin/env bash
# Issue 43, part 4: the open points' figures in one go (docs/benchmarks.md,
# "Where the rendered error sits").
# 1. kitten.xyz judged against the point LOD: the run's figures with
#    --detail-source points and mesh; the LOD reference, the APO and m
#    against M drawn from the same cameras (bench/open_points.py compare);
#    the same reference with M's exact normals on the points
#    (bench/interpolated_normals.py): the floor of 5,210 flat discs.
# 2. blade.off mip-mapped: the run (mip-mapped, filtered) and --no-mipmap;
#    where the error sits (bench/open_points.py edges); what internal nodes
#    store against what they could (bench/mip_values.py).
# 3. Range-scan soups (bunny00, camel: 10 views of range grids, as
#    bench/soups.sh makes them) rendered against M: where the error sits,
#    at the run's 3 MiB and at 12 MiB; --detail-source points rendered
#    against M.
# Usage (after the README's setup and build):
#   bash bench/open_points.sh [OUTDIR]      (APO_BIN=/path/to/apo to use another build)
# Prints the figures as text and markdown tables. Takes about 10 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
here=$(pwd)
out=${1:-out/bench/open_points}
mkdir -p "$out"
: >"$out/log.txt"
apo=${APO_BIN:-$here/build/apo}
py=/usr/bin/python3
export APO_BIN=$apo

run() { "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; exit 1; }; }
json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }
overall() { json "$1/render.json" "'APO %.3f, m %.3f' % (j['overall']['apo']['mean'], j['overall']['baseline']['mean'])"; }
render() {  # APO m DETAIL OUT [options]
  local a=$1 m=$2 d=$3 o=$4
  shift 4
  run "$apo" -q render --apo "$a" --coarse "$m" --detail "$d" --size 512 --filter --frames 0 -o "$o" "$@"
}

echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty), apo: $apo"
echo
echo "## 1. kitten.xyz against the point LOD"
k="$out/kitten"
for s in points mesh; do
  run "$apo" -q run datasets/cgal/points_3/kitten.xyz -o "$k/$s" --no-export --size 512 --detail-source $s
done
run "$apo" -q ingest datasets/cgal/points_3/kitten.xyz -o "$k/ingest"
echo "run, --detail-source points (reference: the point LOD): $(overall "$k/points/render")"
echo "  against the scan's points: $(json "$k/points/manifest.json" "'APO %.3f, m %.3f, M %.3f' % (j['results']['render']['against_scan']['apo_filtered']['mean'], j['results']['render']['against_scan']['m']['mean'], j['results']['render']['against_scan']['M']['normal_degrees']['mean'])")"
echo "  bake: $(json "$k/points/manifest.json" "'%s, %d bytes' % (j['results']['bake']['refinement']['stopped_by'], j['results']['bake']['texture']['bytes'])")"
echo "run, --detail-source mesh (reference: M): $(overall "$k/mesh/render"); against the scan: $(json "$k/mesh/manifest.json" "'APO %.3f' % j['results']['render']['against_scan']['apo_filtered']['mean']")"
render "$k/mesh/scan.apo" "$k/mesh/m.ply" "$k/ingest/scan.ply" "$k/meshapo_vs_lod"
echo "the mesh's APO against the point LOD: $(overall "$k/meshapo_vs_lod")"
render "$k/points/scan.apo" "$k/points/m.ply" "$k/points/M.ply" "$k/pointsapo_vs_M"
echo "the points' APO against M: $(overall "$k/pointsapo_vs_M")"
echo
echo "The run's render (point LOD reference), each buffer against M drawn by bench/open_points.py from the same cameras:"
$py bench/open_points.py compare "$k/points/render" "$k/points/M.ply"
echo "Calibration: the mesh run's render (reference: M itself) against the same drawing of M:"
$py bench/open_points.py compare "$k/mesh/render" "$k/mesh/M.ply"
run $py bench/interpolated_normals.py "$k/points/M.ply" "$k/ingest/scan.ply" "$k/smooth.ply"
render "$k/points/scan.apo" "$k/points/m.ply" "$k/smooth.ply" "$k/smooth"
echo "The points with M's exact normals as the reference: $(overall "$k/smooth"); against M drawn:"
$py bench/open_points.py compare "$k/smooth" "$k/points/M.ply"
echo
echo "## 2. blade.off mip-mapped"
b="$out/blade"
run "$apo" -q run datasets/cgal/meshes/blade.off -o "$b/run" --no-export --size 512
render "$b/run/scan.apo" "$b/run/m.ply" datasets/cgal/meshes/blade.off "$b/nomip" --no-mipmap
echo "mip-mapped (the run): $(overall "$b/run/render"); --no-mipmap: $(overall "$b/nomip")"
echo "internal nodes showing m: $(json "$b/run/manifest.json" "j['results']['bake']['refinement']['internal_nodes_showing_m']")"
echo
echo "mip-mapped:"
$py bench/open_points.py edges "$b/run/render" datasets/cgal/meshes/blade.off 1 4
echo "--no-mipmap:"
$py bench/open_points.py edges "$b/nomip" datasets/cgal/meshes/blade.off 1 4
echo
echo "What a walk stopping at each depth reads, on 400,000 samples of M (mean angle to M's normal, degrees):"
$py bench/mip_values.py "$b/run/scan.apo" "$b/run/m.ply" datasets/cgal/meshes/blade.off "$b/mip_values" 7 8 9 10
echo
echo "## 3. Range-scan soups against M"
for mesh in bunny00 camel; do
  s="$out/soup_$mesh"
  mkdir -p "$s"
  [ -f "$s/soup.ply" ] || run "$apo" -q simulate-scan "datasets/cgal/meshes/$mesh.off" -o "$s/soup.ply" --mesh --views 10 --rays 300
  run "$apo" -q run "$s/soup.ply" -o "$s/run" --no-export --size 512
  run "$apo" -q bake --detail "$s/run/M.ply" --coarse "$s/run/m.ply" --budget 12MiB -o "$s/bake12"
  render "$s/bake12/scan.apo" "$s/run/m.ply" "$s/run/M.ply" "$s/bake12/render"
  run "$apo" -q run "$s/soup.ply" -o "$s/points" --no-export --size 512 --detail-source points
  render "$s/points/scan.apo" "$s/points/m.ply" "$s/points/M.ply" "$s/points_vs_M"
  echo
  echo "### $mesh soup"
  echo "run (baked from $(json "$s/run/manifest.json" "j['results']['bake']['detail_source']['chosen']")): against M $(overall "$s/run/render");" \
       "against the soup $(json "$s/run/manifest.json" "'APO %.3f, m %.3f; M %.3f' % (j['results']['render']['against_scan']['apo_filtered']['mean'], j['results']['render']['against_scan']['m']['mean'], j['results']['render']['against_scan']['M']['normal_degrees']['mean'])")"
  echo "--detail-source points: against M $(overall "$s/points_vs_M"); against the soup $(json "$s/points/manifest.json" "'APO %.3f' % j['results']['render']['against_scan']['apo_filtered']['mean']")"
  echo
  echo "the run (3 MiB):"
  $py bench/open_points.py edges "$s/run/render" "$s/run/M.ply" 1 4
  echo "12 MiB:"
  $py bench/open_points.py edges "$s/bake12/render" "$s/run/M.ply" 1 4
  echo "--detail-source points, against M:"
  $py bench/open_points.py edges "$s/points_vs_M" "$s/points/M.ply" 1 4
done
