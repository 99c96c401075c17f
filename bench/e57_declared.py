#!/usr/bin/env python3
"""What an E57 file declares, read independently of apo's reader: the pages'
CRC-32C stripped (each 1024-byte page ends in 4 CRC bytes), the XML section
found from the file header (ASTM E2807: 'ASTM-E57', major, minor, physical
length, XML physical offset, XML logical length, page size), and each
/data3D scan's points recordCount. Prints JSON {"scans": [counts...]} or
{"error": ...}.
Usage: e57_declared.py FILE.e57"""
import json
import re
import struct
import sys
import xml.etree.ElementTree as ET


def logical_bytes(data, physical_offset, length, page=1024):
    out = bytearray()
    at = physical_offset
    while len(out) < length:
        page_start = at - at % page
        take = min(page - 4 - at % page, length - len(out))
        if page_start + page > len(data):
            raise ValueError("XML section runs past the file's end")
        out += data[at:at + take]
        at = page_start + page
    return bytes(out)


def main(path):
    data = open(path, 'rb').read()
    if data[:8] != b'ASTM-E57':
        return {"error": "no ASTM-E57 signature"}
    _, _, _, xml_offset, xml_length, page = struct.unpack_from('<IIQQQQ', data, 8)
    text = logical_bytes(data, xml_offset, xml_length, page)
    root = ET.fromstring(text)
    ns = re.match(r'\{.*\}', root.tag)
    ns = ns.group(0) if ns else ''
    data3d = root.find(ns + 'data3D')
    counts = []
    for scan in (data3d if data3d is not None else []):
        points = scan.find(ns + 'points')
        counts.append(int(points.get('recordCount')) if points is not None else 0)
    return {"scans": counts}


if __name__ == '__main__':
    try:
        print(json.dumps(main(sys.argv[1])))
    except Exception as error:  # a broken file: say so, the table shows it
        print(json.dumps({"error": str(error)}))
