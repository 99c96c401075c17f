#!/usr/bin/python3
"""interpolated_normals.py MESH SCAN.ply OUT.ply: the scan's points with the mesh's own shading normals.

Each point gets the mesh's interpolated vertex normal (area-weighted vertex normals, as apo and Open3D
compute them) at its closest point on the mesh (Open3D's RaycastingScene, barycentric from the returned
(u, v)). A simulated scan carries the face normal of the triangle each ray hit, which a renderer of the mesh
never shows; with these normals, a render of the points and a render of the mesh show the same field, so
their difference is the point renderer's own."""
import sys
import numpy as np
import open3d as o3d


def main():
    mesh_path, scan_path, out_path = sys.argv[1:4]
    mesh = o3d.io.read_triangle_mesh(mesh_path)
    mesh.compute_vertex_normals()
    scan = o3d.io.read_point_cloud(scan_path)
    points = np.asarray(scan.points, dtype=np.float32)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(mesh))
    hit = scene.compute_closest_points(o3d.core.Tensor(points))
    triangles = np.asarray(mesh.triangles)[hit['primitive_ids'].numpy()]
    uv = hit['primitive_uvs'].numpy()
    weights = np.c_[1.0 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]]
    normals = (np.asarray(mesh.vertex_normals)[triangles] * weights[:, :, None]).sum(1)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    scan.normals = o3d.utility.Vector3dVector(normals)
    o3d.io.write_point_cloud(out_path, scan, write_ascii=False)


if __name__ == '__main__':
    main()
