#!/usr/bin/env bash
# Issue 14, section 5, the 1.2M-triangle bunny onto 3,000 faces, judged in
# one go against two baselines run beside it, since this machine's speed
# drifts by a third between hours (docs/benchmarks.md: the host backing the
# guest's fresh pages):
#   - the build the issue was filed against (fba80e1, at its own defaults,
#     `--error 0.05`), which took 2.97 s when the issue set the 2.0 s target:
#     the target in this go is 2.0 x (its time now) / 2.97;
#   - the Embree bound, as the earlier stops took it: M's Morton BVH built
#     on two threads (bench/embree_options, CPU seconds / 2) plus the bake's
#     2.8M rays (1.26M sampling, 1.2M from M's vertices, the rest from the
#     triangle centres left) at the rays per second the head's own sampling
#     reached in that round (its time less its wait for the BVH); and a
#     tighter one, the same rays at Embree's own rate (bench/embree_options'
#     rays from M's triangles on one thread, counted twice for two cores),
#     without the sampling's own work.
# Each round runs the three, the order of the two bakes alternating from one
# round to the next. Prints every round and the medians, and how many rounds
# meet each target.
# Usage (after `bash bench/build_speed.sh OUT ...` made OUT/inputs, and
# `cmake --build build --target embree_options`):
#   ROUNDS=10 bash bench/bunny_target.sh OUT BASELINE_APO [HEAD_APO]
# where BASELINE_APO is `apo` built at fba80e1 (a git worktree:
#   git worktree add /tmp/base fba80e1 && cmake -S /tmp/base -B /tmp/base/build
#   -DCMAKE_BUILD_TYPE=Release && cmake --build /tmp/base/build --target apo).
set -euo pipefail
cd "$(dirname "$0")/.."
out=$1
baseline=$2
head=${3:-build/apo}
rounds=${ROUNDS:-10}
in=$out/inputs
for f in "$in/bunny_1M.ply" "$in/bunny_m/m.ply"; do
  [ -f "$f" ] || { echo "bunny_target.sh: $f missing: run bench/build_speed.sh $out first" >&2; exit 1; }
done
for b in "$baseline" "$head" build/embree_options; do
  [ -x "$b" ] || { echo "bunny_target.sh: $b is not an executable" >&2; exit 1; }
done

# One bake: its whole-process wall time; its log (-v) in DIR/log.txt.
bake() {
  mkdir -p "$2"
  /usr/bin/time -f "%e" -o "$out/target_time.txt" "$1" -v bake --detail "$in/bunny_1M.ply" \
    --coarse "$in/bunny_m/m.ply" -o "$2" 2>"$2/log.txt"
  cat "$out/target_time.txt"
}

: >"$out/target_runs.tsv"
for ((r = 0; r < rounds; r++)); do
  if ((r % 2 == 0)); then
    base_wall=$(bake "$baseline" "$out/target_base")
    head_wall=$(bake "$head" "$out/target_head")
  else
    head_wall=$(bake "$head" "$out/target_head")
    base_wall=$(bake "$baseline" "$out/target_base")
  fi
  read -r bvh_cpu ray_cpu embree_rays < <(build/embree_options "$in/bunny_1M.ply" 2 1 morton |
    awk '/^morton/ {gsub(/\(/, "", $8); print $3, $6, $8}')
  read -r rays sample < <(python3 -c "import json,sys; r=json.load(open(sys.argv[1])); print(r['sampling']['rays'], r['seconds']['sample'])" \
    "$out/target_head/bake.json")
  # The sampling's wait for M's BVH (logged from 0.01 s on), which the head
  # builds when the sampling asks for it: not the sampling's own work.
  waited=$(sed -n "s/.*the sampling waited \([0-9.]*\) s for M's ray caster$/\1/p" "$out/target_head/log.txt")
  md5=$(md5sum <"$out/target_head/scan.apo" | cut -c1-12)
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$base_wall" "$head_wall" "$bvh_cpu" "$rays" "$sample" \
    "${waited:-0}" "$ray_cpu" "$embree_rays" "$md5" >>"$out/target_runs.tsv"
done

python3 - "$out/target_runs.tsv" <<'EOF'
import statistics, sys
kFiledAt, kTarget, kRays, kTimesBound = 2.97, 2.0, 2.8e6, 3.0
rows = [line.split("\t") for line in open(sys.argv[1]) if line.strip()]
print("| round | fba80e1 s | head s | target this round s | head / fba80e1 | Embree bound s | head / bound "
      "| bound at Embree's rate s | head / it |")
print("|---|---|---|---|---|---|---|---|---|")
ratios, bounds, tight, targets, heads = [], [], [], [], []
for i, (base, head, bvh, rays, sample, waited, ray_cpu, embree_rays, _) in enumerate(rows, 1):
    base, head = float(base), float(head)
    bound = float(bvh) / 2 + kRays / (float(rays) / (float(sample) - float(waited)))
    tighter = float(bvh) / 2 + kRays / (2 * float(embree_rays) / float(ray_cpu))
    target = kTarget * base / kFiledAt
    ratios.append(head / base); bounds.append(head / bound); tight.append(head / tighter)
    targets.append(target); heads.append(head)
    print(f"| {i} | {base:.2f} | {head:.2f} | {target:.2f} | {head / base:.3f} | {bound:.3f} | {head / bound:.2f} "
          f"| {tighter:.3f} | {head / tighter:.2f} |")
median = statistics.median
print(f"\nmedians: head {median(heads):.3f} s, head / fba80e1 {median(ratios):.3f} "
      f"(target {kTarget / kFiledAt:.3f}), head / Embree bound {median(bounds):.2f} (target {kTimesBound:.0f}), "
      f"head / the bound at Embree's rate {median(tight):.2f}")
print(f"rounds meeting the scaled 2.0 s: {sum(h <= t for h, t in zip(heads, targets))} of {len(rows)}; "
      f"within 3x of the bound: {sum(b <= kTimesBound for b in bounds)} of {len(rows)}; "
      f"under 2.0 s as such: {sum(h <= kTarget for h in heads)} of {len(rows)}")
print(f"distinct head scan.apo: {len(set(row[8].strip() for row in rows))}")
EOF
