#!/usr/bin/env python3
"""How spatially coherent a mesh's face order is, and the same mesh with its
faces shuffled, for measuring what the order costs the bake
(docs/benchmarks.md, "What is left of the bunny's 2 s").

Coherence: the median and 90th percentile, over consecutive faces, of the
distance between their centres, over the bounding box's diagonal (a mesh in
scan or subdivision order: about 0.001; shuffled: about 0.35).

Usage:
  python3 bench/face_order.py MESH.ply                 # the statistic
  python3 bench/face_order.py MESH.ply --shuffle OUT.ply [--seed 1]

Binary little-endian PLY only (what bench/build_speed.sh makes), faces as
one list property; the standard library only.
"""
import argparse
import math
import random
import struct
import sys

SIZES = {"char": 1, "int8": 1, "uchar": 1, "uint8": 1, "short": 2, "int16": 2, "ushort": 2, "uint16": 2,
         "int": 4, "int32": 4, "uint": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}
CODES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h", "ushort": "H",
         "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I", "float": "f", "float32": "f",
         "double": "d", "float64": "d"}


def read_mesh(path):
    data = open(path, "rb").read()
    end = data.find(b"end_header\n")
    if end < 0:
        sys.exit(f"{path}: no end_header line")
    body = end + len(b"end_header\n")
    header = data[:end].decode("ascii", "replace").splitlines()
    if "format binary_little_endian 1.0" not in header:
        sys.exit(f"{path}: only binary little-endian PLY is handled")
    elements, current = [], None
    for line in header:
        words = line.split()
        if words[:1] == ["element"]:
            current = {"name": words[1], "count": int(words[2]), "props": []}
            elements.append(current)
        elif words[:1] == ["property"]:
            current["props"].append(words[1:])
    if [e["name"] for e in elements] != ["vertex", "face"]:
        sys.exit(f"{path}: expected the elements vertex then face")
    vertex, face = elements
    if any(p[0] == "list" for p in vertex["props"]) or len(face["props"]) != 1 or face["props"][0][0] != "list":
        sys.exit(f"{path}: expected scalar vertex properties and one face list")
    layout = "<" + "".join(CODES[p[0]] for p in vertex["props"])
    stride = struct.calcsize(layout)
    names = [p[-1] for p in vertex["props"]]
    xyz = [names.index(axis) for axis in "xyz"]
    positions = [tuple(values[k] for k in xyz)
                 for values in struct.iter_unpack(layout, data[body:body + stride * vertex["count"]])]
    count_type, index_type = face["props"][0][1], face["props"][0][2]
    offset = body + stride * vertex["count"]
    faces = []
    for _ in range(face["count"]):
        n = struct.unpack_from("<" + CODES[count_type], data, offset)[0]
        size = SIZES[count_type] + n * SIZES[index_type]
        faces.append(data[offset:offset + size])
        offset += size
    return data[:offset - sum(len(f) for f in faces)], positions, faces, count_type, index_type


def centre(record, positions, count_type, index_type):
    n = struct.unpack_from("<" + CODES[count_type], record)[0]
    indices = struct.unpack_from(f"<{n}{CODES[index_type]}", record, SIZES[count_type])
    return [sum(positions[i][k] for i in indices) / n for k in range(3)]


def coherence(positions, faces, count_type, index_type):
    lo = [min(p[k] for p in positions) for k in range(3)]
    hi = [max(p[k] for p in positions) for k in range(3)]
    diagonal = math.dist(lo, hi)
    step = max(1, len(faces) // 200000)  # at most 200,000 pairs of neighbours
    steps = sorted(math.dist(centre(faces[i], positions, count_type, index_type),
                             centre(faces[i + 1], positions, count_type, index_type)) / diagonal
                   for i in range(0, len(faces) - 1, step))
    return steps[len(steps) // 2], steps[int(0.9 * len(steps))]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mesh")
    parser.add_argument("--shuffle", metavar="OUT")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    head, positions, faces, count_type, index_type = read_mesh(args.mesh)
    median, p90 = coherence(positions, faces, count_type, index_type)
    print(f"{args.mesh}: {len(faces)} faces, step between consecutive centres / diagonal: "
          f"median {median:.5f}, p90 {p90:.5f}")
    if args.shuffle:
        random.Random(args.seed).shuffle(faces)
        with open(args.shuffle, "wb") as out:
            out.write(head)
            out.write(b"".join(faces))
        median, p90 = coherence(positions, faces, count_type, index_type)
        print(f"{args.shuffle}: shuffled (seed {args.seed}): median {median:.5f}, p90 {p90:.5f}")


if __name__ == "__main__":
    main()
