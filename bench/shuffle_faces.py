#!/usr/bin/env python3
"""A mesh with its faces shuffled, for measuring what an incoherent face
order costs the bake (docs/benchmarks.md, "What is left of the bunny's 2
s"). How far apart consecutive faces lie is the bake's own measure,
bake.json `detail.face_order_spread` (core's faceOrderSpread): 0.92 for the
1.2M bunny, 288 for it shuffled with seed 1.

Usage:
  python3 bench/shuffle_faces.py MESH.ply OUT.ply [--seed 1]

Binary little-endian PLY only (what bench/build_speed.sh makes), faces as
one list property; the standard library only.
"""
import argparse
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
    stride = struct.calcsize("<" + "".join(CODES[p[0]] for p in vertex["props"]))
    count_type, index_type = face["props"][0][1], face["props"][0][2]
    offset = body + stride * vertex["count"]
    faces = []
    for _ in range(face["count"]):
        n = struct.unpack_from("<" + CODES[count_type], data, offset)[0]
        size = SIZES[count_type] + n * SIZES[index_type]
        faces.append(data[offset:offset + size])
        offset += size
    return data[:body + stride * vertex["count"]], faces


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mesh")
    parser.add_argument("out")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    head, faces = read_mesh(args.mesh)
    random.Random(args.seed).shuffle(faces)
    with open(args.out, "wb") as out:
        out.write(head)
        out.write(b"".join(faces))
    print(f"{args.out}: the {len(faces)} faces of {args.mesh}, shuffled (seed {args.seed})")


if __name__ == "__main__":
    main()
