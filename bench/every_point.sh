#!/usr/bin/env bash
# The APO baked from every point of a scan (apo run --all-points: the point
# store and the bake in bricks; each point's normal its nearest centroid's,
# or fitted to its own nearest points) against the one baked from ingest's voxel
# centroids, both --detail-source points and --max-scan-points 2000000, on
# the 10M-point bunny scan of bench/big_scans.sh (noise and misregistration
# on) and the same scan without them; judged by ../shared/tools/normal_eval.py
# against bunny00, the mesh the scans were simulated from (200,000 probes on
# m, the filtered lookup). Prints the table of docs/benchmarks.md, "Every point".
# Usage (after the README's build): bash bench/every_point.sh   (about 10 minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
truth=datasets/cgal/meshes/bunny00.off
noisy=build/bench_data/bunny-10M.ply
clean=build/bench_data/bunny-10M-clean.ply
[ -f "$noisy" ] || bash bench/big_scans.sh 10 >/dev/null
rays=$(python3 -c "import math; print(round(math.sqrt(10e6 / 8 / 0.2606)))")
[ -f "$clean" ] || build/apo -q simulate-scan "$truth" --views 8 --rays "$rays" --noise 0 --misregistration 0 -o "$clean"
out=$(mktemp -d)
printf '| scan | APO from | normals k | wall s | peak MiB (stage) | store: points, s, MB | bake s | against bunny00: mean / p95 deg |\n|---|---|---|---|---|---|---|---|\n'
for scan in "$noisy" "$clean"; do
  for from in centroids every every-fitted; do
    flag=()
    [ "$from" = every ] && flag=(--all-points --point-normals centroids)
    [ "$from" = every-fitted ] && flag=(--all-points --point-normals fitted)
    run=$out/$(basename "$scan" .ply)-$from
    /usr/bin/time -f '%e' -o "$run.time" build/apo -q run "$scan" -o "$run" --max-scan-points 2000000 --detail-source points "${flag[@]}"
    /usr/bin/python3 ../shared/tools/normal_eval.py "$truth" "$run/m.ply" --apo "$run/scan.apo" \
      --apo-lookup "build/apo -q lookup {apo} {points} -o {out} --filter --coarse $run/m.ply" >"$run.eval"
    python3 - "$run" "$scan" "$from" <<'PY'
import json, re, sys
run, scan, source = sys.argv[1:]
m = json.load(open(run + "/manifest.json"))
r = m["results"]
store = r["ingest"].get("point_store") or {}
evaluated = [l for l in open(run + ".eval") if l.startswith("apo:")][-1]
mean, p95 = re.search(r"mean=([\d.]+)", evaluated).group(1), re.search(r"p95=([\d.]+)", evaluated).group(1)
stored = f"{store['points']:,}, {store['seconds']:.0f}, {store['bytes'] // 10**6}" if store.get("written") else "-"
peak = max(s.get("peak_memory_bytes", 0) for s in m["stages"]) >> 20
print(f"| {scan.split('/')[-1]} | {source} | {r['ingest']['normals']['neighbours']} | {float(open(run + '.time').read()):.0f} | "
      f"{peak:,} | {stored} | {r['bake']['seconds']['total']:.1f} | {mean} / {p95} |")
PY
  done
done
rm -rf "$out"
