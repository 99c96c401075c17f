#!/usr/bin/env bash
# Issue 43, part 1: apo bake against the tools a user would pick instead, in
# the same run, on the 1.2M-triangle bunny (bunny00 Loop-subdivided twice)
# onto its 3,000-face m, each timed as a whole process (wall seconds: the
# program's start, the reading of both meshes, the bake, the writing):
#   - apo bake at its defaults (3 MiB budget, the size of a 1024x1024 RGB map);
#   - Blender 3.4's Cycles normal bake, selected (M) to active (m), at
#     1024x1024: m unwrapped by Smart UV Project, object-space normals, rays
#     within 1% of m's bounding-box diagonal on either side, 1 sample
#     (bench/peers_blender.py; its bake call's own seconds as a second
#     column);
#   - MeshLab 2020.09's per-triangle parametrization of m and its "Transfer:
#     Vertex Attributes to Texture" of M's vertex normals at 1024x1024,
#     closest points within 1% of the diagonal (bench/peers_meshlab.mlx,
#     through meshlabserver under xvfb-run, whose own start `xvfb-run -a true`
#     is timed as a column apart).
# The three run alternated in ROUNDS rounds (default 5) so that the machine's
# drift touches them alike; each output is checked (apo's scan.apo and
# bake.json; each PNG is 1024x1024 and mostly unit normals, bench/peers_png.py)
# and the script stops at the first that is missing or blank. Prints (and
# writes to OUTDIR/peers.md) every round, the medians, the ratios of the
# medians and the median of the rounds' ratios, against the issue's goal:
# apo at least 3x faster than Blender and 1.5x than MeshLab; each one's CPU
# seconds (user + system) beside, and `uptime`'s load before and after, for
# a machine shared with other work. About 1 min a round on two cores
# (Blender ~40 s, half of it its Python PLY import).
# --accuracy adds, after the timed rounds (whose figures it leaves as they
# are), the accuracy of the three at these bytes: each runs once more,
# untimed, into OUTDIR/accuracy (Blender also exporting m with that run's
# UVs as OBJ, bench/peers_blender.py's fourth argument; MeshLab's
# m_textured.ply turned into an OBJ with its per-wedge UVs by
# bench/peers_obj.py), and the independent ../shared/tools/normal_eval.py
# (NORMAL_EVAL; run by /usr/bin/python3, with Debian's python3-open3d)
# measures the angle to M's normal at 200,000 points on m (seed 1): m alone
# (--baseline), apo's scan.apo through `apo lookup --coarse m.ply` with
# --filter and without, and both maps as object-space (n = 2 rgb / 255 - 1
# in m.ply's own axes; OBJ v = 0 at the image's bottom row). A second table
# (mean / median / p95 degrees, bytes) goes into peers.md; the script stops
# instead if m alone is not within 1-20 degrees, a field is not better than
# m alone (a wrong convention, not a figure), or an OBJ's vertices are not
# m.ply's. About 2 min more.
# Usage (after the README's setup and build, plus
# `cmake --build build -j2 --target open3d_baseline`):
#   bash bench/peers.sh [--install] [--accuracy] [OUTDIR]     (OUTDIR default: the repo's out/peers)
# --install first runs apt-get update and install (Debian 12: blender 3.4.1, meshlab
# 2020.09 with meshlabserver, xvfb, xauth, and python3-pil/numpy for the
# check); otherwise nothing is installed and missing tools are named.
# Environment: APO (default build/apo), OPEN3D (build/open3d_baseline), ROUNDS,
# NORMAL_EVAL (default ../shared/tools/normal_eval.py beside the repository; --accuracy only).
# e.g. APO=/tmp/base/apo ROUNDS=5 bash bench/peers.sh --install --accuracy out/peers
set -euo pipefail
packages=(blender meshlab xvfb xauth python3-pil python3-numpy)
install=0
accuracy=0
while [ "${1:-}" = --install ] || [ "${1:-}" = --accuracy ]; do
  case $1 in
    --install) install=1 ;;
    --accuracy) accuracy=1 ;;
  esac
  shift
done
# Paths given relative to the caller's directory stay so after the cd.
out=${1:+$(realpath -m "$1")}
apo=${APO:+$(realpath -m "$APO")}
open3d=${OPEN3D:+$(realpath -m "$OPEN3D")}
normal_eval=${NORMAL_EVAL:+$(realpath -m "$NORMAL_EVAL")}
cd "$(dirname "$0")/.."
root=$PWD
out=${out:-$root/out/peers}
normal_eval=${normal_eval:-$(realpath -m "$root/../shared/tools/normal_eval.py")}
apo=${apo:-$root/build/apo}
open3d=${open3d:-$root/build/open3d_baseline}
rounds=${ROUNDS:-5}
in=$out/inputs
side=1024

((accuracy)) && packages+=(python3-open3d)
if ((install)); then
  apt-get update
  apt-get install -y --no-install-recommends "${packages[@]}"
fi
missing=()
for tool in blender meshlabserver xvfb-run xauth; do
  command -v "$tool" >/dev/null || missing+=("$tool")
done
[ -x /usr/bin/time ] || missing+=(/usr/bin/time)
/usr/bin/python3 -c "import numpy, PIL" 2>/dev/null || missing+=("/usr/bin/python3's numpy and PIL")
if ((accuracy)); then
  /usr/bin/python3 -c "import open3d" 2>/dev/null || missing+=("/usr/bin/python3's open3d")
  [ -f "$normal_eval" ] || missing+=("$normal_eval (NORMAL_EVAL=...)")
fi
if ((${#missing[@]})); then
  echo "peers.sh: missing ${missing[*]}: run bench/peers.sh --install, or" \
    "apt-get install -y --no-install-recommends ${packages[*]} (Debian 12; meshlab 2020.09 has meshlabserver," \
    "later ones do not), or /usr/bin/time from the time package" >&2
  exit 1
fi
for b in "$apo" "$open3d"; do
  [ -x "$b" ] || { echo "peers.sh: $b is not an executable (APO=..., OPEN3D=...)" >&2; exit 1; }
done

mkdir -p "$in"
if [ ! -f "$in/bunny_1M.ply" ]; then
  "$open3d" subdivide datasets/cgal/meshes/bunny00.off 2 "$in/bunny_1M.ply" >/dev/null
fi
if [ ! -f "$in/bunny_m/m.ply" ]; then
  "$apo" -q simplify "$in/bunny_1M.ply" -o "$in/bunny_m" --faces 3000
fi
detail=$in/bunny_1M.ply
coarse=$in/bunny_m/m.ply

# MeshLab writes its texture beside the target mesh's file: m gets a folder
# of its own, and the search radius (1% of m's bounding-box diagonal) goes
# into the filter script.
mkdir -p "$out/apo" "$out/blender" "$out/meshlab"
cp "$coarse" "$out/meshlab/m.ply"
diagonal=$(/usr/bin/python3 - "$coarse" <<'EOF'
import sys
import numpy as np
types = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4", "float": "f4",
         "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2", "int32": "i4", "uint32": "u4",
         "float32": "f4", "float64": "f8"}
data = open(sys.argv[1], "rb").read()
end = data.index(b"end_header\n") + len(b"end_header\n")
header = data[:end].decode().split("\n")
assert "format binary_little_endian 1.0" in header, "m.ply is not binary little-endian"
count, fields, element = 0, [], None
for line in header:
    words = line.split()
    if words[:1] == ["element"]:
        element = words[1]
        if element == "vertex": count = int(words[2])
    elif words[:1] == ["property"] and element == "vertex":
        fields.append((words[2], "<" + types[words[1]]))
vertices = np.frombuffer(data, dtype=np.dtype(fields), count=count, offset=end)
xyz = np.stack([vertices["x"], vertices["y"], vertices["z"]], axis=1).astype(np.float64)
print(repr(float(np.linalg.norm(xyz.max(axis=0) - xyz.min(axis=0)))))
EOF
)
max_dist=$(python3 -c "print(repr(0.01 * $diagonal))")
sed -e "s/@MAX_DIST@/$max_dist/g" -e "s/@DIAGONAL@/$diagonal/g" bench/peers_meshlab.mlx >"$out/meshlab/peers.mlx"

apo_cmd=("$apo" bake --detail "$detail" --coarse "$coarse" -o "$out/apo")
blender_cmd=(blender -b --factory-startup --python-exit-code 1 --python "$root/bench/peers_blender.py" -- "$detail"
  "$coarse" "$out/blender/normals.png")
meshlab_cmd=(xvfb-run -a meshlabserver -i "$detail" -i "$out/meshlab/m.ply" -o "$out/meshlab/m_textured.ply" -m wt
  -s "$out/meshlab/peers.mlx")

# One contender's run: "WALL CPU" seconds on stdout (CPU: user + system, of
# the process and its children); its output in LOG.
timed() {
  local log=$1
  shift
  if ! /usr/bin/time -f "%e %U %S" -o "$out/peers_time.txt" "$@" >"$log" 2>&1; then
    echo "peers.sh: failed (exit code $?): $*; see $log" >&2
    tail -20 "$log" >&2
    exit 1
  fi
  awk '{ printf "%s %.2f\n", $1, $2 + $3 }' "$out/peers_time.txt"
}
check_png() {
  /usr/bin/python3 bench/peers_png.py "$1" "$side" >"$1.check.txt" ||
    { echo "peers.sh: $2 gave no normal map: $(cat "$1.check.txt")" >&2; exit 1; }
}

load_before=$(uptime)
: >"$out/peers_runs.tsv"
for ((r = 1; r <= rounds; r++)); do
  echo "peers.sh: round $r of $rounds" >&2
  rm -rf "$out/apo"
  apo_s=$(timed "$out/apo.log" "${apo_cmd[@]}")
  [ -f "$out/apo/bake.json" ] && [ "$(stat -c %s "$out/apo/scan.apo" 2>/dev/null || echo 0)" -gt 100000 ] ||
    { echo "peers.sh: apo bake wrote no scan.apo of over 100 kB or no bake.json in $out/apo" >&2; exit 1; }

  rm -f "$out/blender/normals.png"
  blender_s=$(timed "$out/blender.log" "${blender_cmd[@]}")
  blender_bake=$(sed -n 's/^peers_blender: .*bake_seconds \([0-9.]*\).*/\1/p' "$out/blender.log")
  [ -n "$blender_bake" ] || { echo "peers.sh: no bake_seconds in $out/blender.log" >&2; exit 1; }
  check_png "$out/blender/normals.png" Blender

  rm -f "$out/meshlab/peers_meshlab_normals.png" "$out/meshlab/m_textured.ply"
  meshlab_s=$(timed "$out/meshlab.log" "${meshlab_cmd[@]}")
  [ -f "$out/meshlab/m_textured.ply" ] || { echo "peers.sh: MeshLab wrote no m_textured.ply" >&2; exit 1; }
  check_png "$out/meshlab/peers_meshlab_normals.png" MeshLab
  xvfb_s=$(timed "$out/xvfb.log" xvfb-run -a true)

  # wall and CPU seconds: apo, Blender, Blender's bake call (wall), MeshLab, xvfb-run alone.
  echo "$apo_s $blender_s $blender_bake $meshlab_s $xvfb_s" >>"$out/peers_runs.tsv"
done
load_after=$(uptime)

{
  echo "Same-run speed against the peers (bench/peers.sh), $(date -u '+%Y-%m-%d %H:%M UTC'), commit" \
    "$(git rev-parse --short HEAD), $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //')"
  echo
  echo "- apo: $("$apo" --version 2>&1 | head -1): \`apo bake --detail bunny_1M.ply --coarse bunny_m/m.ply -o OUT\`" \
    "(defaults: 3 MiB budget, rays within 1% of m's bounding-box diagonal)"
  echo "- Blender: $(blender --version 2>/dev/null | head -1): \`blender -b --factory-startup --python-exit-code 1" \
    "--python bench/peers_blender.py -- bunny_1M.ply bunny_m/m.ply OUT.png\` (Cycles CPU, ${side}x${side}," \
    "selected to active, OBJECT normal space, cage extrusion 1% and max ray distance 2% of the diagonal, 1 sample," \
    "Smart UV Project with island margin 0.005, margin 16 px)"
  echo "- MeshLab: meshlab $(dpkg-query -W -f='${Version}' meshlab 2>/dev/null || echo '(version unknown)'):" \
    "\`xvfb-run -a meshlabserver -i bunny_1M.ply -i m.ply -o m_textured.ply -m wt -s peers.mlx\`" \
    "(bench/peers_meshlab.mlx: Trivial Per-Triangle at ${side} px, then Vertex Normal transferred from M within" \
    "$max_dist, i.e. 1% of the diagonal $diagonal, ${side}x${side})"
  echo "- load before: ${load_before#*load average: }; after: ${load_after#*load average: }"
  echo
  python3 - "$out/peers_runs.tsv" <<'EOF'
import statistics, sys
kBlenderGoal, kMeshlabGoal = 3.0, 1.5
# Per round: apo wall, CPU; Blender wall, CPU; its bake call; MeshLab wall, CPU; xvfb-run wall, CPU.
rows = [[float(x) for x in line.split()] for line in open(sys.argv[1]) if line.strip()]
rows = [(r[0], r[2], r[4], r[5], r[7], r[1], r[3], r[6]) for r in rows]
median = statistics.median
print("| round | apo s | Blender s | Blender's bake call s | MeshLab s | xvfb-run alone s | Blender / apo "
      "| MeshLab / apo | CPU s: apo / Blender / MeshLab |")
print("|---|---|---|---|---|---|---|---|---|")
for i, (apo, blender, bake, meshlab, xvfb, apo_cpu, blender_cpu, meshlab_cpu) in enumerate(rows, 1):
    print(f"| {i} | {apo:.2f} | {blender:.2f} | {bake:.2f} | {meshlab:.2f} | {xvfb:.2f} | {blender / apo:.2f} "
          f"| {meshlab / apo:.2f} | {apo_cpu:.2f} / {blender_cpu:.2f} / {meshlab_cpu:.2f} |")
cols = list(zip(*rows))
m = [median(c) for c in cols]
per_round_b = median(r[1] / r[0] for r in rows)
per_round_m = median(r[3] / r[0] for r in rows)
print(f"| median | {m[0]:.2f} | {m[1]:.2f} | {m[2]:.2f} | {m[3]:.2f} | {m[4]:.2f} | {m[1] / m[0]:.2f} "
      f"| {m[3] / m[0]:.2f} | {m[5]:.2f} / {m[6]:.2f} / {m[7]:.2f} |")
print()
print(f"Ratios of the medians: Blender / apo {m[1] / m[0]:.2f}, MeshLab / apo {m[3] / m[0]:.2f}; medians of the "
      f"rounds' ratios: {per_round_b:.2f} and {per_round_m:.2f} ({len(rows)} rounds).")
met = lambda r, goal: "met" if r >= goal else "NOT met"
print(f"Goal (issue 43), whole process each: apo >= {kBlenderGoal:g}x faster than Blender: "
      f"{met(m[1] / m[0], kBlenderGoal)} ({m[1] / m[0]:.2f}x); >= {kMeshlabGoal:g}x faster than MeshLab: "
      f"{met(m[3] / m[0], kMeshlabGoal)} ({m[3] / m[0]:.2f}x).")
EOF
  echo
  echo "Outputs checked in the last round: Blender's $(cat "$out/blender/normals.png.check.txt");" \
    "MeshLab's $(cat "$out/meshlab/peers_meshlab_normals.png.check.txt"); apo's scan.apo" \
    "$(stat -c %s "$out/apo/scan.apo") bytes."
} >"$out/peers.md"
cat "$out/peers.md"

((accuracy)) || exit 0

# The accuracy pass: each contender once more, untimed, into $acc; then
# normal_eval.py on each output (and on m alone).
acc=$out/accuracy
echo "peers.sh: accuracy pass (untimed) into $acc" >&2
rm -rf "$acc"
mkdir -p "$acc/blender" "$acc/meshlab"
run() {
  local log=$1
  shift
  "$@" >"$log" 2>&1 || { echo "peers.sh: failed (exit code $?): $*; see $log" >&2; tail -20 "$log" >&2; exit 1; }
}
run "$acc/apo.log" "$apo" bake --detail "$detail" --coarse "$coarse" -o "$acc/apo"
[ "$(stat -c %s "$acc/apo/scan.apo" 2>/dev/null || echo 0)" -gt 100000 ] ||
  { echo "peers.sh: apo bake wrote no scan.apo of over 100 kB in $acc/apo" >&2; exit 1; }
run "$acc/blender.log" "${blender_cmd[@]:0:${#blender_cmd[@]}-1}" "$acc/blender/normals.png" "$acc/blender/m_uv.obj"
check_png "$acc/blender/normals.png" Blender
[ -s "$acc/blender/m_uv.obj" ] || { echo "peers.sh: Blender exported no $acc/blender/m_uv.obj" >&2; exit 1; }
cp "$coarse" "$acc/meshlab/m.ply"
cp "$out/meshlab/peers.mlx" "$acc/meshlab/peers.mlx"
run "$acc/meshlab.log" xvfb-run -a meshlabserver -i "$detail" -i "$acc/meshlab/m.ply" -o "$acc/meshlab/m_textured.ply" \
  -m wt -s "$acc/meshlab/peers.mlx"
check_png "$acc/meshlab/peers_meshlab_normals.png" MeshLab
run "$acc/meshlab_obj.log" /usr/bin/python3 bench/peers_obj.py "$acc/meshlab/m_textured.ply" "$acc/meshlab/m_uv.obj"

# name, m as the field sees it, normal_eval.py's evaluator; one JSON each.
evaluate() {
  local name=$1 mesh=$2
  shift 2
  run "$acc/eval_$name.log" /usr/bin/python3 "$normal_eval" "$detail" "$mesh" "$@" --label "$name" \
    --json "$acc/eval_$name.json"
}
evaluate m "$coarse" --baseline
evaluate apo_filtered "$coarse" --apo "$acc/apo/scan.apo" \
  --apo-lookup "$apo lookup --filter --coarse $coarse {apo} {points} -o {out}"
evaluate apo_plain "$coarse" --apo "$acc/apo/scan.apo" --apo-lookup "$apo lookup --coarse $coarse {apo} {points} -o {out}"
evaluate blender "$acc/blender/m_uv.obj" --map "$acc/blender/normals.png" --space object
evaluate meshlab "$acc/meshlab/m_uv.obj" --map "$acc/meshlab/peers_meshlab_normals.png" --space object

# m.ply against the OBJs the maps are read on: the same vertices (so the
# maps' object space is m.ply's frame), or the figures are not comparable.
if ! PYTHONPATH="$(dirname "$normal_eval")" /usr/bin/python3 - "$coarse" "$acc/blender/m_uv.obj" \
  "$acc/meshlab/m_uv.obj" >"$acc/vertices.txt" 2>&1 <<'EOF'; then
import sys
import numpy as np
import normal_eval
m = normal_eval.read_mesh(sys.argv[1])
bad = []
for path in sys.argv[2:]:
    obj = normal_eval.read_mesh(path)
    if obj.V.shape != m.V.shape or obj.F.shape != m.F.shape:
        bad.append(f"{path}: {len(obj.V)} vertices, {len(obj.F)} faces, m.ply {len(m.V)} and {len(m.F)}")
        continue
    # Vertex by vertex, else (if an exporter reordered them) as sorted coordinates.
    dv = np.abs(obj.V - m.V).max()
    if dv > 1e-5:
        dv = np.abs(np.sort(obj.V, axis=0) - np.sort(m.V, axis=0)).max()
    print(f"{path.split('/')[-2]}'s largest coordinate difference from m.ply {dv:.1g}")
    if dv > 1e-5:
        bad.append(f"{path}: coordinates differ from m.ply's by up to {dv:.3g} (axes converted?)")
if bad:
    sys.exit("; ".join(bad))
EOF
  echo "peers.sh: the maps' OBJs are not m.ply: $(cat "$acc/vertices.txt")" >&2
  exit 1
fi

scan_bytes=$(stat -c %s "$acc/apo/scan.apo")
/usr/bin/python3 - "$acc" "$scan_bytes" "$side" >"$acc/accuracy_table.md" <<'EOF' || exit 1
import json, os, sys
acc, scan_bytes, side = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
png = {key: os.path.getsize(os.path.join(acc, path)) for key, path in
       (("blender", "blender/normals.png"), ("meshlab", "meshlab/peers_meshlab_normals.png"))}
rows = [("m alone (its vertex normals)", "m", "0 (m.ply's own normals)"),
        ("apo, filtered (`lookup --filter`)", "apo_filtered", f"{scan_bytes:,} (scan.apo)"),
        ("apo, plain (`lookup`)", "apo_plain", f"{scan_bytes:,} (scan.apo)"),
        (f"Blender 3.4, Cycles object-space bake, {side}x{side}", "blender",
         f"{side * side * 3:,} ({side}x{side}x3; PNG file {png['blender']:,})"),
        (f"MeshLab 2020.09, per-triangle transfer, {side}x{side}", "meshlab",
         f"{side * side * 3:,} ({side}x{side}x3; PNG file {png['meshlab']:,})")]
results = {key: json.load(open(os.path.join(acc, f"eval_{key}.json"))) for _, key, _ in rows}
problems = []
base = results["m"]["stats"]["mean"]
if not 1.0 <= base <= 20.0:
    problems.append(f"m alone {base:.2f} degrees mean, not within 1-20")
for _, key, _ in rows[1:]:
    mean = results[key]["stats"]["mean"]
    if not mean < base:
        problems.append(f"{key} {mean:.2f} degrees mean, not below m alone's {base:.2f} (a wrong convention?)")
    if results[key].get("invalid"):
        problems.append(f"{key}: {results[key]['invalid']} points with no answer")
if problems:
    sys.exit("peers.sh: accuracy not reported: " + "; ".join(problems))
print("| field | bytes | mean deg | median deg | p95 deg |")
print("|---|---|---|---|---|")
for name, key, size in rows:
    s = results[key]["stats"]
    print(f"| {name} | {size} | {s['mean']:.3f} | {s['median']:.3f} | {s['p95']:.3f} |")
EOF
{
  echo
  echo "Same-run accuracy at these bytes (bench/peers.sh --accuracy: each contender run once more, untimed, into" \
    "accuracy/), by $(basename "$normal_eval") (independent of apo: 200,000 points on m by area, seed 1; the" \
    "truth is M's area-weighted vertex normal interpolated at M's closest point; the angle in degrees to the" \
    "stored normal). apo: \`apo lookup [--filter] --coarse m.ply scan.apo\` (filtered: trilinear, as the shader" \
    "with filtering on). Maps: object space, n = normalize(2 rgb / 255 - 1) in m.ply's axes, bilinear at the" \
    "point's UV (OBJ convention, v = 0 at the image's bottom row), on m exported with the bake's own UVs" \
    "(Blender: its OBJ exporter, forward Y up Z, i.e. no axis change; MeshLab: m_textured.ply's per-wedge UVs," \
    "bench/peers_obj.py); $(paste -sd ';' "$acc/vertices.txt" | sed 's/;/; /g')."
  echo
  cat "$acc/accuracy_table.md"
} >"$acc/accuracy.md"
cat "$acc/accuracy.md" >>"$out/peers.md"
cat "$acc/accuracy.md"
