#!/usr/bin/env python3
"""How often a warp of the GPU engine's row walk runs a touching contact's long evaluation
(docs/gpu.md section 2, "The walks sharing their touching contacts").

    python3 bench/walk_divergence.py RUN_DIR

RUN_DIR: the output folder of a `biodem run` of a drum case with a final snapshot (for the bench
drums: the case with its rotation phase cut to a few steps; any engine). From the last sphere
snapshot (snapshots/*.vtu: centres, radii, body ids) and run.log (the drum's diameter and width,
the skin), it makes each sphere's row as the device builds it (every sphere of another body
closer than r_i + r_j + skin, sorted by stable id: here the snapshot's sphere index) followed by
the drum's three walls (mantle of the drum's radius about the z axis, end plates at z = 0 and
z = width), orders the spheres as the device does (bodies by the list cell of their first
sphere, z-major, x fastest; a body's spheres together), and for each warp of 32 spheres counts:
the steps of the warp's walk (its longest walk), the steps at which at least one lane's entry
touches (the walk by one thread per row runs the long path there), the most touching contacts
of one lane (a walk that took its touching contacts first), and the rounds of 32 touching
contacts (the walks sharing their touching contacts across the warp). Needs numpy and scipy
(Debian: python3-numpy, python3-scipy).
"""
import base64
import glob
import re
import struct
import sys

import numpy as np
from scipy.spatial import cKDTree


def read_vtu(path):
    """The arrays of a biodem VTU file (inline binary, base64 of [UInt32 byte count][data])."""
    text = open(path).read()
    arrays = {}
    pattern = r'<DataArray type="(\w+)"(?: Name="(\w+)")?(?: NumberOfComponents="(\d)")? format="binary">([^<]*)</DataArray>'
    for m in re.finditer(pattern, text):
        kind, name, comps, data = m.group(1), m.group(2) or "points", int(m.group(3) or 1), m.group(4)
        raw = base64.b64decode(data)
        nbytes = struct.unpack("<I", raw[:4])[0]
        a = np.frombuffer(raw[4:4 + nbytes], dtype={"Float64": "<f8", "Int64": "<i8", "UInt8": "u1"}[kind])
        arrays.setdefault(name, a.reshape(-1, comps) if comps > 1 else a)
    return arrays


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    log = open(out + "/run.log").read()
    m = re.search(r"^drum: diameter ([0-9.eE+-]+) m, width ([0-9.eE+-]+) m", log, re.M)
    k = re.search(r"skin = ([0-9.eE+-]+) m", log)
    snaps = sorted(glob.glob(out + "/snapshots/*.vtu"))
    if not m or not k or not snaps:
        sys.exit(f"walk_divergence.py: {out}: no drum line or skin in run.log, or no snapshots/*.vtu")
    radius_drum, width, skin = 0.5 * float(m.group(1)), float(m.group(2)), float(k.group(1))
    a = read_vtu(snaps[-1])
    x, r, body = a["points"], a["radius"], a["body_id"]
    n = len(r)
    cut = 2 * r.max() + skin
    # the device order: bodies by the cell of their first sphere (z-major, x fastest)
    c = np.floor((x - x.min(0)) / cut).astype(np.int64)
    nx, ny = c[:, 0].max() + 1, c[:, 1].max() + 1
    key = (c[:, 2] * ny + c[:, 1]) * nx + c[:, 0]
    first = {}
    for i in range(n):
        first.setdefault(int(body[i]), i)
    order = []
    for b in sorted(first, key=lambda b: (key[first[b]], first[b])):
        order.extend(np.nonzero(body == b)[0])
    # rows: (neighbour, touching), sorted by the neighbour's index
    pairs = cKDTree(x).query_pairs(cut, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    d = np.linalg.norm(x[i] - x[j], axis=1)
    keep = (d < r[i] + r[j] + skin) & (body[i] != body[j])
    rows = [[] for _ in range(n)]
    for p, q, dd in zip(i[keep], j[keep], d[keep]):
        t = dd < r[p] + r[q]
        rows[p].append((q, t))
        rows[q].append((p, t))
    rho = np.hypot(x[:, 0], x[:, 1])
    walls = np.stack([rho + r >= radius_drum, x[:, 2] - r <= 0.0, x[:, 2] + r >= width], axis=1)
    length = np.array([len(q) for q in rows])
    touching = np.array([sum(t for _, t in q) for q in rows])
    print(f"{out}: {n} spheres in {len(first)} bodies; rows {length.mean():.2f} entries on average (at most "
          f"{length.max()}), {touching.mean():.2f} touching; walls touched per sphere: mantle {walls[:, 0].mean():.3f}, "
          f"end plates {walls[:, 1].mean():.3f} and {walls[:, 2].mean():.3f}")
    steps = long_steps = most = rounds = busy = 0
    warps = 0
    for w0 in range(0, n, 32):
        walks = [[t for _, t in sorted(rows[s])] + list(walls[s]) for s in order[w0:w0 + 32]]
        steps += max(len(wk) for wk in walks)
        long_steps += len({v for wk in walks for v, t in enumerate(wk) if t})
        counts = [sum(wk) for wk in walks]
        most += max(counts)
        rounds += -(-sum(counts) // 32)
        busy += sum(counts)
        warps += 1
    print(f"per warp ({warps} warps): {steps / warps:.2f} steps of the walk; steps with a touching contact: one thread "
          f"per row {long_steps / warps:.2f} ({busy / long_steps:.1f} of 32 lanes busy in them), touching first in each "
          f"row {most / warps:.2f}, shared across the warp {rounds / warps:.2f}")


if __name__ == "__main__":
    main()
