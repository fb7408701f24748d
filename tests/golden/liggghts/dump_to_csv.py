#!/usr/bin/env python3
"""Converts a LIGGGHTS custom dump (id x y z vx vy vz omegax omegay omegaz, sorted by id) into
the CSV the golden tests read: step,id,x,y,z,vx,vy,vz,wx,wy,wz (SI units, 17 significant digits).
Usage: dump_to_csv.py DUMP CSV"""
import sys


def main(dump, out):
    rows = []
    with open(dump) as f:
        lines = f.read().split("\n")
    i = 0
    while i < len(lines):
        if lines[i].startswith("ITEM: TIMESTEP"):
            step = int(lines[i + 1])
            n = int(lines[i + 3])
            cols = lines[i + 8].split()[2:]
            for k in range(n):
                v = dict(zip(cols, lines[i + 9 + k].split()))
                rows.append([str(step), v["id"]] + ["%.17g" % float(v[c]) for c in
                            ("x", "y", "z", "vx", "vy", "vz", "omegax", "omegay", "omegaz")])
            i += 9 + n
        else:
            i += 1
    with open(out, "w") as f:
        f.write("step,id,x,y,z,vx,vy,vz,wx,wy,wz\n")
        for r in rows:
            f.write(",".join(r) + "\n")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
