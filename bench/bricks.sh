#!/usr/bin/env bash
# The bake in bricks (docs/bake.md, "Bricks") against the bake in one piece,
# on the same points: the 10-million-point bunny scan of bench/big_scans.sh
# ingested into about 1.3 million voxel centroids (--max-scan-points
# 2000000), m = bunny00 simplified to 3,000 faces, the default budget.
# Per --brick-depth: wall seconds, peak MiB, each pass's seconds, the brick
# builds, and whether scan.apo is byte-identical to depth 0's.
# Usage (after the README's build): bash bench/bricks.sh [DEPTH...]   (default 0 1 2 3)
set -euo pipefail
cd "$(dirname "$0")/.."
depths=("$@")
[ ${#depths[@]} -gt 0 ] || depths=(0 1 2 3)
[ "${depths[0]}" = 0 ] || depths=(0 "${depths[@]}")
scan=build/bench_data/bunny-10M.ply
[ -f "$scan" ] || bash bench/big_scans.sh 10 >/dev/null
out=$(mktemp -d)
build/apo -q ingest "$scan" -o "$out/scan" --max-scan-points 2000000
build/apo -q simplify datasets/cgal/meshes/bunny00.off -o "$out/m" --faces 3000
printf '| --brick-depth | wall s | peak MiB | areas / refinement / sampling s | bricks | brick builds | most points in a brick | same .apo as depth 0 |\n|---|---|---|---|---|---|---|---|\n'
for depth in "${depths[@]}"; do
  /usr/bin/time -f '%e %M' -o "$out/time" build/apo -q bake --detail "$out/scan/scan.ply" --coarse "$out/m/m.ply" \
    -o "$out/d$depth" --brick-depth "$depth"
  same=$(cmp -s "$out/d0/scan.apo" "$out/d$depth/scan.apo" && echo yes || echo NO)
  python3 - "$out/time" "$out/d$depth/bake.json" "$depth" "$same" <<'PY'
import json, sys
wall, peak = open(sys.argv[1]).read().split()
b = json.load(open(sys.argv[2]))
r = b.get("bricks")
passes = f"{r['seconds']['areas']:.1f} / {r['seconds']['refinement']:.1f} / {r['seconds']['sampling']:.1f}" if r else \
    f"(one piece: build {b['seconds']['build']:.1f}, sample {b['seconds']['sample']:.1f})"
print(f"| {sys.argv[3]} | {float(wall):.1f} | {int(peak) // 1024} | {passes} | {r['bricks'] if r else 1} | "
      f"{r['refinement_runs'] if r else 1} | {r['largest_brick_points'] if r else b['detail']['primitives']} | {sys.argv[4]} |")
PY
done
rm -rf "$out"
