"""A binary little-endian PLY mesh as the bench scripts rewrite it: the
bytes up to the end of the vertices, and each face's record apart (its
count and indices, as stored), for scripts that reorder or rewind faces
(bench/shuffle_faces.py, bench/flip_winding.py). Vertex properties must be
scalars, and faces one list property; the standard library only."""
import struct
import sys

SIZES = {"char": 1, "int8": 1, "uchar": 1, "uint8": 1, "short": 2, "int16": 2, "ushort": 2, "uint16": 2,
         "int": 4, "int32": 4, "uint": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}
CODES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h", "ushort": "H",
         "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I", "float": "f", "float32": "f",
         "double": "d", "float64": "d"}


class Faces:
    """`head`: the header and the vertices, as read; `records`: each face's
    bytes; `count_code`, `index_code`: their struct codes."""

    def __init__(self, head, records, count_code, index_code):
        self.head, self.records = head, records
        self.count_code, self.index_code = count_code, index_code

    def indices(self, record):
        n = struct.unpack_from("<" + self.count_code, record)[0]
        return list(struct.unpack_from("<%d%s" % (n, self.index_code), record, struct.calcsize(self.count_code)))

    def record(self, indices):
        return struct.pack("<%s%d%s" % (self.count_code, len(indices), self.index_code), len(indices), *indices)

    def write(self, path, records):
        with open(path, "wb") as out:
            out.write(self.head)
            out.write(b"".join(records))


def read_faces(path):
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
    head = data[:offset]
    records = []
    for _ in range(face["count"]):
        n = struct.unpack_from("<" + CODES[count_type], data, offset)[0]
        size = SIZES[count_type] + n * SIZES[index_type]
        records.append(data[offset:offset + size])
        offset += size
    return Faces(head, records, CODES[count_type], CODES[index_type])
