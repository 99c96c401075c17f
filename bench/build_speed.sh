#!/usr/bin/env bash
# Issue 14, section 5: the bake's wall time on its three sizes, for several
# builds of apo side by side, runs alternated so that the machine's drift
# touches every build alike:
#   - the 1.2M-triangle bunny (bunny00 Loop-subdivided twice) onto 3,000 faces;
#   - the bumpy torus, 7.2M triangles onto 15,000 (as bench/bake_bench.sh);
#   - 2,084,460 points with their normals (an 8-view simulated scan of the
#     1.2M bunny) onto the bunny's m.
# Defaults (3 MiB budget) unless EXTRA says otherwise. Each bake runs REPEATS
# times (default 3); the table gives every run, whole process wall time, and
# the bake's own setup / build / sample seconds of the fastest.
# A label may end in ":nohuge": that build then runs with glibc's huge-page
# tunable off (GLIBC_TUNABLES=glibc.malloc.hugetlb=0), as apo ran before it
# restarted itself with the tunable on.
# Usage (after the README's setup and build, plus
# `cmake --build build -j2 --target make_detail_mesh open3d_baseline`):
#   bash bench/build_speed.sh OUTDIR LABEL=APO_BINARY [LABEL=APO_BINARY ...]
# e.g. bash bench/build_speed.sh out/speed old:nohuge=/tmp/apo_old new=build/apo
set -euo pipefail
cd "$(dirname "$0")/.."
out=$1
shift
repeats=${REPEATS:-3}
in=$out/inputs
mkdir -p "$in"

if [ ! -f "$in/bunny_1M.ply" ]; then
  build/open3d_baseline subdivide datasets/cgal/meshes/bunny00.off 2 "$in/bunny_1M.ply" >/dev/null
fi
if [ ! -f "$in/bunny_m/m.ply" ]; then
  build/apo -q simplify "$in/bunny_1M.ply" -o "$in/bunny_m" --faces 3000
fi
if [ ! -f "$in/torus_7M.ply" ]; then
  build/make_detail_mesh torus "$in/torus_7M.ply" "$in/torus_m.ply" --nu 3000 --nv 1200 --coarse-nu 150 \
    --coarse-nv 50 --amplitude 0.001 --period-edges 50 >/dev/null
fi
if [ ! -f "$in/points_2M.ply" ]; then
  build/apo -q simulate-scan "$in/bunny_1M.ply" -o "$in/points_2M.ply" --views 8 --rays 1000 --normals
fi

inputs=("bunny_1M:$in/bunny_1M.ply:$in/bunny_m/m.ply" "torus_7M:$in/torus_7M.ply:$in/torus_m.ply"
  "points_2M:$in/points_2M.ply:$in/bunny_m/m.ply")

# One bake: appends "label input wall setup build sample peak_MiB" to runs.txt
# (tab-separated: labels may hold spaces).
bake() {
  local label=$1 binary=$2 name=$3 detail=$4 coarse=$5
  local dir=$out/bakes/$name/${label%%:*}
  local env=()
  [[ $label == *:nohuge ]] && env=(GLIBC_TUNABLES=glibc.malloc.hugetlb=0)
  /usr/bin/time -f "%e %M" -o "$out/time.txt" env "${env[@]}" "$binary" -q bake --detail "$detail" --coarse "$coarse" \
    -o "$dir" ${EXTRA:-}
  python3 - "$dir/bake.json" "$out/time.txt" "${label%%:*}" "$name" >>"$out/runs.txt" <<'EOF'
import json, sys
report = json.load(open(sys.argv[1]))
wall, peak = open(sys.argv[2]).read().split()
s = report["seconds"]
print(sys.argv[3], sys.argv[4], wall, f'{s["setup"]:.2f}', f'{s["build"]:.2f}', f'{s["sample"]:.2f}', int(peak) // 1024, sep="\t")
EOF
}

: >"$out/runs.txt"
for input in "${inputs[@]}"; do
  IFS=: read -r name detail coarse <<<"$input"
  for ((r = 0; r < repeats; r++)); do
    for pair in "$@"; do
      bake "${pair%%=*}" "${pair#*=}" "$name" "$detail" "$coarse"
    done
  done
done

# Same .apo from every build? (A change of the metric may move leaves.)
for input in "${inputs[@]}"; do
  name=${input%%:*}
  sums=$(for pair in "$@"; do label=${pair%%=*}; md5sum <"$out/bakes/$name/${label%%:*}/scan.apo"; done | sort -u | wc -l)
  echo "$name: $sums distinct scan.apo across the builds"
done

python3 - "$out/runs.txt" <<'EOF'
import sys
from collections import defaultdict
runs = defaultdict(list)
order = []
for line in open(sys.argv[1]):
    label, name, wall, setup, build, sample, peak = line.rstrip("\n").split("\t")
    if (name, label) not in runs: order.append((name, label))
    runs[(name, label)].append((float(wall), setup, build, sample, peak))
print("| input | build | whole bake s (process), each run | setup / build / sample s (fastest) | peak MiB |")
print("|---|---|---|---|---|")
for name, label in order:
    r = runs[(name, label)]
    best = min(r)
    print(f"| {name} | {label} | {', '.join(f'{w:.2f}' for w, *_ in r)} | {best[1]} / {best[2]} / {best[3]} | {best[4]} |")
EOF
