#!/usr/bin/env python3
"""Writes the fuzzers' seed corpora (fuzz/corpus/<target>/): small, valid
files of each format that touch its features (encodings, attributes, faces,
comments), a few of the datasets' own small files, and the golden .apo.
Deterministic; run from the repository root after
datasets_scripts/fetch_datasets.sh:  python3 fuzz/make_seeds.py"""
import os
import shutil
import struct

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")
TETRA = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
FACES = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def put(target, name, data):
    os.makedirs(os.path.join(ROOT, target), exist_ok=True)
    with open(os.path.join(ROOT, target, name), "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)


def copy(target, dataset):
    path = os.path.join("datasets", dataset)
    if os.path.exists(path):
        shutil.copyfile(path, os.path.join(ROOT, target, os.path.basename(path)))


def ply_seeds():
    head = "ply\nformat {}\ncomment seed\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
    ascii_body = "".join(f"{x} {y} {z}\n" for x, y, z in TETRA) + "".join(f"3 {a} {b} {c}\n" for a, b, c in FACES)
    put("ply", "ascii_mesh.ply", head.format("ascii 1.0") + "element face 4\nproperty list uchar int vertex_indices\nend_header\n" + ascii_body)
    attrs = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
             "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\n"
             "property uchar blue\nproperty float confidence\nend_header\n")
    put("ply", "ascii_attributes.ply", attrs + "".join(f"{x} {y} {z} 0 0 1 255 128 0 0.5\n" for x, y, z in TETRA))
    for name, fmt, order in (("binary_le.ply", "binary_little_endian 1.0", "<"), ("binary_be.ply", "binary_big_endian 1.0", ">")):
        body = b"".join(struct.pack(order + "3f", *p) for p in TETRA)
        body += b"".join(struct.pack(order + "B3i", 3, *f) for f in FACES)
        put("ply", name, (head.format(fmt) + "element face 4\nproperty list uchar int vertex_indices\nend_header\n").encode() + body)
    double = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\nend_header\n"
    put("ply", "binary_double.ply", double.encode() + b"".join(struct.pack("<3d", *p) for p in TETRA))
    copy("ply", "cgal/meshes/colored_tetra.ply")


def literal_lzf(data):
    """LZF with literal runs only (control byte n < 32: the next n + 1 bytes)."""
    out = bytearray()
    for at in range(0, len(data), 32):
        chunk = data[at:at + 32]
        out.append(len(chunk) - 1)
        out += chunk
    return bytes(out)


def pcd_seeds():
    head = ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 4\nHEIGHT 1\n"
            "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA {}\n")
    put("pcd", "ascii.pcd", head.format("ascii") + "".join(f"{x} {y} {z}\n" for x, y, z in TETRA))
    put("pcd", "binary.pcd", head.format("binary").encode() + b"".join(struct.pack("<3f", *p) for p in TETRA))
    plain = b"".join(struct.pack("<4f", *[p[axis] for p in TETRA]) for axis in range(3))  # field-major
    packed = literal_lzf(plain)
    put("pcd", "binary_compressed.pcd", head.format("binary_compressed").encode() + struct.pack("<II", len(packed), len(plain)) + packed)
    rgb = ("VERSION .7\nFIELDS x y z rgb normal_x normal_y normal_z intensity\nSIZE 4 4 4 4 4 4 4 4\nTYPE F F F F F F F F\n"
           "COUNT 1 1 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 2\nPOINTS 4\nDATA ascii\n")
    put("pcd", "ascii_attributes.pcd", rgb + "".join(f"{x} {y} {z} 4.2108e+06 0 0 1 7\n" for x, y, z in TETRA))


def text_seeds():
    put("xyz", "points.xyz", "".join(f"{x} {y} {z}\n" for x, y, z in TETRA))
    put("xyz", "normals.xyzn", "# x y z nx ny nz\n" + "".join(f"{x}\t{y}\t{z}\t0 0 1\n" for x, y, z in TETRA))
    put("xyz", "count.pts", "4\n" + "".join(f"{x} {y} {z} 12 200 100 50\n" for x, y, z in TETRA))
    put("off", "tetra.off", "OFF\n4 4 6\n" + "".join(f"{x} {y} {z}\n" for x, y, z in TETRA) + "".join(f"3 {a} {b} {c}\n" for a, b, c in FACES))
    put("off", "quad.coff", "COFF\n# comment\n4 1 0\n" + "".join(f"{x} {y} {z} 255 0 0 255\n" for x, y, z in TETRA) + "4 0 1 2 3\n")
    put("off", "normals.noff", "NOFF\n4 0 0\n" + "".join(f"{x} {y} {z} 0 0 1\n" for x, y, z in TETRA))
    for name in ("triangle.off", "cube_quad.off", "mesh_with_colors.off"):
        copy("off", "cgal/meshes/" + name)
    obj = ("# seed\no tetra\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in TETRA) + "vn 0 0 1\nvt 0 0\n"
           "f 1/1/1 3/1/1 2/1/1\nf 1//1 2//1 4//1\nf -4 -1 -2\nf 2 3 4 1\n")
    put("obj", "tetra.obj", obj)
    put("stl", "ascii.stl", "solid seed\n" + "".join(
        "facet normal 0 0 1\nouter loop\n" + "".join(f"vertex {TETRA[v][0]} {TETRA[v][1]} {TETRA[v][2]}\n" for v in f) +
        "endloop\nendfacet\n" for f in FACES) + "endsolid seed\n")
    binary = b"seed".ljust(80, b" ") + struct.pack("<I", len(FACES))
    for f in FACES:
        binary += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *TETRA[v]) for v in f) + b"\0\0"
    put("stl", "binary.stl", binary)


def hostile_seeds():
    """The broken files of the tests and of bench/pipeline_bench.sh."""
    put("ply", "huge_count.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n")
    put("ply", "truncated.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n" + "\0" * 40)
    put("off", "bad_index.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 9\n")
    put("pcd", "short.pcd", "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 10\nHEIGHT 1\n"
        "POINTS 10\nDATA ascii\n1 2 3\n")
    put("stl", "count_past_end.stl", b"x".ljust(80, b" ") + struct.pack("<I", 1000000) + b"\0" * 50)
    put("obj", "bad_face.obj", "v 0 0 0\nv 1 0 0\nf 1 2 7\nf 1/2/3/4 2\n")
    put("xyz", "nan.xyz", "nan 0 0\n1 inf 0\n1 2\n")


def config_seeds():
    put("config", "stages.toml", "faces = 5000\nerror = 0.01\nmethod = \"poisson\"\nno-filter = true\nsize = 256\n")
    put("config", "lists.toml", "# every kind of value\nsensor = [1.0, 2.0, 3.5]\nvoxel = 0.5\nremove-outliers = true\npolicy = 'lt'\n")
    put("config", "bad.toml", "[bake]\nerror = -1\nunknown = 3\n")


def las_seeds():
    """PDAL's test files (../shared/data/las, from PDAL/PDAL test/data/las and
    laz at ccf0ab7), all but the 812 KB 4_6_crop.las; the LAS reader's tests
    read them from here too."""
    source = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data", "las")
    if not os.path.isdir(source):
        return
    os.makedirs(os.path.join(ROOT, "las"), exist_ok=True)
    for name in sorted(os.listdir(source)):
        if name.endswith((".las", ".laz")) and name != "4_6_crop.las":
            shutil.copyfile(os.path.join(source, name), os.path.join(ROOT, "las", name))


def laz_seeds():
    """The LAZ test files (../shared/data/laz, whose README gives each one's
    source, commit and licence: PDAL, LAZperf, laspy, LASzip), all under
    600 KB (not the 2.7 MB lone-star.copc.laz); the LAZ reader's tests read
    them from here too."""
    source = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data", "laz")
    if not os.path.isdir(source):
        return
    os.makedirs(os.path.join(ROOT, "laz"), exist_ok=True)
    for name in sorted(os.listdir(source)):
        path = os.path.join(source, name)
        if name.endswith(".laz") and os.path.getsize(path) < 600 * 1024:
            shutil.copyfile(path, os.path.join(ROOT, "laz", name))


def apo_seeds():
    golden = os.path.join(os.path.dirname(ROOT), "..", "tests", "golden", "v1", "scan.apo")
    if os.path.exists(golden):
        os.makedirs(os.path.join(ROOT, "apo"), exist_ok=True)
        shutil.copyfile(golden, os.path.join(ROOT, "apo", "golden_v1.apo"))


def n3t_seeds():
    golden = os.path.join(os.path.dirname(ROOT), "..", "tests", "golden", "n3t", "scan_n2.n3t")
    if os.path.exists(golden):
        os.makedirs(os.path.join(ROOT, "n3t"), exist_ok=True)
        shutil.copyfile(golden, os.path.join(ROOT, "n3t", "golden_n2.n3t"))


if __name__ == "__main__":
    ply_seeds()
    pcd_seeds()
    text_seeds()
    hostile_seeds()
    config_seeds()
    las_seeds()
    laz_seeds()
    apo_seeds()
    n3t_seeds()
