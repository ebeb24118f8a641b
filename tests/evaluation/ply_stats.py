#!/usr/bin/env python3
"""Prints vertices, faces and the bounding box of blobvk's binary PLY frames (no numpy needed).

Usage: ply_stats.py FILE... -> one line per file: name vertices faces minx miny minz maxx maxy maxz
"""
import struct, sys

def stats(path):
    with open(path, "rb") as f:
        header, props, nv, nf = [], [], 0, 0
        while True:
            line = f.readline().decode("ascii").strip()
            header.append(line)
            if line.startswith("element vertex"): nv = int(line.split()[2]); props = []; cur = "v"
            elif line.startswith("element face"): nf = int(line.split()[2]); cur = "f"
            elif line.startswith("property") and cur == "v": props.append(line.split()[1])
            elif line == "end_header": break
        sizes = {"float": 4, "uchar": 1, "int": 4, "double": 8}
        if props[:3] != ["float"] * 3: raise SystemExit(f"{path}: expected float x, y, z first")
        stride = sum(sizes[p] for p in props)
        data = f.read(nv * stride)
        lo, hi = [float("inf")] * 3, [float("-inf")] * 3
        for i in range(nv):
            x, y, z = struct.unpack_from("<fff", data, i * stride)
            for c, v in enumerate((x, y, z)):
                lo[c] = min(lo[c], v); hi[c] = max(hi[c], v)
        return nv, nf, lo, hi

for path in sys.argv[1:]:
    nv, nf, lo, hi = stats(path)
    print(path, nv, nf, *(f"{v:.4f}" for v in lo + hi))
