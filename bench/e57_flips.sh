#!/usr/bin/env bash
# Issue 44: what the normals still flipped with scan positions are, and
# what per-scan neighbourhoods would change (docs/benchmarks.md, "Scan
# positions"). The camel (or MESH) scanned from 10 positions as bench/e57_scans.sh
# scans it (the same seed: the same points), also as LAS, whose point source
# ids name each point's scan; `apo ingest` of the E57 as points (normals
# towards their own scan positions); then, on the same points:
#   - the flipped normals (against the true ones) by how far their line is
#     from the truth (|cos| under 0.5: the plane fitted is wrong, whichever
#     way it is turned) and by how squarely their scanner saw them;
#   - PCA over each point's k nearest of its own scan only (one scanner
#     cannot see both faces of a thin part), turned towards the scanner;
#   - the product's normals re-signed by those per-scan normals where the
#     product saw the point at a grazing angle.
# Usage (after the README's setup and build):
#   [MESH=datasets/cgal/meshes/elephant.off] bash bench/e57_flips.sh [OUTDIR]   (about 1 minute)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/e57_flips}
mesh=${MESH:-datasets/cgal/meshes/camel.off}
mkdir -p "$out"
build/apo -q simulate-scan "$mesh" --views 10 --rays 300 -o "$out/truth.ply" --normals
build/apo -q simulate-scan "$mesh" --views 10 --rays 300 -o "$out/scan.ply" --e57 "$out/scan.e57" --las "$out/scan.las"
rm -rf "$out/ingest"
build/apo -q ingest "$out/scan.e57" --no-grid-mesh -o "$out/ingest"
/usr/bin/python3 - "$out" <<'PY'
import json, struct, sys
import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree
out = sys.argv[1]
raw = open(f"{out}/scan.las", "rb").read()
offset, length, count = struct.unpack_from("<I", raw, 96)[0], struct.unpack_from("<H", raw, 105)[0], struct.unpack_from("<I", raw, 107)[0]
records = np.frombuffer(raw[offset:offset + length * count], dtype=np.uint8).reshape(count, length)
station = records[:, 18:20].copy().view("<u2").ravel()  # point source id: the scan
ingest = json.load(open(f"{out}/ingest/ingest.json"))
positions = np.array([s["position"] for s in ingest["scan_positions"]])
truth = o3d.io.read_point_cloud(f"{out}/truth.ply")
p, t = np.asarray(truth.points), np.asarray(truth.normals)
scan = o3d.io.read_point_cloud(f"{out}/scan.ply")
assert np.allclose(np.asarray(scan.points), p), "scan.ply and truth.ply hold other points"
assert len(station) == len(p)
ours = o3d.io.read_point_cloud(f"{out}/ingest/scan.ply")
_, match = cKDTree(p).query(np.asarray(ours.points) + np.array(ingest["origin"]))
product = np.zeros_like(p)
product[match] = np.asarray(ours.normals)
view = positions[station] - p
view /= np.linalg.norm(view, axis=1)[:, None]

def pca(points, k):
    _, neighbours = cKDTree(points).query(points, k)
    offsets = points[neighbours] - points[:, None, :]
    return np.linalg.eigh(np.einsum("nki,nkj->nij", offsets, offsets))[1][:, :, 0]

def row(name, normals):
    cos = np.clip(np.sum(normals * t, axis=1), -1, 1)
    print(f"| {name} | {int((cos < 0).sum())} | {np.degrees(np.arccos(cos)).mean():.2f} |")

cos = np.sum(product * t, axis=1)
flipped = cos < 0
print(f"{len(p):,} points, {int(flipped.sum())} flipped by the product; of those, "
      f"{int((flipped & (np.abs(cos) < 0.5)).sum())} with a line over 60 deg from the truth, "
      f"{int((flipped & (np.sum(t * view, axis=1) < 0.3)).sum())} seen at a grazing angle (true cosine to the scanner under 0.3)\n")
print("| normals | flipped | mean angle to the truth (deg) |\n|---|---|---|")
row("the product (ingest, scan positions)", product)
row("merged k = 32, towards the scanner", pca(p, 32) * np.sign(np.sum(pca(p, 32) * view, axis=1))[:, None])
for k in (8, 12, 16, 24):
    own = np.zeros_like(p)
    for s in range(len(positions)):
        mine = station == s
        own[mine] = pca(p[mine], k)
    own *= np.sign(np.sum(own * view, axis=1))[:, None]
    row(f"each scan's own k = {k}, towards the scanner", own)
    grazing = (np.abs(np.sum(product * view, axis=1)) < 0.3) & (np.abs(np.sum(own * view, axis=1)) >= 0.5)
    resigned = product.copy()
    resigned[grazing] *= np.sign(np.sum(resigned[grazing] * own[grazing], axis=1))[:, None]
    row(f"the product, grazing ones signed by each scan's own k = {k}", resigned)
PY
