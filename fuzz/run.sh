#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (-fsanitize=fuzzer,address,undefined)
# into build-fuzz/ and runs each for SECONDS (default 60), seeded from
# fuzz/corpus/<target>/; the corpus they grow stays in build-fuzz/corpus/.
# A crash, leak, sanitizer report or timeout fails the run and leaves its
# input in build-fuzz/artifacts/. Prints a table of executions per target.
#   bash fuzz/run.sh [SECONDS] [TARGET...]      (targets: ply pcd xyz off obj stl las laz e57 apo n3t config)
# FUZZ_RUNS=N stops a target after N executions (whichever comes first);
# FUZZ_JOBS=N runs N targets at a time (default 1).
# FUZZ_MAX_LEN=N caps the inputs at N bytes (libFuzzer's default: the
# largest seed): the E57 and LAZ seeds are up to 500 kB, each a full decode.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(ply pcd xyz off obj stl las laz e57 apo n3t config)
build=build-fuzz
mkdir -p "$build/artifacts"

CC=clang CXX=clang++ cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DAPO_FUZZ=ON \
  -DAPO_BUILD_TESTS=OFF -DAPO_BUILD_BENCHMARKS=OFF >"$build/configure.log" 2>&1 ||
  { cat "$build/configure.log"; exit 1; }
cmake --build "$build" -j2 --target "${targets[@]/#/fuzz_}" >"$build/build.log" 2>&1 ||
  { tail -n 40 "$build/build.log"; exit 1; }

# One target: its row of the table in $build/result_<target>.
fuzz_one() {
  local target=$1 log="$build/fuzz_$1.log" status=0
  mkdir -p "$build/corpus/$target"
  # The grown corpus first (new inputs go there), the committed seeds second.
  "$build/fuzz_$target" -max_total_time="$seconds" ${FUZZ_RUNS:+-runs=$FUZZ_RUNS} ${FUZZ_MAX_LEN:+-max_len=$FUZZ_MAX_LEN} -timeout=10 -rss_limit_mb=2048 \
    -malloc_limit_mb=1024 -print_final_stats=1 -artifact_prefix="$build/artifacts/$target-" \
    "$build/corpus/$target" "fuzz/corpus/$target" >"$log" 2>&1 || status=$?
  local executions rate elapsed corpus result=ok
  executions=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  elapsed=$(grep -o 'Done [0-9]* runs in [0-9]* second' "$log" | grep -o '[0-9]* second' | grep -o '[0-9]*' || echo "$seconds")
  corpus=$(find "$build/corpus/$target" -type f | wc -l)
  if [ "$status" -ne 0 ]; then
    result="FAILED (exit $status, see $log)"
    grep -E 'ERROR|SUMMARY|Test unit written' "$log" | head -n 5 >&2 || true
  fi
  printf '| %s | %s | %s | %s | %s | %s |\n' "$target" "$elapsed" "$executions" "$rate" "$corpus" "$result" \
    >"$build/result_$target"
}
export -f fuzz_one
export build seconds FUZZ_RUNS FUZZ_MAX_LEN

rm -f "$build"/result_*
printf '%s\n' "${targets[@]}" | xargs -P "${FUZZ_JOBS:-1}" -I{} bash -c 'fuzz_one {}'
summary="$build/fuzz-summary.md"
{
  printf '| target | seconds | executions | exec/s | corpus | result |\n|---|---|---|---|---|---|\n'
  for target in "${targets[@]}"; do cat "$build/result_$target"; done
} >"$summary"
cat "$summary"
! grep -q FAILED "$summary"
