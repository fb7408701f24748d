#!/usr/bin/env python3
"""Check that the needle clumps in a LIGGGHTS custom dump are intact.

The dump must contain the columns id, mol, x, y, z (in.drum_raw writes them with -var dumpN N).
For every snapshot in every file given, the spheres are grouped by `mol` (the multisphere body);
each body must have `n` spheres lying on a straight line with neighbouring centres `s` apart,
i.e. the sorted pair distances must be s, s, 2s for n = 3 (generally k*s for k = 1..n-1).

usage: check_clumps.py DUMP [DUMP ...] [--s 0.0023872] [--n 3] [--tol 1e-5]
exit status 1 if any body is broken (wrong sphere count or spacing error above tol [m]).
"""
import argparse
import math
import sys


def snapshots(path):
    """Yield (timestep, columns, rows) for each snapshot of a LAMMPS/LIGGGHTS text dump."""
    with open(path) as fh:
        lines = iter(fh)
        for line in lines:
            if not line.startswith("ITEM: TIMESTEP"):
                continue
            step = int(next(lines))
            next(lines)                      # ITEM: NUMBER OF ATOMS
            natoms = int(next(lines))
            next(lines)                      # ITEM: BOX BOUNDS
            for _ in range(3):
                next(lines)
            cols = next(lines).split()[2:]   # ITEM: ATOMS c1 c2 ...
            rows = [next(lines).split() for _ in range(natoms)]
            yield step, cols, rows


def expected_distances(n, s):
    """Sorted centre distances of n collinear spheres spaced s apart."""
    return sorted(abs(i - j) * s for i in range(n) for j in range(i + 1, n))


def check(step, cols, rows, n, s):
    try:
        im, ix, iy, iz = (cols.index(c) for c in ("mol", "x", "y", "z"))
    except ValueError:
        sys.exit("dump needs the columns mol x y z; found: " + " ".join(cols))
    bodies = {}
    for r in rows:
        bodies.setdefault(int(float(r[im])), []).append((float(r[ix]), float(r[iy]), float(r[iz])))
    ref = expected_distances(n, s)
    wrong_count = 0
    worst = 0.0
    for pts in bodies.values():
        if len(pts) != n:
            wrong_count += 1
            continue
        d = sorted(math.dist(pts[a], pts[b]) for a in range(n) for b in range(a + 1, n))
        worst = max(worst, max(abs(x - y) for x, y in zip(d, ref)))
    return len(rows), len(bodies), wrong_count, worst


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dumps", nargs="+")
    ap.add_argument("--s", type=float, default=0.8 * 2.984e-3, help="centre spacing [m]")
    ap.add_argument("--n", type=int, default=3, help="spheres per body")
    ap.add_argument("--tol", type=float, default=1e-5, help="allowed spacing error [m]")
    a = ap.parse_args()
    bad = False
    for path in a.dumps:
        for step, cols, rows in snapshots(path):
            nsph, nbody, nwrong, worst = check(step, cols, rows, a.n, a.s)
            ok = nwrong == 0 and worst <= a.tol
            bad |= not ok
            print(f"{path} step {step}: {nsph} spheres, {nbody} bodies, "
                  f"bodies with != {a.n} spheres: {nwrong}, max spacing error {worst:.3e} m "
                  f"({worst / a.s:.2e} of s) -> {'OK' if ok else 'BROKEN'}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
