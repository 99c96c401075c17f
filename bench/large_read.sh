#!/usr/bin/env bash
# Issue 45 §1: `apo ingest` of a scan above --max-scan-points, format by
# format, each read a run at a time into voxel centroids (docs/ingest.md,
# "Large scans"); at --max-scan-points 1000000, so that what is kept weighs
# little beside the read, and the XYZ text, the E57 and the compressed PCD
# also read whole (--max-scan-points 0: what they were before their runs).
# The scan: bunny00 by `apo simulate-scan` (8 views, noise and
# misregistration on), MILLIONS million points (default 20), written as
# binary PLY, LAS, LAZ and E57 (one scan per view, with its grid), as a
# binary_compressed PCD of x y z (by Open3D, from the PLY), and from those points as XYZ text (x y z, 5
# decimals) and ASCII PLY (the same lines behind a PLY header), into
# build/bench_data/ unless there already (not committed). Prints wall
# seconds and peak MiB (GNU time) of each ingest, with `uptime`'s load
# before and after (the machine may be shared).
#   bash bench/large_read.sh [MILLIONS]      (about 8 minutes at 20)
# Needs build/apo (cmake --build build --target apo).
set -euo pipefail
cd "$(dirname "$0")/.."
millions=${1:-20}
stem=build/bench_data/read-${millions}M
mkdir -p build/bench_data
# 8 views of r x r rays hit bunny00 about 26% of the time.
rays=$(python3 -c "import math,sys; print(round(math.sqrt(float(sys.argv[1]) * 1e6 / 8 / 0.2606)))" "$millions")
if [ ! -f "$stem.laz" ]; then
  build/apo -q simulate-scan datasets/cgal/meshes/bunny00.off --views 8 --rays "$rays" \
    -o "$stem.ply" --las "$stem.las" --laz "$stem.laz"
fi
if [ ! -f "$stem.e57" ]; then  # the same seed: the same points
  build/apo -q simulate-scan datasets/cgal/meshes/bunny00.off --views 8 --rays "$rays" --e57 "$stem.e57"
fi
if [ ! -f "$stem.zpcd.pcd" ]; then
  /usr/bin/python3 -c "import open3d as o3d, sys; o3d.io.write_point_cloud(sys.argv[2], o3d.io.read_point_cloud(sys.argv[1]), compressed=True)" \
    "$stem.ply" "$stem.zpcd.pcd"
fi
if [ ! -f "$stem.ascii.ply" ]; then
  /usr/bin/python3 - "$stem" <<'EOF'
import sys
import numpy as np
stem = sys.argv[1]
raw = open(stem + ".ply", "rb").read()
end = raw.index(b"end_header\n") + len(b"end_header\n")
header = raw[:end].decode()
count = int(next(l.split()[2] for l in header.splitlines() if l.startswith("element vertex")))
names = [l.split()[2] for l in header.splitlines() if l.startswith("property")]
types = {"float": "<f4", "double": "<f8", "uchar": "u1", "uint8": "u1", "int": "<i4", "uint": "<u4", "ushort": "<u2"}
dtype = np.dtype([(n, types[l.split()[1]]) for n, l in zip(names, [l for l in header.splitlines() if l.startswith("property")])])
vertices = np.frombuffer(raw, dtype=dtype, count=count, offset=end)
origin = [0.0, 0.0, 0.0]
for line in header.splitlines():
    if line.startswith("comment apo_origin"):
        origin = [float(v) for v in line.split()[2:5]]
xyz = np.stack([vertices["x"] + origin[0], vertices["y"] + origin[1], vertices["z"] + origin[2]], axis=1)
with open(stem + ".xyz", "w") as out:
    np.savetxt(out, xyz, fmt="%.5f")
body = open(stem + ".xyz", "rb")
with open(stem + ".ascii.ply", "wb") as out:
    out.write(f"ply\nformat ascii 1.0\nelement vertex {count}\nproperty double x\nproperty double y\n"
              f"property double z\nend_header\n".encode())
    while True:
        block = body.read(1 << 24)
        if not block:
            break
        out.write(block)
EOF
fi
echo "load before: $(uptime | sed 's/.*average: //')"
printf '| file | MB | read | wall s | peak MiB | points in file | kept |\n|---|---|---|---|---|---|---|\n'
for file in "$stem.ply" "$stem.las" "$stem.laz" "$stem.xyz" "$stem.ascii.ply" "$stem.e57" "$stem.zpcd.pcd"; do
  limits=(1000000)
  case "$file" in *.xyz | *.e57 | *.zpcd.pcd) limits+=(0) ;; esac
  for limit in "${limits[@]}"; do
    out=$(mktemp -d)
    args=(--max-scan-points "$limit")
    /usr/bin/time -f '%e %M' -o "$out.time" build/apo -q ingest "$file" -o "$out/ingest" "${args[@]}" >"$out.log" 2>&1 ||
      { tail -n 20 "$out.log"; exit 1; }
    python3 - "$out" "$file" "$limit" <<'EOF'
import json, os, sys
out, path, limit = sys.argv[1:]
wall, peak_kib = open(out + ".time").read().split()
ingest = json.load(open(os.path.join(out, "ingest", "ingest.json")))
large = ingest.get("large_scan") or {}
points = large.get("points_in_file", ingest["counts"]["points_in"])
how = "runs into centroids" if large else "whole"
print(f"| {os.path.basename(path)} | {os.path.getsize(path) / 1e6:.0f} | {how} | {float(wall):.1f} | "
      f"{int(peak_kib) // 1024} | {points:,} | {ingest['counts']['points_out']:,} |")
EOF
    rm -rf "$out" "$out.time" "$out.log"
  done
done
echo "load after: $(uptime | sed 's/.*average: //')"
