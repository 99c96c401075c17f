"""bench/peers.sh --accuracy's conversion of MeshLab's textured m (a binary
PLY with per-wedge texture coordinates, "property list uchar float
texcoord", as meshlabserver -m wt writes it) to a Wavefront OBJ with v, vt
and f v/vt, as ../shared/tools/normal_eval.py's --map reads it. Positions
and UVs are copied as they are (%.9g): VCG's texture coordinates, like OBJ's,
have v = 0 at the bottom row of the image. Prints one line: vertices, faces,
the UV range.
Usage: python3 bench/peers_obj.py M_TEXTURED.ply OUT.obj"""
import sys

import numpy as np

TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4", "float": "f4",
         "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2", "int32": "i4", "uint32": "u4",
         "float32": "f4", "float64": "f8"}

ply_path, obj_path = sys.argv[1:3]
data = open(ply_path, "rb").read()
end = data.index(b"end_header\n") + len(b"end_header\n")
header = data[:end].decode(errors="replace").split("\n")
if "format binary_little_endian 1.0" not in header:
    sys.exit(f"peers_obj.py: {ply_path} is not a binary little-endian PLY")
elements, element = {}, None
for line in header:
    words = line.split()
    if words[:1] == ["element"]:
        element = words[1]
        elements[element] = {"count": int(words[2]), "props": []}
    elif words[:1] == ["property"]:
        elements[element]["props"].append(words[1:])
if list(elements)[:2] != ["vertex", "face"]:
    sys.exit(f"peers_obj.py: {ply_path}: elements {list(elements)}, not vertex then face")

vertex = elements["vertex"]
vdtype = np.dtype([(p[1], "<" + TYPES[p[0]]) for p in vertex["props"]])
v = np.frombuffer(data, dtype=vdtype, count=vertex["count"], offset=end)
xyz = np.stack([v["x"], v["y"], v["z"]], axis=1).astype(np.float64)
offset = end + vdtype.itemsize * vertex["count"]

# The faces: every list is read per face (MeshLab writes triangles, but the
# reader does not rely on it); scalar properties are skipped.
face = elements["face"]
faces, uvs = [], []
for _ in range(face["count"]):
    record = {}
    for p in face["props"]:
        if p[0] == "list":
            count_type, item_type, name = "<" + TYPES[p[1]], "<" + TYPES[p[2]], p[3]
            n = int(np.frombuffer(data, dtype=count_type, count=1, offset=offset)[0])
            offset += np.dtype(count_type).itemsize
            record[name] = np.frombuffer(data, dtype=item_type, count=n, offset=offset)
            offset += np.dtype(item_type).itemsize * n
        else:
            offset += np.dtype("<" + TYPES[p[0]]).itemsize
    corners = record.get("vertex_indices", record.get("vertex_index"))
    tex = record.get("texcoord")
    if corners is None or tex is None or len(tex) != 2 * len(corners):
        sys.exit(f"peers_obj.py: {ply_path}: a face without vertex indices or per-corner texcoord")
    faces.append(corners.astype(np.int64))
    uvs.append(tex.astype(np.float64).reshape(-1, 2))
if offset != len(data):
    sys.exit(f"peers_obj.py: {ply_path}: {len(data) - offset} bytes left after the faces")

with open(obj_path, "w") as out:
    out.write(f"# {ply_path} (bench/peers_obj.py)\n")
    out.writelines(f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in xyz)
    uv = np.concatenate(uvs)
    out.writelines(f"vt {s:.9g} {t:.9g}\n" for s, t in uv)
    k = 1
    for corners in faces:
        out.write("f " + " ".join(f"{c + 1}/{k + i}" for i, c in enumerate(corners)) + "\n")
        k += len(corners)
print(f"peers_obj.py: {len(xyz)} vertices, {len(faces)} faces, u {uv[:, 0].min():.4f}..{uv[:, 0].max():.4f}, "
      f"v {uv[:, 1].min():.4f}..{uv[:, 1].max():.4f}")
