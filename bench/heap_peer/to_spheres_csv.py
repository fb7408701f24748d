#!/usr/bin/env python3
"""Sphere list (x,y,z,radius,body_id per line, metres) for bench/heap_measure, from either code.

    to_spheres_csv.py vtu spheres_NNNNNN.vtu OUT.csv       biodem snapshot (snapshots/spheres_*.vtu)
    to_spheres_csv.py liggghts dump_TAG.txt OUT.csv        LIGGGHTS custom dump (id mol x y z radius)

biodem: the points and the `radius` and `body_id` arrays of the VTK XML file (inline "binary":
base64 of a UInt32 byte count and the little-endian data, docs/outputs.md). LIGGGHTS: the last
snapshot of the dump; body_id = `mol`, the multisphere body of the sphere (fix multisphere).
Coordinates are written as they are (biodem y up, LIGGGHTS z up: heap_measure --up says which).
"""
import base64
import re
import struct
import sys


def vtu_arrays(path):
    text = open(path).read()
    arrays = {}
    for m in re.finditer(r'<DataArray type="(\w+)"([^>]*)format="binary">([^<]*)</DataArray>', text):
        kind, attrs, data = m.group(1), m.group(2), m.group(3).strip()
        name = re.search(r'Name="([^"]+)"', attrs)
        name = name.group(1) if name else "points"
        if name == "points" and "points" in arrays:
            continue
        raw = base64.b64decode(data)
        nbytes = struct.unpack("<I", raw[:4])[0]
        fmt = {"Float64": "d", "Int64": "q", "UInt8": "B"}[kind]
        size = struct.calcsize(fmt)
        arrays[name] = struct.unpack("<%d%s" % (nbytes // size, fmt), raw[4:4 + nbytes])
    return arrays


def from_vtu(path):
    a = vtu_arrays(path)
    p, r, b = a["points"], a["radius"], a["body_id"]
    return [(p[3 * i], p[3 * i + 1], p[3 * i + 2], r[i], b[i]) for i in range(len(r))]


def from_liggghts(path):
    last = None
    with open(path) as fh:
        lines = iter(fh)
        for line in lines:
            if not line.startswith("ITEM: TIMESTEP"):
                continue
            next(lines)
            next(lines)
            n = int(next(lines))
            next(lines)
            for _ in range(3):
                next(lines)
            cols = next(lines).split()[2:]
            last = (cols, [next(lines).split() for _ in range(n)])
    if last is None:
        sys.exit("%s: no snapshot" % path)
    cols, rows = last
    ix = [cols.index(c) for c in ("x", "y", "z", "radius", "mol")]
    return [(float(r[ix[0]]), float(r[ix[1]]), float(r[ix[2]]), float(r[ix[3]]), int(float(r[ix[4]]))) for r in rows]


def main():
    if len(sys.argv) != 4 or sys.argv[1] not in ("vtu", "liggghts"):
        sys.exit(__doc__)
    rows = from_vtu(sys.argv[2]) if sys.argv[1] == "vtu" else from_liggghts(sys.argv[2])
    with open(sys.argv[3], "w") as f:
        f.write("x,y,z,radius,body_id\n")
        for x, y, z, r, b in rows:
            f.write("%.9g,%.9g,%.9g,%.9g,%d\n" % (x, y, z, r, b))
    print("%s: %d spheres, %d bodies" % (sys.argv[3], len(rows), len({r[4] for r in rows})))


if __name__ == "__main__":
    main()
