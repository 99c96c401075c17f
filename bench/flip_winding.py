#!/usr/bin/env python3
"""Writes a binary little-endian PLY triangle soup (as `apo simulate-scan
--mesh` writes it: float vertex properties, `list uchar int` faces) with
every face wound the other way, as some range-grid converters write them.
Usage: flip_winding.py IN.ply OUT.ply"""
import struct
import sys

data = open(sys.argv[1], 'rb').read()
end = data.index(b'end_header\n') + len(b'end_header\n')
lines = data[:end].decode().split('\n')
count = lambda name: int(next(l for l in lines if l.startswith('element ' + name)).split()[2])
vertex_bytes = 4 * sum(1 for l in lines if l.startswith('property float'))
body = bytearray(data[end:])
at = count('vertex') * vertex_bytes
for _ in range(count('face')):
    a, b, c = struct.unpack_from('<iii', body, at + 1)
    struct.pack_into('<iii', body, at + 1, a, c, b)
    at += 13
open(sys.argv[2], 'wb').write(data[:end] + bytes(body))
