#!/usr/bin/env python3
"""ASCII STL meshes of the heap rig for in.heap_peer (LIGGGHTS 3.8.0), axis z, plate at z = 0.

    python3 make_meshes.py [--radius 0.02] [--height 0.32] [--plate-radius 0.09] [--segments 64]
                           [--row-height 0.04] [--outdir .]

tube.stl:  open tube of `segments` flat facets from z = 0 to `height`. The vertices lie at
           radius / cos(pi / segments), so every facet's plane is at `radius` from the axis (the
           sphere contacts inside the facets are those of biodem's cylinder of that radius; at a
           vertex the polygon is 0.12 % wider for 64 facets). Split into rows of at most
           `row-height` so no triangle angle falls below LIGGGHTS' 0.5 degree quality limit.
plate.stl: a flat disc of `plate-radius` (triangle fan about the axis; the fan's rim is a
           polygon inscribed in the circle, as biodem's disc of that radius).
"""
import argparse
import math
import os


def facet(out, a, b, c):
    ux, uy, uz = (b[i] - a[i] for i in range(3))
    vx, vy, vz = (c[i] - a[i] for i in range(3))
    n = (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx)
    ln = math.sqrt(sum(x * x for x in n)) or 1.0
    out.append("  facet normal %.9g %.9g %.9g\n    outer loop\n" % tuple(x / ln for x in n))
    for p in (a, b, c):
        out.append("      vertex %.9g %.9g %.9g\n" % p)
    out.append("    endloop\n  endfacet\n")


def write(path, name, facets):
    with open(path, "w") as f:
        f.write("solid %s\n" % name)
        f.writelines(facets)
        f.write("endsolid %s\n" % name)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--radius", type=float, default=0.02)
    ap.add_argument("--height", type=float, default=0.32)
    ap.add_argument("--plate-radius", type=float, default=0.09)
    ap.add_argument("--segments", type=int, default=64)
    ap.add_argument("--row-height", type=float, default=0.04)
    ap.add_argument("--outdir", default=".")
    a = ap.parse_args()
    n = a.segments
    rv = a.radius / math.cos(math.pi / n)
    rows = max(1, math.ceil(a.height / a.row_height - 1e-9))
    ring = [(rv * math.cos(2 * math.pi * k / n), rv * math.sin(2 * math.pi * k / n)) for k in range(n)]
    tube = []
    for j in range(rows):
        z0, z1 = a.height * j / rows, a.height * (j + 1) / rows
        for k in range(n):
            (x0, y0), (x1, y1) = ring[k], ring[(k + 1) % n]
            facet(tube, (x0, y0, z0), (x1, y1, z0), (x1, y1, z1))
            facet(tube, (x0, y0, z0), (x1, y1, z1), (x0, y0, z1))
    plate = []
    for k in range(n):
        a0, a1 = 2 * math.pi * k / n, 2 * math.pi * (k + 1) / n
        facet(plate, (0.0, 0.0, 0.0), (a.plate_radius * math.cos(a0), a.plate_radius * math.sin(a0), 0.0),
              (a.plate_radius * math.cos(a1), a.plate_radius * math.sin(a1), 0.0))
    os.makedirs(a.outdir, exist_ok=True)
    write(os.path.join(a.outdir, "tube.stl"), "tube", tube)
    write(os.path.join(a.outdir, "plate.stl"), "plate", plate)
    print("tube.stl: %d facets (%d segments x %d rows), radius %.6g m (vertices at %.6g m), height %.6g m; "
          "plate.stl: %d facets, radius %.6g m" % (2 * n * rows, n, rows, a.radius, rv, a.height,
                                                    n, a.plate_radius))


if __name__ == "__main__":
    main()
