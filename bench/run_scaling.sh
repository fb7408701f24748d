#!/usr/bin/env bash
# Thread scaling of the CPU engine (issue 18 item 5): one case run at 1, 2, 4, 8, 16 threads (those
# not above the machine's CPU count), the timed rotation phase of a settled bed, printed as
# us/step, sphere-steps/s per thread, speed-up over 1 thread and parallel efficiency, with the
# CPU cores the host actually gave each run (run.log's "CPU x cores" figure: a run that got less
# than it asked for is marked, its speed-up is not the engine's).
#
#   bash bench/run_scaling.sh [case]     case: bench/cases/<case>_bench.toml (default raw), or a case file
#
# Environment: THREADS="1 2 4 8 16", REPS=1 (repetitions, interleaved over the thread counts),
# OUT=/tmp/biodem-scaling, BIODEM=./build/biodem. Run on an otherwise idle machine.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
c=${1:-raw}
f="$here/cases/${c}_bench.toml"
if [ -f "$c" ]; then f=$c; c=$(basename "$c" .toml); fi  # or any case file with a 'rotate' phase
[ -f "$f" ] || { echo "no bench case $f" >&2; exit 2; }
BIODEM=${BIODEM:-$root/build/biodem}
OUT=${OUT:-/tmp/biodem-scaling}
REPS=${REPS:-1}
ncpu=$(nproc)
threads=()
for t in ${THREADS:-1 2 4 8 16}; do [ "$t" -le "$ncpu" ] && threads+=("$t"); done
mkdir -p "$OUT"
results="$OUT/scaling_${c}.csv"
echo "case,threads,rep,spheres,timed_steps,wall_s,us_per_step,sphere_steps_per_s_per_thread,cpu_cores_given,stepping_threads" > "$results"
for rep in $(seq 1 "$REPS"); do
  for t in "${threads[@]}"; do
    d="$OUT/${c}_t${t}_r$rep"
    rm -rf "$d"
    "$BIODEM" run "$f" --out "$d" --threads "$t" > "$d.screen" 2>&1
    line=$(grep "phase 'rotate' ends" "$d/run.log")
    steps=$(sed -E "s/.* after ([0-9]+) steps.*/\1/" <<<"$line")
    wall=$(sed -E "s/.*wall ([0-9.e+-]+) s.*/\1/" <<<"$line")
    cores=$(sed -nE "s/.*CPU ([0-9.]+) cores.*/\1/p" <<<"$line")
    stepping=$(sed -nE "s/.*cores for ([0-9]+) stepping thread.*/\1/p" <<<"$line")
    spheres=$(sed -nE "s/^bodies: [0-9]+, spheres: ([0-9]+)/\1/p" "$d/run.log")
    python3 -c "import sys; s,n,w,t=int('$spheres'),int('$steps'),float('$wall'),int('$t'); print(f'$c,{t},$rep,{s},{n},{w:.4g},{1e6*w/n:.4g},{s*n/w/t:.4g},${cores:-nan},${stepping:-$t}')" >> "$results"
  done
done
python3 - "$results" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
base = {}
for r in rows:
    if r["threads"] == "1":
        base.setdefault(r["rep"], float(r["us_per_step"]))
print(f"{'threads':>7} {'rep':>3} {'us/step':>9} {'Msph-st/s/thr':>13} {'speed-up':>8} {'efficiency':>10} {'cores given':>11}")
for r in rows:
    t, us = int(r["threads"]), float(r["us_per_step"])
    b = base.get(r["rep"])
    sp = b / us if b else float("nan")
    given = float(r["cpu_cores_given"]) if r["cpu_cores_given"] not in ("", "nan") else float("nan")
    used = int(r["stepping_threads"])
    mark = "  (host gave less than asked)" if given == given and given < 0.85 * used else ""
    if used < t:
        mark += f"  (below the parallel threshold: {used} stepping thread)"
    print(f"{t:>7} {r['rep']:>3} {us:>9.1f} {float(r['sphere_steps_per_s_per_thread'])/1e6:>13.2f} {sp:>8.2f} {sp/t:>10.2f} {given:>11.2f}{mark}")
PY
echo "results: $results"
