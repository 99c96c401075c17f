#!/usr/bin/python3
"""mip_values.py APO m.ply M.off OUTDIR [DEPTH...]: what a mip-mapped walk stopping at DEPTH reads, against
what it could read (issue 43, part 4, point 2).

Samples 400,000 points on M by area (fixed seed) with M's interpolated vertex normals (the truth, as M's
render shows it). For each DEPTH: `apo lookup --depth DEPTH --coarse m` (the stored value a walk stopping
there reads) and the leaf value (`apo lookup`, no depth); where the two differ the walk stopped at an
internal node. Over those samples, prints the mean angle to the truth of: the leaf, the stored value, and
two values an internal node could store instead, computed from the samples of its cell: M's area-weighted
mean normal, and the L1 (geometric) median of M's normals on the unit sphere (the constant that minimises
the mean angle better than the mean where the normals spread, e.g. round a thin part's rim).
Needs python3-numpy and python3-open3d (run with /usr/bin/python3) and APO_BIN (default build/apo)."""
import os, struct, subprocess, sys
import numpy as np
import open3d as o3d


def angle(a, b):
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), (a * b).sum(1)))


def main():
    apo_file, coarse, detail, out = sys.argv[1:5]
    depths = [int(d) for d in sys.argv[5:]] or [6, 7, 8, 9]
    apo = os.environ.get('APO_BIN', 'build/apo')
    os.makedirs(out, exist_ok=True)
    mesh = o3d.io.read_triangle_mesh(detail)
    mesh.compute_vertex_normals()
    o3d.utility.random.seed(1)
    pc = mesh.sample_points_uniformly(400_000, use_triangle_normal=False)
    P = np.asarray(pc.points); N = np.asarray(pc.normals)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    pts = os.path.join(out, 'points.xyz')
    np.savetxt(pts, P, fmt='%.9g')
    with open(apo_file, 'rb') as f:
        head = f.read(52)
    scale, ox, oy, oz = struct.unpack_from('<dddd', head, 20)
    U = P * scale + np.array([ox, oy, oz])

    def lookup(extra, name):
        path = os.path.join(out, name)
        subprocess.run([apo, '-q', 'lookup', apo_file, pts, '-o', path, '--coarse', coarse] + extra, check=True)
        return np.loadtxt(path)

    leaf = lookup([], 'leaf.xyz')
    print('| stop depth | samples stopped at an internal node | leaf | stored (mean of children, or m) | M\'s mean normal in the cell | L1 median in the cell | two sides\' means | best of the three per cell |')
    print('|---|---|---|---|---|---|---|---|')
    for d in depths:
        stored = lookup(['--depth', str(d)], f'depth{d}.xyz')
        inner = (np.abs(stored - leaf).max(1) > 1e-6) & (np.linalg.norm(stored, axis=1) > 0.5)
        cells = np.floor(U[inner] * (1 << d)).astype(np.int64)
        key = (cells[:, 0] << 42) | (cells[:, 1] << 21) | cells[:, 2]
        uniq, inv = np.unique(key, return_inverse=True)
        n = N[inner]
        mean = np.zeros((uniq.size, 3)); np.add.at(mean, inv, n)
        mean /= np.maximum(np.linalg.norm(mean, axis=1, keepdims=True), 1e-12)
        med = mean.copy()
        for _ in range(20):  # Weiszfeld on the sphere (re-normalised)
            w = 1.0 / np.maximum(angle(med[inv], n), 1e-3)
            acc = np.zeros_like(med); np.add.at(acc, inv, w[:, None] * n)
            med = acc / np.maximum(np.linalg.norm(acc, axis=1, keepdims=True), 1e-12)
        # Two sides: the samples of a cell split by the sign of their normal on the cell's principal axis
        # of normals (M's own normals pick the side: an upper bound on a side picked by m's normal).
        cov = np.zeros((uniq.size, 3, 3)); np.add.at(cov, inv, n[:, :, None] * n[:, None, :])
        axis = np.linalg.eigh(cov)[1][:, :, 2]
        side = ((n * axis[inv]).sum(1) >= 0).astype(np.int64)
        two = np.zeros((uniq.size, 2, 3)); np.add.at(two, (inv, side), n)
        two /= np.maximum(np.linalg.norm(two, axis=2, keepdims=True), 1e-12)
        e_stored = angle(stored[inner], n); e_mean = angle(mean[inv], n); e_med = angle(med[inv], n)
        # per cell, the best of stored / mean / median (the rule choosing with hindsight)
        sums = np.zeros((uniq.size, 3))
        for j, e in enumerate((e_stored, e_mean, e_med)): np.add.at(sums[:, j], inv, e)
        best = sums.min(1).sum() / inner.sum()
        row = [angle(leaf[inner], n).mean(), e_stored.mean(), e_mean.mean(), e_med.mean(),
               angle(two[inv, side], n).mean(), best]
        print(f'| {d} | {inner.sum()} of {len(P)} ({uniq.size} cells) | ' + ' | '.join(f'{x:.3f}' for x in row) + ' |')


if __name__ == '__main__':
    main()
