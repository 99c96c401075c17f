#!/usr/bin/env bash
# Our LAZ decoder against LAZperf's (npm laz-perf, its C++ compiled to WASM,
# under Node.js) in the same run: each decompresses each file to its raw
# point records REPEATS times in one process (default 3: laz-perf's first
# run compiles its WASM), in ROUNDS rounds alternated (default 5), the best
# wall time of each kept; both start from the file in memory and include
# opening it (header, LASzip VLR, chunk table) and every record, neither its
# reading from disk nor hashing. The records' SHA-256 must agree or the
# script stops.
# Prints points/s for each and the ratio, with `uptime`'s load before and
# after (the machine may be shared).
#   [REPEATS=3] bash bench/laz_bench.sh [ROUNDS] [FILE.laz ...]
# Defaults: ../shared/data/laz/lone-star.copc.laz (518,862 points, COPC,
# compressor 3) and fuzz/corpus/laz/simple.laz (1,065 points, compressor 2).
#   [REPEATS=3] bash bench/laz_bench.sh --simulated [ROUNDS]
# instead makes a LAZ file of 21,350,000-odd points with our own writer
# (apo simulate-scan of the bundled Stanford bunny, 8 views of 3,200 x 3,200
# rays; LASzip compressor 2, point format 0) in build/bench_data, unless it
# is there already, and times it: a scanner-sized file where the fixed costs
# (opening the file, WASM start-up) no longer count.
# Needs build/laz_speed (cmake --build build --target laz_speed) and npm ci;
# --simulated also build/apo (--target apo).
set -euo pipefail
cd "$(dirname "$0")/.."
simulated=
if [ "${1:-}" = --simulated ]; then
  simulated=build/bench_data/bunny-8x3200.laz
  shift
fi
rounds=${1:-5}
repeats=${REPEATS:-3}
shift || true
files=("$@")
if [ -n "$simulated" ]; then
  if [ ! -f "$simulated" ]; then
    mkdir -p "$(dirname "$simulated")"
    build/apo simulate-scan datasets/cgal/meshes/bunny00.off --views 8 --rays 3200 --laz "$simulated"
  fi
  files=("$simulated")
fi
[ ${#files[@]} -gt 0 ] || files=(../shared/data/laz/lone-star.copc.laz fuzz/corpus/laz/simple.laz)
echo "load before: $(uptime)"
printf '| file | points | apo s | apo points/s | laz-perf s | laz-perf points/s | laz-perf time / apo time |\n|---|---|---|---|---|---|---|\n'
for file in "${files[@]}"; do
  ours=1e9 theirs=1e9 points=0
  for _ in $(seq "$rounds"); do
    a=$(build/laz_speed "$file" "$repeats")
    b=$(node tests/ingest/lazperf_decode.mjs "$file" --repeat "$repeats")
    read -r points sha_a seconds_a < <(python3 -c 'import json,sys; d=json.loads(sys.argv[1]); print(d["points"], d["sha256"], d["seconds"])' "$a")
    read -r _ sha_b seconds_b < <(python3 -c 'import json,sys; d=json.loads(sys.argv[1]); print(d["points"], d["sha256"], d["seconds"])' "$b")
    [ "$sha_a" = "$sha_b" ] || { echo "$file: the records differ (apo $sha_a, laz-perf $sha_b)" >&2; exit 1; }
    ours=$(python3 -c "print(min($ours, $seconds_a))")
    theirs=$(python3 -c "print(min($theirs, $seconds_b))")
  done
  python3 -c "
p, a, b = $points, $ours, $theirs
print(f'| $(basename "$file") | {p:,} | {a:.4f} | {p / a / 1e6:.2f} M | {b:.4f} | {p / b / 1e6:.2f} M | {b / a:.2f} |')"
done
echo "load after: $(uptime)"
