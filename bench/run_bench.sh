#!/usr/bin/env bash
# Side-by-side speed of biodem and LIGGGHTS 3.8.0 on the same drum cases, same machine, same
# session (README "Performance"). Figures: sphere-steps per second per core over the timed
# rotation phase (settled bed), and the ratio biodem / LIGGGHTS.
#
#   bash bench/run_bench.sh [case ...]      cases: bench/cases/<case>_bench.toml or <case>.toml:
#                                           glass_small glass raw clump_overhead_needles
#                                           clump_overhead_spheres (default: glass_small glass)
#
# Environment: THREADS="1 2" (biodem threads and LIGGGHTS MPI ranks), NO_LIGGGHTS=1 to skip the
# peer, OUT=/tmp/biodem-bench. Build first with scripts/build.sh (optionally -DBIODEM_NATIVE=ON).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
cases=${*:-glass_small glass}
THREADS=${THREADS:-1 2}
OUT=${OUT:-/tmp/biodem-bench}
mkdir -p "$OUT"
results="$OUT/results.csv"
echo "code,case,cores,spheres,timed_steps,wall_s,sphere_steps_per_s_per_core" > "$results"

for c in $cases; do
  for t in $THREADS; do
    d="$OUT/biodem_${c}_t$t"
    rm -rf "$d"
    f="$here/cases/${c}_bench.toml"; [ -f "$f" ] || f="$here/cases/${c}.toml"
    "$root/build/biodem" run "$f" --out "$d" --threads "$t" > "$d.screen" 2>&1
    line=$(grep "phase 'rotate' ends" "$d/run.log")
    steps=$(sed -E "s/.* after ([0-9]+) steps.*/\1/" <<<"$line")
    wall=$(sed -E "s/.*wall ([0-9.e+-]+) s.*/\1/" <<<"$line")
    spheres=$(sed -nE "s/^bodies: [0-9]+, spheres: ([0-9]+)/\1/p" "$d/run.log")
    rate=$(python3 -c "print(f'{$spheres*$steps/$wall/$t:.4g}')")
    echo "biodem,$c,$t,$spheres,$steps,$wall,$rate" | tee -a "$results"
  done
  case $c in glass|glass_small|raw) peer=1 ;; *) peer= ;; esac   # LIGGGHTS inputs exist for these
  if [ -n "$peer" ] && [ -z "${NO_LIGGGHTS:-}" ] && command -v liggghts > /dev/null; then
    for t in $THREADS; do
      (cd "$here/liggghts" && NPS="$t" NICE= sh run_bench.sh "_cmp" "$c" > /dev/null 2>&1) || true
      log="$here/liggghts/logs/${c}_np${t}_cmp.log"
      [ -f "$log" ] || { echo "liggghts,$c,$t,,,,(no log)" | tee -a "$results"; continue; }
      python3 - "$log" "$t" "$c" <<'PY' | tee -a "$results"
import re, sys
log, ranks, case = sys.argv[1], int(sys.argv[2]), sys.argv[3]
text = open(log).read()
loops = re.findall(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms", text)
if not loops:
    print(f"liggghts,{case},{ranks},,,,(incomplete)"); sys.exit()
wall, steps, atoms = float(loops[-1][0]), int(loops[-1][1]), int(loops[-1][2])
print(f"liggghts,{case},{ranks},{atoms},{steps},{wall},{atoms*steps/wall/ranks:.4g}")
PY
    done
  fi
done
echo "results: $results"
