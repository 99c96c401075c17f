#!/usr/bin/env python3
"""A mesh with its faces shuffled, for measuring what an incoherent face
order costs the bake (docs/benchmarks.md, "A faster build"). How far apart consecutive faces lie is the bake's own measure,
bake.json `detail.face_order_spread` (core's faceOrderSpread): 0.92 for the
1.2M bunny, 288 for it shuffled with seed 1.

Usage:
  python3 bench/shuffle_faces.py MESH.ply OUT.ply [--seed 1]

Binary little-endian PLY only (what bench/build_speed.sh makes), faces as
one list property (bench/binary_ply.py).
"""
import argparse
import random

from binary_ply import read_faces


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mesh")
    parser.add_argument("out")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    mesh = read_faces(args.mesh)
    records = list(mesh.records)
    random.Random(args.seed).shuffle(records)
    mesh.write(args.out, records)
    print(f"{args.out}: the {len(records)} faces of {args.mesh}, shuffled (seed {args.seed})")


if __name__ == "__main__":
    main()
