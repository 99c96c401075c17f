#!/usr/bin/python3
"""Noisy and smoothed copies of a mesh for bench/noise_budget.sh.

Each vertex moves along its normal by Gaussian noise of SIGMA mean edge
lengths (seeded, so the copy is the same on every run); the smoothed copy is
the noisy one after Taubin smoothing (Open3D, ITERATIONS steps), a surface
smoothed at a fixed scale. Run with Debian's /usr/bin/python3 (Open3D).
Usage: noise_budget.py MESH SIGMA NOISY.ply SMOOTHED.ply [ITERATIONS]
"""
import sys

import numpy as np
import open3d as o3d

source, sigma, noisy_path, smoothed_path = sys.argv[1], float(sys.argv[2]), sys.argv[3], sys.argv[4]
iterations = int(sys.argv[5]) if len(sys.argv) > 5 else 10
mesh = o3d.io.read_triangle_mesh(source)
mesh.compute_vertex_normals()
v, t = np.asarray(mesh.vertices), np.asarray(mesh.triangles)
edges = np.linalg.norm(v[t] - v[np.roll(t, 1, axis=1)], axis=2)
step = sigma * edges.mean() * np.random.default_rng(1).standard_normal(len(v))
noisy = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(v + step[:, None] * np.asarray(mesh.vertex_normals)),
                                  mesh.triangles)
o3d.io.write_triangle_mesh(noisy_path, noisy, write_ascii=False)
o3d.io.write_triangle_mesh(smoothed_path, noisy.filter_smooth_taubin(number_of_iterations=iterations), write_ascii=False)
