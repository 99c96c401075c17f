#!/usr/bin/env bash
# Byte identity of two builds' outputs (issue 12): `apo run` with binary A and
# with binary B on the same scans, each copied to the same path and writing to
# the same folders (CGAL's advancing front breaks ties by heap address, so
# even one build's M can depend on the length of the paths it was given:
# docs/benchmarks.md, "Structure"), then m.ply, M.ply, scan.apo and
# texture.png compared by SHA-256. Scans:
#   subset       the first 12 scans of datasets/ by path (pipeline_bench.sh's subset)
#   points       11 point clouds (reconstructed: Poisson and advancing front)
#   detailpoints 3 scans with --detail-source points
# Usage: bash bench/identity_check.sh APO_A APO_B [OUTDIR]
# e.g. the previous main:  git worktree add /tmp/old <commit> && cmake -S /tmp/old -B /tmp/old/build \
#   && cmake --build /tmp/old/build -j2 --target apo && bash bench/identity_check.sh /tmp/old/build/apo build/apo
set -uo pipefail
cd "$(dirname "$0")/.."
a=$(realpath "$1"); b=$(realpath "$2"); out=${3:-out/bench/identity}
mkdir -p "$out"
find datasets -type f \( -iname '*.ply' -o -iname '*.pcd' -o -iname '*.xyz' -o -iname '*.xyzn' -o -iname '*.pts' \
  -o -iname '*.pwn' -o -iname '*.off' -o -iname '*.obj' -o -iname '*.stl' \) | sort | head -12 >"$out/subset.txt"
printf '%s\n' cgal/points_3/kitten.xyz cgal/points_3/oni.pwn cgal/points_3/sphere_20k.xyz cgal/points_3/hippo1.ply \
  cgal/points_3/building.ply cgal/points_3/blobby.xyz cgal/points_3/colors.ply pcl/bun0.pcd pcl/milk.pcd \
  pcl/lamppost.pcd pcl/table_scene_lms400.pcd | sed 's|^|datasets/|' >"$out/points.txt"
printf '%s\n' cgal/points_3/kitten.xyz pcl/bun0.pcd cgal/meshes/bear.off | sed 's|^|datasets/|' >"$out/detailpoints.txt"

run() {  # binary, label, list, extra options
  local bin=$1 label=$2 list=$3
  shift 3
  mkdir -p /tmp/apo-identity
  cp "$bin" /tmp/apo-identity/apo
  rm -rf /tmp/apo-identity/run
  while read -r scan; do
    name=$(echo "$scan" | tr '/' '_')
    /tmp/apo-identity/apo -q run "$scan" -o "/tmp/apo-identity/run/$name" "$@" >/dev/null 2>&1
    echo "$scan exit $?"
  done <"$out/$list.txt" >"$out/$label.$list.status"
  (cd /tmp/apo-identity/run && find . \( -name m.ply -o -name M.ply -o -name scan.apo -o -name texture.png \) | sort |
    xargs sha256sum) >"$out/$label.$list.sha256"
}

for list in subset points detailpoints; do
  extra=()
  [ "$list" = detailpoints ] && extra=(--detail-source points)
  run "$a" a "$list" "${extra[@]}"
  run "$b" b "$list" "${extra[@]}"
  scans=$(wc -l <"$out/$list.txt")
  differing=$(diff "$out/a.$list.sha256" "$out/b.$list.sha256" | grep '^[<>]' | awk '{print $3}' | cut -d/ -f2 | sort -u)
  echo "$list: $scans scans, $(echo "$differing" | grep -c . ) differ: $(echo $differing)"
done
