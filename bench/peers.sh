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
# Usage (after the README's setup and build, plus
# `cmake --build build -j2 --target open3d_baseline`):
#   bash bench/peers.sh [--install] [OUTDIR]     (OUTDIR default: the repo's out/peers)
# --install first runs apt-get update and install (Debian 12: blender 3.4.1, meshlab
# 2020.09 with meshlabserver, xvfb, xauth, and python3-pil/numpy for the
# check); otherwise nothing is installed and missing tools are named.
# Environment: APO (default build/apo), OPEN3D (build/open3d_baseline), ROUNDS.
# e.g. APO=/tmp/base/apo ROUNDS=5 bash bench/peers.sh --install out/peers
set -euo pipefail
packages=(blender meshlab xvfb xauth python3-pil python3-numpy)
install=0
if [ "${1:-}" = --install ]; then
  install=1
  shift
fi
# Paths given relative to the caller's directory stay so after the cd.
out=${1:+$(realpath -m "$1")}
apo=${APO:+$(realpath -m "$APO")}
open3d=${OPEN3D:+$(realpath -m "$OPEN3D")}
cd "$(dirname "$0")/.."
root=$PWD
out=${out:-$root/out/peers}
apo=${apo:-$root/build/apo}
open3d=${open3d:-$root/build/open3d_baseline}
rounds=${ROUNDS:-5}
in=$out/inputs
side=1024

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
