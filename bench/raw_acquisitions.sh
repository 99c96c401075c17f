#!/usr/bin/env bash
# Raw acquisitions (issue 13): the 1.2M-triangle simplification with and
# without meshoptimizer's quick pass beside Open3D, the quick pass against
# CGAL alone on three large meshes and three targets, normal orientation of a
# 1M-point scan without sensor (our propagation against CGAL's MST, against
# the scan's true normals), meshes wound inward, and depth frames (the grid
# triangulated against Poisson, judged by ../shared/tools/scan_eval.py), in one run.
# Usage (after the README's setup and build): bash bench/raw_acquisitions.sh [OUTDIR]
# Prints markdown tables for docs/benchmarks.md.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/raw}
apo=build/apo
baseline=build/open3d_baseline
mkdir -p "$out"

# "seconds peak_MiB" of a command (its output goes to $out/log.txt).
measure() {
  /usr/bin/time -f "%e %M" -o "$out/time.txt" "$@" >>"$out/log.txt" 2>&1 || { echo "FAILED: $*" >&2; echo "failed -"; return; }
  awk '{printf "%.2f %d\n", $1, $2 / 1024}' "$out/time.txt"
}
json() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

# The 1.2M-face bunny: bunny00 Loop-subdivided twice by Open3D.
big="$out/bunny_1M.ply"
[ -f "$big" ] || $baseline subdivide datasets/cgal/meshes/bunny00.off 2 "$big" >>"$out/log.txt"

echo "### Simplifying 1,206,528 faces to 3,000 (whole process, reading included)"
echo
echo "| method | seconds | peak MiB | faces out | Hausdorff / diag | mean / diag |"
echo "|---|---|---|---|---|---|"
for variant in quick cgal-only; do
  flags=""; [ "$variant" = cgal-only ] && flags="--no-quick-pass"
  read -r s mem < <(measure $apo -q simplify "$big" -o "$out/simplify-$variant" --faces 3000 $flags)
  j="$out/simplify-$variant/simplify.json"
  echo "| apo ($variant) | $s | $mem | $(json "$j" 'j["faces"]["out"]') | $(json "$j" '"%.5f" % j["distance_to_input"]["hausdorff"]') | $(json "$j" '"%.6f" % j["distance_to_input"]["mean"]') |"
done
read -r s mem < <(measure $baseline decimate "$big" 3000 "$out/open3d_decimated.ply")
echo "| Open3D quadric decimation | $s | $mem | 3000 | | |"
echo

echo "### The quick pass against CGAL alone: three large meshes, three targets"
echo
echo "| mesh | faces in | target | CGAL alone s | quick pass s | Hausdorff: CGAL / quick (change) | mean: CGAL / quick (change) |"
echo "|---|---|---|---|---|---|---|"
for name in armadillo elephant; do
  file="$out/${name}_big.ply"
  source=$(find datasets -name "$name.off" -o -name "refined_$name.off" | head -n 1)
  [ -f "$file" ] || $baseline subdivide "$source" 2 "$file" >>"$out/log.txt"
done
for target in 1000 3000 10000; do
  for file in "$out/armadillo_big.ply" "$out/elephant_big.ply" "$big"; do
    name=$(basename "$file" .ply)
    read -r sc _ < <(measure $apo -q simplify "$file" -o "$out/sweep-$name-$target-cgal" --faces $target --no-quick-pass)
    read -r sq _ < <(measure $apo -q simplify "$file" -o "$out/sweep-$name-$target-quick" --faces $target)
    python3 - "$out/sweep-$name-$target-cgal/simplify.json" "$out/sweep-$name-$target-quick/simplify.json" "$name" "$target" "$sc" "$sq" <<'PY'
import json, sys
c, q = (json.load(open(p)) for p in sys.argv[1:3])
dc, dq = c["distance_to_input"], q["distance_to_input"]
change = lambda a, b: "%+.0f%%" % (100 * (b / a - 1))
print("| %s | %d | %s | %s | %s | %.5f / %.5f (%s) | %.6f / %.6f (%s) |" % (
    sys.argv[3], c["faces"]["in"], sys.argv[4], sys.argv[5], sys.argv[6],
    dc["hausdorff"], dq["hausdorff"], change(dc["hausdorff"], dq["hausdorff"]),
    dc["mean"], dq["mean"], change(dc["mean"], dq["mean"])))
PY
  done
done
echo

echo "### Orienting a 1M-point scan without sensor position (ingest, whole process)"
echo
scan="$out/bunny_scan_n.ply"
[ -f "$scan" ] || $apo -q simulate-scan "$big" -o "$scan" --views 8 --rays 700 --normals >>"$out/log.txt"
echo "| orientation | seconds | peak MiB | normals step s | points | flipped fraction | mean angle to truth (deg) |"
echo "|---|---|---|---|---|---|---|"
for orient in propagation mst; do
  read -r s mem < <(measure $apo -q ingest "$scan" -o "$out/ingest-$orient" --force-normals --orient "$orient")
  j="$out/ingest-$orient/ingest.json"
  accuracy=$(build/orientation_accuracy "$scan" "$out/ingest-$orient/scan.ply")
  flipped=$(echo "$accuracy" | sed -E 's/.*flipped ([0-9.]+);.*/\1/')
  angle=$(echo "$accuracy" | sed -E 's/.*mean angle ([0-9.]+) deg.*/\1/')
  echo "| $orient | $s | $mem | $(json "$j" '"%.2f" % j["seconds"]["normals"]') | $(json "$j" 'j["counts"]["points_out"]') | $flipped | $angle |"
done
echo

echo "### Meshes wound inward (apo run, defaults)"
echo
echo "| input | flipped pieces / pieces | APO mean error (deg) | m alone (deg) | silhouette mismatch |"
echo "|---|---|---|---|---|"
echo "| input | decision | flipped pieces / pieces | APO mean (deg) | m alone (deg) | seconds | peak MiB |"
echo "|---|---|---|---|---|---|---|"
src=datasets/cgal/meshes/bunny00.off
# Every face's winding reversed: "3 a b c" -> "3 a c b".
awk 'NR <= 2 { print; next } NF == 4 && $1 == 3 { print $1, $2, $4, $3; next } { print }' "$src" >"$out/bunny00_inward.off"
# A multi-view soup of range grids, and the same soup wound inward.
$apo -q simulate-scan "$src" -o "$out/bunny00_soup.ply" --mesh --views 10 --rays 300 >>"$out/log.txt"
python3 bench/flip_winding.py "$out/bunny00_soup.ply" "$out/bunny00_soup_inward.ply"
for input in "$src" "$out/bunny00_inward.off" "$out/bunny00_soup.ply" "$out/bunny00_soup_inward.ply"; do
  name=$(basename "${input%.*}")
  read -r s mem < <(measure $apo -q run "$input" -o "$out/run-$name")
  m="$out/run-$name/manifest.json"
  echo "| $name | $(json "$m" 'j["results"]["ingest"]["mesh_input"]["decision"]') | $(json "$m" '"%d / %d" % (j["results"]["ingest"]["face_orientation"]["flipped_pieces"], j["results"]["ingest"]["face_orientation"]["pieces"])') | $(json "$m" '"%.2f" % j["results"]["render"]["overall"]["apo"]["mean"]') | $(json "$m" '"%.2f" % j["results"]["render"]["overall"]["baseline"]["mean"]') | $s | $mem |"
done
echo

echo "### A 2.1M-triangle range-scan soup end to end (apo run, defaults)"
echo
soup="$out/bunny_soup_2M.ply"
[ -f "$soup" ] || $apo -q simulate-scan "$big" -o "$soup" --mesh --views 15 --rays 530 >>"$out/log.txt"
read -r s mem < <(measure $apo -q run "$soup" -o "$out/run-soup2M")
m="$out/run-soup2M/manifest.json"
echo "| seconds | peak MiB | stages (s) | APO / m against M (deg) | m / APO / M against the soup's points (deg) |"
echo "|---|---|---|---|---|"
echo "| $s | $mem | $(json "$m" '", ".join("%s %.1f" % (n, st["seconds"]) for n, st in zip(["ingest", "reconstruct", "simplify", "bake", "render", "report"], j["stages"]))') | $(json "$m" '"%.2f / %.2f" % (j["results"]["render"]["overall"]["apo"]["mean"], j["results"]["render"]["overall"]["baseline"]["mean"])') | $(json "$m" '"%.2f / %.2f / %.2f" % (j["results"]["render"]["against_scan"]["m"]["mean"], j["results"]["render"]["against_scan"]["apo_filtered"]["mean"], j["results"]["render"]["against_scan"]["M"]["normal_degrees"]["mean"])') |"
echo

echo "### Depth frames: the grid triangulated, against Poisson from the points (apo run)"
echo
echo "| frame | M | pixels without a return | M triangles (refused) | seconds, peak MiB | APO / m against M (deg) | silhouette mismatch | m alone / APO against the scan (deg) |"
echo "|---|---|---|---|---|---|---|---|"
# The truth for scan_eval.py (../shared/tools/, needs python3-numpy, -scipy,
# -open3d): the frame's own points with PCA normals facing its sensor.
for frame in table_scene_mug_stereo_textured milk_cartoon_all_small_clorox; do
  input=datasets/pcl/$frame.pcd
  $apo -q ingest "$input" -o "$out/depth-$frame-truth" --no-grid-mesh >>"$out/log.txt" 2>&1
  for variant in grid points; do
    flags=""; [ "$variant" = points ] && flags="--no-grid-mesh"
    run="$out/depth-$frame-$variant"
    read -r s mem < <(measure $apo -q run "$input" -o "$run" $flags)
    eval_lines=$(/usr/bin/python3 ../shared/tools/scan_eval.py "$out/depth-$frame-truth/scan.ply" "$run/m.ply" \
      "$apo -q lookup {apo} {points} -o {out} --coarse $run/m.ply" "$run/scan.apo" | tail -n 2)
    python3 - "$run/manifest.json" "$frame" "$variant" "$s" "$mem" "$eval_lines" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))["results"]
grid, render = r["ingest"]["grid_mesh"], r["render"]["overall"]
m_alone, apo = (line.split()[1] for line in sys.argv[6].splitlines())
print("| %s | %s | %s | %s | %s, %s | %.2f / %.2f | %.1f%% | %s / %s |" % (
    sys.argv[2], sys.argv[3],
    grid["pixels_without_return"] if grid else "",
    "%d (%d)" % (grid["triangles"], grid["refused_triangles"]) if grid else "",
    sys.argv[4], sys.argv[5], render["apo"]["mean"], render["baseline"]["mean"],
    100 * render["apo_image"]["silhouette_mismatch"], m_alone, apo))
PY
  done
done
