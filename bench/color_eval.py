#!/usr/bin/python3
"""color_eval.py ASSET.glb SCAN: how close the GLB's base colour is to a coloured scan's own colours.

Independent of apo's code: Open3D reads the scan (PCD or PLY with colours), SciPy's k-d tree finds nearest points, and finds, for each scan point near
m, the closest point of the GLB's triangles (Embree, through Open3D); the baseColorTexture is sampled there
bilinearly at the interpolated TEXCOORD_0 (texel centres, UV origin top-left, clamped), as a viewer samples it.
The GLB's coordinates are the scan's minus asset.extras.georeference.origin. Scan points farther from m than
1% of m's bounding-box diagonal are left out (background and outliers the reconstruction dropped); their count
is printed. Beside the GLB, on the same points:
  - m with vertex colours: each vertex of m the mean of its 4 nearest scan colours, interpolated across the
    triangle (what a decimation keeping per-vertex colour gives);
  - the rule at the points themselves: each scan point against the mean of its 4 nearest scan colours (itself
    included; inverse-distance weights would give it alone), the colour apo's rule gives with no texels in
    between: what is left is the scan's colour noise at its own spacing, which no map of 4-point means removes.
Prints one JSON object: mean absolute difference per channel (0-255 levels) for each.
Uncompressed GLB only (no Draco)."""
import io
import json
import struct
import sys

import numpy as np
import open3d as o3d
from PIL import Image
from scipy.spatial import cKDTree

TYPES = {5125: np.uint32, 5126: np.float32}
WIDTHS = {'SCALAR': 1, 'VEC2': 2, 'VEC3': 3, 'VEC4': 4}


def read_glb(path):
    data = open(path, 'rb').read()
    magic, version, length = struct.unpack_from('<4sII', data, 0)
    if magic != b'glTF' or version != 2:
        sys.exit(f'{path}: not a glTF 2.0 binary')
    json_length = struct.unpack_from('<I', data, 12)[0]
    gltf = json.loads(data[20:20 + json_length])
    return gltf, data[20 + json_length + 8:]


def accessor(gltf, binary, index):
    a = gltf['accessors'][index]
    view = gltf['bufferViews'][a['bufferView']]
    dtype, width = np.dtype(TYPES[a['componentType']]), WIDTHS[a['type']]
    start = view.get('byteOffset', 0) + a.get('byteOffset', 0)
    return np.frombuffer(binary, dtype=dtype, count=a['count'] * width, offset=start).reshape(a['count'], width)


def texture_image(gltf, binary, texture):
    image = gltf['images'][gltf['textures'][texture]['source']]
    view = gltf['bufferViews'][image['bufferView']]
    png = binary[view.get('byteOffset', 0):view.get('byteOffset', 0) + view['byteLength']]
    return np.asarray(Image.open(io.BytesIO(png)).convert('RGB'), dtype=np.float64)


def bilinear(image, uv):
    h, w = image.shape[:2]
    x = np.clip(uv[:, 0] * w - 0.5, 0, w - 1)
    y = np.clip(uv[:, 1] * h - 0.5, 0, h - 1)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    return (image[y0, x0] * (1 - fx) * (1 - fy) + image[y0, x1] * fx * (1 - fy) + image[y1, x0] * (1 - fx) * fy
            + image[y1, x1] * fx * fy)


def mean_of_nearest(tree, colors, queries, k):
    _, index = tree.query(queries, k=k)
    return colors[index].mean(axis=1)


def main(glb_path, scan_path):
    gltf, binary = read_glb(glb_path)
    primitive = gltf['meshes'][0]['primitives'][0]
    if 'KHR_draco_mesh_compression' in primitive.get('extensions', {}):
        sys.exit('Draco-compressed GLB: not supported here')
    pbr = gltf['materials'][primitive['material']]['pbrMetallicRoughness']
    if 'baseColorTexture' not in pbr:
        sys.exit(f'{glb_path}: no baseColorTexture')
    origin = np.array(gltf['asset'].get('extras', {}).get('georeference', {}).get('origin', [0, 0, 0]), float)
    positions = accessor(gltf, binary, primitive['attributes']['POSITION']).astype(np.float64)
    uvs = accessor(gltf, binary, primitive['attributes']['TEXCOORD_0']).astype(np.float64)
    faces = accessor(gltf, binary, primitive['indices']).astype(np.int64).reshape(-1, 3)
    image = texture_image(gltf, binary, pbr['baseColorTexture']['index'])

    cloud = o3d.io.read_point_cloud(scan_path)
    if not cloud.has_colors():
        sys.exit(f'{scan_path}: no colours')
    points = np.asarray(cloud.points, dtype=np.float64) - origin
    colors = np.asarray(cloud.colors, dtype=np.float64) * 255.0
    keep = np.isfinite(points).all(axis=1)
    points, colors = points[keep], colors[keep]

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(positions.astype(np.float32)), o3d.core.Tensor(faces.astype(np.uint32)))
    found = scene.compute_closest_points(o3d.core.Tensor(points.astype(np.float32)))
    closest = found['points'].numpy().astype(np.float64)
    diagonal = np.linalg.norm(positions.max(axis=0) - positions.min(axis=0))
    near = np.linalg.norm(closest - points, axis=1) <= 0.01 * diagonal
    triangle = found['primitive_ids'].numpy().astype(np.int64)[near]
    b = found['primitive_uvs'].numpy().astype(np.float64)[near]
    weights = np.c_[1 - b[:, 0] - b[:, 1], b[:, 0], b[:, 1]]
    corners = faces[triangle]
    truth = colors[near]

    glb_colors = bilinear(image, (uvs[corners] * weights[:, :, None]).sum(axis=1))

    tree = cKDTree(points)
    vertex_colors = mean_of_nearest(tree, colors, positions, 4)
    per_vertex = (vertex_colors[corners] * weights[:, :, None]).sum(axis=1)
    at_points = mean_of_nearest(tree, colors, points[near], 4)

    def mad(estimate):
        return round(float(np.abs(estimate - truth).mean()), 2)

    print(json.dumps({'scan_points': int(len(points)), 'points_near_m': int(near.sum()),
                      'glb_base_color': mad(glb_colors), 'm_vertex_colors': mad(per_vertex),
                      'four_nearest_at_the_points': mad(at_points), 'unit': 'mean absolute difference per channel, 0-255'}))


if __name__ == '__main__':
    if len(sys.argv) != 3:
        sys.exit(__doc__.splitlines()[0])
    main(sys.argv[1], sys.argv[2])
