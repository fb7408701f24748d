#!/usr/bin/env bash
# What the step kernels are made of and where their warps wait, instruction by instruction
# (docs/gpu.md section 4), for the sessions without a GPU that read it afterwards:
#   1. the SASS of the step kernels (cuobjdump --dump-sass of the biodem binary, one file per
#      kernel whose name matches SASS_KERNELS, gzipped): what a machine without cuobjdump or
#      nvdisasm cannot make, and what says whether a load is wide, whether an array went to local
#      memory (LDL/STL) and how long each path is;
#   2. Nsight Compute's source counters (warp stall samples per SASS instruction, with the stall
#      reasons, and the instructions executed) of two launches of the step kernels in the timed
#      rotation phase: the raw drum with the row walk in one thread per sphere and the clumps'
#      body kernel (Forces, ReduceKickDrift), the same with the walks of a warp sharing their
#      touching contacts (BIODEM_GPU_WALK_PACK=1), glass_small with the entry kernels (PairEntries,
#      SumEntriesKickDrift), and the raw drum in the order-free family with its entry kernels
#      (PairEntriesFixed, ReduceKickDriftFixed). One CSV per run (ncu --page source), gzipped,
#      and the report file. ncu writes its report when the program ends: a run cut by its time
#      limit leaves nothing, so the limit is generous (the same runs took about 20 s each with
#      ncu's sections on 2026-11-26).
#
#   bash bench/gpu_sass.sh     Environment: BIODEM (default build/biodem), OUT (default
#                              /tmp/biodem-gpu-sass), SASS_KERNELS (a Python regular expression on
#                              the demangled names; default the step kernels), SASS_NCU (0: no
#                              ncu), SASS_NCU_S (seconds per ncu run, default 90)
# Needs a GPU for part 2 only; part 1 needs cuobjdump (CUDA toolkit).
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
BIODEM=${BIODEM:-$root/build/biodem}
OUT=${OUT:-/tmp/biodem-gpu-sass}
mkdir -p "$OUT"
pattern=${SASS_KERNELS:-ReduceKickDrift|SumEntriesKickDrift<|SumEntriesKickDrift>|PairEntries|Forces<|ForcesFixed<|ForcesKickDrift<|WalkKickGroups|KickDriftSpheres|TakeFixedSums}

# ------------------------------------------------------------------------------- 1. the SASS
cuobjdump=$(command -v cuobjdump || echo /usr/local/cuda/bin/cuobjdump)
if [ -x "$cuobjdump" ]; then
  "$cuobjdump" --dump-sass "$BIODEM" > "$OUT/sass_all.txt" 2> "$OUT/sass.err"
  echo "cuobjdump: status $?, $(wc -l < "$OUT/sass_all.txt") lines"
  python3 - "$OUT" "$pattern" <<'PY'
import gzip, re, subprocess, sys
out, pattern = sys.argv[1], sys.argv[2]
text = open(f"{out}/sass_all.txt", errors="replace").read()
# cuobjdump writes "Function : <mangled name>" before each kernel's code
parts = re.split(r"^\s*Function : (\S+)\s*$", text, flags=re.M)
names = parts[1::2]
bodies = parts[2::2]
demangled = subprocess.run(["c++filt"], input="\n".join(names), capture_output=True, text=True).stdout.split("\n")
index = []
for i, (m, d, body) in enumerate(zip(names, demangled, bodies)):
    instr = len(re.findall(r"/\*[0-9a-f]{4,}\*/", body))
    ldl = len(re.findall(r"\bLDL\b", body))
    stl = len(re.findall(r"\bSTL\b", body))
    ldg = len(re.findall(r"\bLDG\b", body))
    dfma = len(re.findall(r"\b(DFMA|DADD|DMUL)\b", body))
    short = re.sub(r"biodem::gpu::(cuda_device::)?", "", d)
    index.append(f"{i}\t{instr}\t{ldg}\t{ldl}\t{stl}\t{dfma}\t{short}")
    if re.search(pattern, d):
        with gzip.open(f"{out}/sass_{i:03d}.txt.gz", "wt") as f:
            f.write(f"// {d}\n// {m}\n{body}")
with open(f"{out}/sass_index.tsv", "w") as f:
    f.write("file\tinstructions\tLDG\tLDL\tSTL\tDADD_DMUL_DFMA\tkernel\n" + "\n".join(index) + "\n")
kept = sum(1 for d in demangled if re.search(pattern, d))
print(f"SASS: {len(names)} kernels, {kept} kept (sass_NNN.txt.gz, named in sass_index.tsv)")
PY
  rm -f "$OUT/sass_all.txt"
else
  echo "no cuobjdump: no SASS"
fi

# ------------------------------------------------------------ 2. stall samples per instruction
ncu_bin=$(command -v ncu || echo /usr/local/cuda/bin/ncu)
[ "${SASS_NCU:-1}" = 1 ] && [ -x "$ncu_bin" ] || { echo "no ncu run"; exit 0; }
# (the launch counts of bench/run_gpu_sweep.sh's part 1b, which landed in the rotation phase on
# 2026-11-26: two step kernels per step)
profile() {  # case launches-to-skip label VAR=value...
  local c=$1 skipn=$2 label=$3
  shift 3
  env "$@" BIODEM_GPU_GRAPH=0 timeout "${SASS_NCU_S:-90}" "$ncu_bin" --clock-control none --cache-control none \
    --kernel-name-base demangled --kernel-name 'regex:PairEntries|SumEntries|Forces|ReduceKickDrift' \
    --launch-skip "$skipn" --launch-count 2 --section SourceCounters --section WarpStateStats \
    --warp-sampling-interval 0 -f -o "$OUT/src_$label" \
    "$BIODEM" run "$here/cases/${c}_bench.toml" --out "$OUT/run_$label" --device gpu > "$OUT/src_$label.log" 2>&1
  echo "ncu $label: status $?"
  [ -f "$OUT/src_$label.ncu-rep" ] || return 0
  # the source page, SASS, as CSV (per instruction: stall samples by reason, instructions executed)
  "$ncu_bin" -i "$OUT/src_$label.ncu-rep" --page source --csv --print-source sass > "$OUT/src_$label.csv" 2> "$OUT/src_$label.err" ||
    "$ncu_bin" -i "$OUT/src_$label.ncu-rep" --page source --csv > "$OUT/src_$label.csv" 2>> "$OUT/src_$label.err"
  echo "ncu $label source page: $(wc -l < "$OUT/src_$label.csv") lines"
  "$ncu_bin" -i "$OUT/src_$label.ncu-rep" --page details > "$OUT/src_${label}_details.txt" 2>&1
  gzip -f "$OUT/src_$label.csv"
  rm -rf "$OUT/run_$label"
}
profile raw 61000 raw_walk1 BIODEM_GPU_FORCES=rows BIODEM_GPU_ROW_LANES=1
# (the same walk with the touching contacts shared across a warp: its active threads per warp
# against raw_walk1's 13.8 of 32)
profile raw 61000 raw_packed BIODEM_GPU_FORCES=rows BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_WALK_PACK=1
profile glass_small 24000 glass_small_entries BIODEM_GPU_FORCES=entries
profile raw 61000 raw_fixed BIODEM_GPU_SUMS=fixed BIODEM_GPU_FORCES=entries
ls -la "$OUT"
