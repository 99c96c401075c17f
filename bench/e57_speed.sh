#!/usr/bin/env bash
# Issue 44: E57 read speed on a scan of over 20 million points made by
# `apo simulate-scan --e57` (bunny00, 8 scans of 3200 x 3200 rays: scaled-
# integer cartesian coordinates, row/column grids), read by `apo ingest
# --no-normals --no-grid-mesh` ROUNDS times (default 3); the read time is
# ingest.json's seconds.read (the file from disk, its CRCs, the XML, every
# record decoded and posed into one local frame). (docs/benchmarks.md,
# "Read speed"; LAZ's counterpart is bash bench/laz_bench.sh --simulated.)
#   bash bench/e57_speed.sh [ROUNDS]
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-3}
file=build/bench_data/bunny-8x3200.e57
if [ ! -f "$file" ]; then
  mkdir -p "$(dirname "$file")"
  build/apo -q simulate-scan datasets/cgal/meshes/bunny00.off --views 8 --rays 3200 --e57 "$file"
fi
echo "load before: $(uptime | sed 's/.*average: //'), $(du -m "$file" | cut -f1) MB"
printf '| round | points | read s | points/s |\n|---|---|---|---|\n'
for round in $(seq "$rounds"); do
  out=$(mktemp -d)
  build/apo -q ingest --no-normals --no-grid-mesh --max-scan-points 0 "$file" -o "$out"
  python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); n=j["counts"]["points_in"]; s=j["seconds"]["read"]; print("| %s | %d | %.2f | %.1f M |" % (sys.argv[2], n, s, n / s / 1e6))' \
    "$out/ingest.json" "$round"
  rm -rf "$out"
done
echo "load after: $(uptime | sed 's/.*average: //')"
