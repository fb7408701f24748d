#!/usr/bin/env bash
# List builds of the bench drums' rotation phase with several device skins (docs/gpu.md
# section 4): each drum settles on the CPU engine and stops at the end of its settle phase
# (a checkpoint), then the rotation phase resumes on the GPU engine once per skin, and the phase
# line of run.log gives its list builds. Emulated by default (the build times follow from the
# list check's rule, not from the device); no timing.
#
#   bash bench/count_skin_builds.sh [case ...]     cases: glass_small glass raw (default: all three)
#
# Environment: DEVICE=gpu-emulated (or gpu), SKINS="case 0.25 0.5 1" (device skin in smallest
# sphere diameters, "case": the case's own), ROTATION_STEPS=6000 (at most; fewer if the case
# has fewer), THREADS=2, OUT=/tmp/biodem-skin-builds, BIODEM=./build/biodem.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
cases=${*:-glass_small glass raw}
DEVICE=${DEVICE:-gpu-emulated}
SKINS=${SKINS:-case 0.25 0.5 1}
ROTATION_STEPS=${ROTATION_STEPS:-6000}
THREADS=${THREADS:-2}
OUT=${OUT:-/tmp/biodem-skin-builds}
BIODEM=${BIODEM:-$root/build/biodem}
mkdir -p "$OUT"
echo "case,skin_diameters,rotation_steps,list_builds,steps_per_build,row_capacity" > "$OUT/builds.csv"
for c in $cases; do
  src="$here/cases/${c}_bench.toml"
  # The case with its rotation phase cut to ROTATION_STEPS, and the settle phase's length.
  settle=$(python3 - "$src" "$OUT/$c.toml" "$ROTATION_STEPS" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
def steps_of(name):
    i = text.index(f'name = "{name}"')
    m = re.compile(r"^steps\s*=\s*(\d+)", re.M).search(text, i)
    return m
settle, rot = steps_of("settle"), steps_of("rotate")
n = min(int(rot.group(1)), int(sys.argv[3]))
open(sys.argv[2], "w").write(text[:rot.start()] + f"steps = {n}" + text[rot.end():])
print(settle.group(1))
PY
)
  base="$OUT/${c}_settled"
  rm -rf "$base"
  # SIGTERM once the settle phase is done: a checkpoint at its last step.
  BIODEM_TEST_SIGNAL_AT_STEP="$settle" "$BIODEM" run "$OUT/$c.toml" --out "$base" --threads "$THREADS" > "$base.screen" 2>&1 || true
  [ -f "$base/checkpoint.bin" ] || { echo "$c: no checkpoint after the settle phase (see $base.screen)" >&2; exit 1; }
  for f in $SKINS; do
    d="$OUT/${c}_skin_$f"
    rm -rf "$d"
    cp -r "$base" "$d"
    envs=()
    [ "$f" != case ] && envs=("BIODEM_GPU_SKIN_DIAMETERS=$f")
    env "${envs[@]}" "$BIODEM" run "$OUT/$c.toml" --out "$d" --resume --device "$DEVICE" --threads "$THREADS" > "$d.screen" 2>&1
    python3 - "$d/run.log" "$c" "$f" <<'PY' | tee -a "$OUT/builds.csv"
import re, sys
text = open(sys.argv[1]).read()
m = re.search(r"phase 'rotate' ends .* after (\d+) steps;.*?; (\d+) list builds", text)
cap = re.search(r"row capacity (\d+)", text)
steps, builds = int(m.group(1)), int(m.group(2))
print(f"{sys.argv[2]},{sys.argv[3]},{steps},{builds},{steps / builds if builds else float('inf'):.1f},{cap.group(1) if cap else ''}")
PY
  done
done
echo "results: $OUT/builds.csv"
