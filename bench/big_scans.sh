#!/usr/bin/env bash
# Issue 45: `apo run` on scans of 10, 30 and 100 million points (or the
# sizes given, in millions) made by `apo simulate-scan` from bunny00 (8 views,
# noise and misregistration on: the defaults), written as binary PLY, LAS
# and LAZ into build/bench_data/ unless there already (not committed: about
# 12 bytes a point as PLY, 20 as LAS, 4 as LAZ). Each is run whole with the
# defaults (scans above --max-scan-points are read a run at a time into voxel
# centroids, docs/ingest.md "Large scans"); FORMAT=las or laz runs those copies.
# Prints per scan: wall seconds and peak MiB (the largest of the manifest's
# stage peaks and GNU time's),
# seconds per stage, the points in the file and those kept, the points the
# bake used, the scan-side figures (the APO's and m's mean angle to the scan's
# own normals, degrees), and the output folder's size; with `uptime`'s load
# before and after (the machine may be shared).
#   [FORMAT=ply|las] bash bench/big_scans.sh [MILLIONS ...]
# Needs build/apo (cmake --build build --target apo).
set -euo pipefail
cd "$(dirname "$0")/.."
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(10 30 100)
format=${FORMAT:-ply}
mkdir -p build/bench_data
echo "load before: $(uptime | sed 's/.*average: //')"
printf '| points (M) | format | wall s | peak MiB | ingest / reconstruct / simplify / bake / render / export / report s | points in file | kept by ingest | used by the bake | against scan: APO / m, mean deg | output MiB |\n'
printf '|---|---|---|---|---|---|---|---|---|---|\n'
for millions in "${sizes[@]}"; do
  # 8 views of r x r rays hit bunny00 about 26% of the time.
  rays=$(python3 -c "import math,sys; print(round(math.sqrt(float(sys.argv[1]) * 1e6 / 8 / 0.2606)))" "$millions")
  stem=build/bench_data/bunny-${millions}M
  if [ ! -f "$stem.ply" ] || [ ! -f "$stem.las" ] || [ ! -f "$stem.laz" ]; then
    build/apo -q simulate-scan datasets/cgal/meshes/bunny00.off --views 8 --rays "$rays" \
      -o "$stem.ply" --las "$stem.las" --laz "$stem.laz"
  fi
  scan=$stem.$format
  out=$(mktemp -d)
  /usr/bin/time -f '%e %M' -o "$out.time" build/apo -q run "$scan" -o "$out/run" >"$out.log" 2>&1 ||
    { tail -n 20 "$out.log"; exit 1; }
  python3 - "$out" "$millions" "$format" <<'EOF'
import json, os, subprocess, sys
out, millions, fmt = sys.argv[1:]
wall, peak_kib = open(out + ".time").read().split()
m = json.load(open(os.path.join(out, "run", "manifest.json")))
peak = max([int(peak_kib) // 1024] + [s.get("peak_memory_bytes", 0) // 2**20 for s in m["stages"]])
stages = " / ".join(f"{s['seconds']:.0f}" for s in m["stages"])
r = m["results"]
ingest = r["ingest"]
large = ingest.get("large_scan") or {}
in_file = large.get("points_in_file", ingest["counts"]["points_in"])
scan_side = r["render"].get("against_scan") or {}
apo = (scan_side.get("apo_filtered") or scan_side.get("apo") or {}).get("mean")
coarse = (scan_side.get("m") or {}).get("mean")
size = int(subprocess.check_output(["du", "-sm", os.path.join(out, "run")]).split()[0])
figures = f"{apo:.2f} / {coarse:.2f}" if apo is not None and coarse is not None else "-"
print(f"| {millions} | {fmt} | {float(wall):.0f} | {peak} | {stages} | {in_file:,} | "
      f"{ingest['counts']['points_out']:,} | {r['bake']['detail']['primitives']:,} | {figures} | {size} |")
EOF
  rm -rf "$out" "$out.time" "$out.log"
done
echo "load after: $(uptime | sed 's/.*average: //')"
