#!/usr/bin/env python3
"""Table of the rotation-phase timings in LIGGGHTS logs written by run_bench.sh.

usage: python3 parse_logs.py logs/*.log

Each drum script does two runs: settle (incl. insertion at step 1), then rotation.  The timed
figure is the LAST "Loop time" block of a log (the rotation run); a log with only one block was
cut short (e.g. by the timeout) and is reported as incomplete.

  s/step                 = loop wall seconds / steps
  sphere-steps/s/core    = spheres x steps / loop wall seconds / ranks
  speed-up 1->2          = s/step at 1 rank / s/step at 2 ranks, for logs whose names differ
                           only in "np1" / "np2"
"""
import re
import sys

LOOP = re.compile(r"^Loop time of (\S+) on (\d+) procs for (\d+) steps with (\d+) atoms")
PART = re.compile(r"^(Pair|Neigh|Comm|Outpt|Other)\s+time \(%\) = (\S+) \((\S+)\)")
NEIGHS = re.compile(r"^Ave neighs/atom = (\S+)")
BUILDS = re.compile(r"^Neighbor list builds = (\d+)")


def parse(path):
    """Return the list of run blocks of one log: dicts with loop, procs, steps, atoms, parts..."""
    blocks = []
    with open(path, errors="replace") as fh:
        for line in fh:
            m = LOOP.match(line)
            if m:
                blocks.append(dict(loop=float(m[1]), procs=int(m[2]), steps=int(m[3]),
                                   atoms=int(m[4]), parts={}, neighs=None, builds=None))
                continue
            if not blocks:
                continue
            b = blocks[-1]
            m = PART.match(line)
            if m:
                b["parts"][m[1]] = (float(m[2]), float(m[3]))
            elif NEIGHS.match(line):
                b["neighs"] = float(NEIGHS.match(line)[1])
            elif BUILDS.match(line):
                b["builds"] = int(BUILDS.match(line)[1])
    return blocks


def main(paths):
    if not paths:
        sys.exit(__doc__)
    rows, per_step = [], {}
    for p in paths:
        blocks = parse(p)
        name = re.sub(r"^.*/|\.log$", "", p)
        if len(blocks) < 2:
            rows.append(f"| {name} | incomplete: {len(blocks)} of 2 runs finished "
                        f"(settle loop {blocks[0]['loop']:.1f} s) |" if blocks else
                        f"| {name} | no finished run |")
            continue
        settle, rot = blocks[0], blocks[-1]
        sps = rot["loop"] / rot["steps"]
        ssc = rot["atoms"] * rot["steps"] / rot["loop"] / rot["procs"]
        per_step[name] = (sps, rot["procs"])
        pair = rot["parts"].get("Pair", (float("nan"),) * 2)
        other = rot["parts"].get("Other", (float("nan"),) * 2)
        rows.append(f"| {name} | {rot['atoms']} | {rot['procs']} | {rot['steps']} | "
                    f"{rot['loop']:.2f} | {sps:.3e} | {ssc:.3e} | {settle['loop']:.1f} | "
                    f"{pair[1]:.1f} | {other[1]:.1f} | {rot['builds']} | {rot['neighs']} |")
    print("| log | spheres | ranks | rot. steps | loop [s] | s/step | sphere-steps/s/core "
          "| settle loop [s] | Pair % | Other % | neigh builds | neighs/sphere |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    sp = []
    for name, (sps, procs) in sorted(per_step.items()):
        if procs == 1 and "np1" in name:
            other = name.replace("np1", "np2")
            if other in per_step:
                sp.append(f"{name} -> {other}: speed-up {sps / per_step[other][0]:.2f}")
    if sp:
        print()
        print("\n".join(sp))


if __name__ == "__main__":
    main(sys.argv[1:])
