#!/usr/bin/env bash
# Side-by-side speed of biodem and LIGGGHTS 3.8.0 on the same drum cases, same machine, same
# session (README "Performance", docs/performance.md). Figures: sphere-steps per second per core
# over the timed rotation phase (settled bed), and the ratios the project tracks:
#   - biodem 1 -> 2 threads speed-up, for each repetition (runs interleaved: 1, 2, 1, 2, ...);
#   - biodem 1 thread / LIGGGHTS 1 rank, with LIGGGHTS at its recommended skin (d/2) and at
#     biodem's default skin (d/8 since 2026-11-25; d/4 before).
#
#   bash bench/run_bench.sh [case ...]      cases: bench/cases/<case>_bench.toml or <case>.toml:
#                                           glass_small glass raw clump_overhead_needles
#                                           clump_overhead_spheres (default: glass_small glass)
#
# Environment: THREADS="1 2" (biodem threads and LIGGGHTS MPI ranks), REPS=3 (interleaved biodem
# repetitions), LIGGGHTS_SKINS="1.0 0.25" (LIGGGHTS skin / radius; its 1-rank runs use every value,
# the other rank counts the first), NO_LIGGGHTS=1 to skip the peer, OUT=/tmp/biodem-bench.
# Build first with scripts/build.sh (optionally -DBIODEM_NATIVE=ON). Run on an idle machine: a
# second job on a 2-core machine halves the 2-thread figures.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
cases=${*:-glass_small glass}
THREADS=${THREADS:-1 2}
REPS=${REPS:-3}
LIGGGHTS_SKINS=${LIGGGHTS_SKINS:-1.0 0.25}
OUT=${OUT:-/tmp/biodem-bench}
mkdir -p "$OUT"
results="$OUT/results.csv"
echo "code,case,cores,rep,skin,spheres,timed_steps,wall_s,sphere_steps_per_s_per_core" > "$results"

for c in $cases; do
  f="$here/cases/${c}_bench.toml"; [ -f "$f" ] || f="$here/cases/${c}.toml"
  for rep in $(seq 1 "$REPS"); do
    for t in $THREADS; do
      d="$OUT/biodem_${c}_t${t}_r$rep"
      rm -rf "$d"
      "$root/build/biodem" run "$f" --out "$d" --threads "$t" --profile > "$d.screen" 2>&1
      line=$(grep "phase 'rotate' ends" "$d/run.log")
      steps=$(sed -E "s/.* after ([0-9]+) steps.*/\1/" <<<"$line")
      wall=$(sed -E "s/.*wall ([0-9.e+-]+) s.*/\1/" <<<"$line")
      spheres=$(sed -nE "s/^bodies: [0-9]+, spheres: ([0-9]+)/\1/p" "$d/run.log")
      rate=$(python3 -c "print(f'{$spheres*$steps/$wall/$t:.4g}')")
      echo "biodem,$c,$t,$rep,default,$spheres,$steps,$wall,$rate" | tee -a "$results"
    done
  done
  case $c in glass|glass_small|raw) peer=1 ;; *) peer= ;; esac   # LIGGGHTS inputs exist for these
  if [ -n "$peer" ] && [ -z "${NO_LIGGGHTS:-}" ] && command -v liggghts > /dev/null; then
    first_skin=${LIGGGHTS_SKINS%% *}
    for skin in $LIGGGHTS_SKINS; do
      for t in $THREADS; do
        [ "$t" != 1 ] && [ "$skin" != "$first_skin" ] && continue
        tag="_cmp_s$skin"
        (cd "$here/liggghts" && SKINF="$skin" NPS="$t" NICE= sh run_bench.sh "$tag" "$c" > /dev/null 2>&1) || true
        log="$here/liggghts/logs/${c}_np${t}${tag}.log"
        [ -f "$log" ] || { echo "liggghts,$c,$t,1,$skin,,,,(no log)" | tee -a "$results"; continue; }
        python3 - "$log" "$t" "$c" "$skin" <<'PY' | tee -a "$results"
import re, sys
log, ranks, case, skin = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
text = open(log).read()
loops = re.findall(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms", text)
if not loops:
    print(f"liggghts,{case},{ranks},1,{skin},,,,(incomplete)"); sys.exit()
wall, steps, atoms = float(loops[-1][0]), int(loops[-1][1]), int(loops[-1][2])
print(f"liggghts,{case},{ranks},1,{skin},{atoms},{steps},{wall},{atoms*steps/wall/ranks:.4g}")
PY
      done
    done
  fi
done

python3 - "$results" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
def rate(r):
    try: return float(r["sphere_steps_per_s_per_core"])
    except ValueError: return None
print("\nsummary (sphere-steps/s/core; speed-up = 2-thread total / 1-thread, per repetition)")
for case in dict.fromkeys(r["case"] for r in rows):
    b = [r for r in rows if r["case"] == case and r["code"] == "biodem"]
    one = {r["rep"]: rate(r) for r in b if r["cores"] == "1"}
    two = {r["rep"]: rate(r) for r in b if r["cores"] == "2"}
    print(f"{case}:")
    if one: print("  biodem 1 thread:  " + ", ".join(f"{v:.3g}" for v in one.values()))
    if two: print("  biodem 2 threads: " + ", ".join(f"{v:.3g}" for v in two.values()) + " per core")
    ups = [2 * two[k] / one[k] for k in one if k in two and one[k] and two[k]]
    if ups: print("  1->2 speed-up:    " + ", ".join(f"{u:.2f}x" for u in ups) + f"  (min {min(ups):.2f}x, target >= 1.8x)")
    ones = sorted(v for v in one.values() if v)
    best1 = ones[len(ones) // 2] if ones else None  # the median repetition
    for r in rows:
        if r["case"] != case or r["code"] != "liggghts" or rate(r) is None: continue
        line = f"  LIGGGHTS {r['cores']} rank(s), skin {r['skin']} x radius: {rate(r):.3g}"
        # the median repetition (the upper one of an even count) and the range of all of them
        if r["cores"] == "1" and best1:
            line += (f"  -> biodem 1 thread / LIGGGHTS = {best1 / rate(r):.2f}x"
                     f" (repetitions {ones[0] / rate(r):.2f}-{ones[-1] / rate(r):.2f}x; target >= 3x)")
        if r["cores"] == "2" and two:
            twos = sorted(v for v in two.values() if v)
            best2 = twos[len(twos) // 2]
            line += (f"  -> biodem 2 threads / LIGGGHTS 2 ranks = {best2 / rate(r):.2f}x"
                     f" (repetitions {twos[0] / rate(r):.2f}-{twos[-1] / rate(r):.2f}x)")
        print(line)
PY
echo "results: $results"
