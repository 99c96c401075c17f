#!/usr/bin/env bash
# `apo run --all-points` (the point store and the bake of every point in
# bricks) for several builds of apo side by side, runs alternated so that the
# machine's drift touches every build alike, on the 10M-point bunny scan of
# bench/big_scans.sh (or SCAN=...), --max-scan-points 2000000 --detail-source
# points as bench/every_point.sh runs it. Prints one line per run: wall
# seconds and peak (GNU time), the store's seconds, the bake's and its three
# passes', the render's; then whether every build wrote the same scan.apo.
# Usage (after the README's build):
#   [REPEATS=2] [SCAN=FILE] bash bench/all_points_speed.sh LABEL=APO_BINARY [LABEL=APO_BINARY ...]
# e.g. bash bench/all_points_speed.sh old=/tmp/old/build/apo new=build/apo   (about 10 minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
scan=${SCAN:-build/bench_data/bunny-10M.ply}
[ -f "$scan" ] || bash bench/big_scans.sh 10 >/dev/null
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty), $(basename "$scan"), load $(uptime | sed 's/.*average: //')"
for ((round = 1; round <= ${REPEATS:-2}; round++)); do
  for pair in "$@"; do
    label=${pair%%=*}
    run=$out/$label
    rm -rf "$run"
    /usr/bin/time -f '%e %M' -o "$out/time" "${pair#*=}" -q run "$scan" -o "$run" --max-scan-points 2000000 \
      --detail-source points --all-points >/dev/null
    python3 - "$run" "$out/time" "$label" "$round" <<'PY'
import json, sys
run, timing, label, round_ = sys.argv[1:]
m = json.load(open(run + "/manifest.json"))
stages = {s["name"]: s["seconds"] for s in m["stages"]}
passes = m["results"]["bake"]["bricks"]["seconds"]
wall, kb = open(timing).read().split()
print(f"{label} {round_}: wall {float(wall):.1f} s, peak {int(kb) >> 10} MiB, store {m['results']['ingest']['point_store']['seconds']:.1f}, "
      f"bake {stages['bake']:.1f} (areas {passes['areas']:.1f}, refinement {passes['refinement']:.1f}, "
      f"sampling {passes['sampling']:.1f}), render {stages['render']:.1f}", flush=True)
PY
    md5sum <"$run/scan.apo" >"$run.md5"
  done
done
echo "$(cat "$out"/*.md5 | sort -u | wc -l) distinct scan.apo across the builds"
