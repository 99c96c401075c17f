#!/usr/bin/env python3
"""Writes a binary little-endian PLY mesh (as `apo simulate-scan --mesh`
writes its triangle soups) with every face wound the other way, as some
range-grid converters write them: a, b, c becomes a, c, b, and a polygon's
corners after the first are reversed (bench/binary_ply.py).
Usage: flip_winding.py IN.ply OUT.ply"""
import sys

from binary_ply import read_faces

mesh = read_faces(sys.argv[1])
flipped = []
for record in mesh.records:
    corners = mesh.indices(record)
    flipped.append(mesh.record(corners[:1] + corners[:0:-1]))
mesh.write(sys.argv[2], flipped)
