#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (-fsanitize=fuzzer,address,undefined)
# into build-fuzz/ and runs each for SECONDS (default 60), seeded from
# fuzz/corpus/<target>/; the corpus they grow stays in build-fuzz/corpus/.
# A crash, leak, sanitizer report or timeout fails the run and leaves its
# input in build-fuzz/artifacts/. Prints a table of executions per target.
#   bash fuzz/run.sh [SECONDS] [TARGET...]      (targets: ply pcd xyz off obj stl apo config)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(ply pcd xyz off obj stl apo config)
build=build-fuzz
mkdir -p "$build"

CC=clang CXX=clang++ cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DAPO_FUZZ=ON \
  -DAPO_BUILD_TESTS=OFF -DAPO_BUILD_BENCHMARKS=OFF >"$build/configure.log" 2>&1 ||
  { cat "$build/configure.log"; exit 1; }
cmake --build "$build" -j2 --target "${targets[@]/#/fuzz_}" >"$build/build.log" 2>&1 ||
  { tail -n 40 "$build/build.log"; exit 1; }

mkdir -p "$build/artifacts"
summary="$build/fuzz-summary.md"
printf '| target | seconds | executions | exec/s | corpus | result |\n|---|---|---|---|---|---|\n' >"$summary"
failed=0
for target in "${targets[@]}"; do
  mkdir -p "$build/corpus/$target"
  log="$build/fuzz_$target.log"
  # The grown corpus first (new inputs go there), the committed seeds second.
  set +e
  "$build/fuzz_$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 \
    -print_final_stats=1 -artifact_prefix="$build/artifacts/$target-" \
    "$build/corpus/$target" "fuzz/corpus/$target" >"$log" 2>&1
  status=$?
  set -e
  executions=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  corpus=$(find "$build/corpus/$target" -type f | wc -l)
  result=ok
  if [ $status -ne 0 ]; then
    result="FAILED (exit $status, see $log)"
    failed=1
    grep -E 'ERROR|SUMMARY|Test unit written' "$log" | head -n 5 >&2 || true
  fi
  printf '| %s | %s | %s | %s | %s | %s |\n' "$target" "$seconds" "$executions" "$rate" "$corpus" "$result" >>"$summary"
done
cat "$summary"
exit $failed
