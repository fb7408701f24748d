#!/usr/bin/env bash
# GPU engine speed on the drum benchmark cases (docs/gpu.md): microseconds per step and
# sphere-steps per second over the timed rotation phase of a settled bed, the wall time that
# implies for the SPEC's 3 revolutions at 0.5 rpm, and the CPU engine beside it.
#
#   bash bench/run_gpu_bench.sh [case ...]     cases: glass_small glass raw (default: all three)
#
# Environment: DEVICE=gpu (or gpu-emulated to try the script without a GPU), CPU_THREADS="16"
# (CPU engine runs for comparison; empty to skip), OUT=/tmp/biodem-gpu-bench,
# BIODEM=./build/biodem. Build first (docs/gpu.md: lean build on GPU machines).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
cases=${*:-glass_small glass raw}
DEVICE=${DEVICE:-gpu}
CPU_THREADS=${CPU_THREADS-16}
OUT=${OUT:-/tmp/biodem-gpu-bench}
BIODEM=${BIODEM:-$root/build/biodem}
mkdir -p "$OUT"
results="$OUT/gpu_results.csv"
echo "engine,case,spheres,timed_steps,wall_s,us_per_step,sphere_steps_per_s,dt_s,three_revolutions_h,timed_list_builds" > "$results"

run_one() {  # engine-label case extra-args...
  local label=$1 c=$2; shift 2
  local d="$OUT/${label}_${c}"
  rm -rf "$d"
  local f="$here/cases/${c}_bench.toml"
  "$BIODEM" run "$f" --out "$d" "$@" > "$d.screen" 2>&1 || { echo "$label,$c,,,,,,,(failed: $d.screen)," | tee -a "$results"; return; }
  python3 - "$d/run.log" "$label" "$c" "$f" <<'PY' | tee -a "$results"
import re, sys
log, label, case, casefile = sys.argv[1:5]
text = open(log).read()
m = re.search(r"phase 'rotate' ends .* after (\d+) steps; wall ([0-9.e+-]+) s", text)
spheres = int(re.search(r"^bodies: \d+, spheres: (\d+)", text, re.M).group(1))
dt = float(re.search(r"^dt_s\s*=\s*([0-9.eE+-]+)", open(casefile).read(), re.M).group(1))
steps, wall = int(m.group(1)), float(m.group(2))
b = re.search(r"phase 'rotate' ends .*?; (\d+) list builds", text)  # the timed phase's list builds
builds = b.group(1) if b else ""
us = 1e6 * wall / steps
three_rev_steps = 3 * 60.0 / 0.5 / dt
print(f"{label},{case},{spheres},{steps},{wall:.4g},{us:.4g},{spheres*steps/wall:.4g},{dt},{three_rev_steps*us*1e-6/3600:.3g},{builds}")
PY
}

for c in $cases; do
  run_one "$DEVICE" "$c" --device "$DEVICE"
  for t in $CPU_THREADS; do run_one "cpu_t$t" "$c" --threads "$t"; done
done
echo "results: $results"
