#!/usr/bin/env bash
# Where the GPU engine's step time goes, and which launch settings help (docs/gpu.md section 4):
#   1. Nsight Compute (ncu) kernel durations in a window of the timed rotation phase of each
#      bench drum (plain launches, BIODEM_GPU_GRAPH=0, so that ncu counts every kernel);
#   2. bench/run_gpu_bench.sh on the GPU with BIODEM_GPU_PROFILE=1 (where the whole runs' step
#      time went: step kernels, list checks, list builds; OUT/profile.txt), with the list checks
#      waiting for their reduction (BIODEM_GPU_QUEUED_CHECK=0), and for several values of
#      BIODEM_GPU_FORCES (force kernels), BIODEM_GPU_ROW_LANES (lanes per row walk),
#      BIODEM_GPU_WALK_KICK (the row walk with the body update, single-sphere drums),
#      BIODEM_GPU_RECORDS and BIODEM_GPU_OWN_SPHERE (how the contact kernels load the spheres),
#      BIODEM_GPU_BODY_LANES (the clumps' body kernel by a group of lanes per body),
#      BIODEM_GPU_PDL (programmatic dependent launch), the list
#      build by one thread per row (BIODEM_GPU_BUILD_LANES=1, profiled beside the default),
#      BIODEM_GPU_SKIN_DIAMETERS (the device list's skin), BIODEM_GPU_BLOCK (threads per block)
#      and BIODEM_GPU_CHECK_EVERY (most steps between list checks), the default first and again
#      last (the spread of the two is the noise).
# No setting but one changes results: they change which of the bit-identical kernel sets runs,
# how the kernels are launched and when the list is rebuilt, and results do not depend on the
# rebuild (docs/gpu.md section 2). The exception is BIODEM_GPU_SUMS=fixed, the order-free
# family, whose fixed-point sums give results of their own (the same on any number of threads).
#
#   bash bench/run_gpu_sweep.sh          Environment: BIODEM (default build/biodem), OUT
#                                        (default /tmp/biodem-gpu-sweep), SWEEP_CASES, NCU_CASES
#                                        (empty: no ncu), NCU_DETAIL (1: ncu's sections of
#                                        step kernels, part 1b), SWEEP_SETTINGS (empty:
#                                        no sweep)
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
BIODEM=${BIODEM:-$root/build/biodem}
OUT=${OUT:-/tmp/biodem-gpu-sweep}
mkdir -p "$OUT"
cases=${SWEEP_CASES:-glass_small glass raw}

# -------------------------------------------------------------------- 1. kernel durations
ncu_bin=$(command -v ncu || echo /usr/local/cuda/bin/ncu)
declare -A skip=([glass_small]=62000 [glass]=40000 [raw]=66000)
for c in ${NCU_CASES-glass_small raw}; do
  [ -x "$ncu_bin" ] || { echo "ncu not found"; break; }
  rm -rf "$OUT/ncu_$c"
  BIODEM_GPU_GRAPH=0 timeout 90 "$ncu_bin" --clock-control none --metrics gpu__time_duration.sum \
    --launch-skip "${skip[$c]}" --launch-count 80 --csv \
    "$BIODEM" run "$here/cases/${c}_bench.toml" --out "$OUT/ncu_$c" --device gpu > "$OUT/ncu_$c.csv" 2> "$OUT/ncu_$c.err"
  echo "ncu $c: status $?"
  python3 - "$OUT/ncu_$c.csv" "$c" <<'PY'
import csv, re, sys, collections
path, case = sys.argv[1], sys.argv[2]
lines = [l for l in open(path, errors="replace") if l.startswith('"')]
rows = list(csv.DictReader(lines))
agg = collections.OrderedDict()
for r in rows:
    if r.get("Metric Name") != "gpu__time_duration.sum":
        continue
    name = r["Kernel Name"]
    m = re.search(r"(SumEntries<[^>]*>|Forces<[^>]*>|ReduceKickDrift|KickDriftSpheres|ReduceKick|SettleUpdate|block_sums|sum_blocks|"
                  r"DeviceReduce\w*|DeviceRadixSort\w*|DeviceScan\w*|DeviceMergeSort\w*|[A-Z][A-Za-z]+)", name)
    key = (m.group(1) if m else name[:40]) + f" [{r['Grid Size']}x{r['Block Size']}]"
    v = float(r["Metric Value"].replace(",", ""))
    unit = r["Metric Unit"]
    us = v / 1000.0 if unit in ("nsecond", "ns") else v * 1000.0 if unit in ("msecond", "ms") else v
    a = agg.setdefault(key, [0, 0.0])
    a[0] += 1; a[1] += us
print(f"{case}: kernel durations (ncu, {sum(a[0] for a in agg.values())} kernels)")
for k, (n, t) in agg.items():
    print(f"  {k:60s} n={n:3d} mean {t/n:8.2f} us")
PY
done

# ---------------------------------------------------- 1b. what the step kernels wait for (NCU_DETAIL=1)
# ncu's sections (speed of light, occupancy, launch, warp states, scheduler, memory and compute
# workload) of four launches of the step kernels in the timed rotation phase of each of three
# runs, with the caches as the run leaves them (--cache-control none): glass_small with the entry
# kernels, the same with their sums by the row lanes, raw with the row walk by one thread per
# sphere. The kernels are named by their demangled names (all launch for_each_index). The launches are counted among those kernels only.
if [ "${NCU_DETAIL:-0}" = 1 ] && [ -x "$ncu_bin" ]; then
  run_detail() {  # case launches-to-skip label VAR=value...
    local c=$1 skipn=$2 label=$3
    shift 3
    env "$@" BIODEM_GPU_GRAPH=0 timeout 100 "$ncu_bin" --clock-control none --cache-control none \
      --kernel-name-base demangled --kernel-name 'regex:PairEntries|SumEntries|Forces|ReduceKickDrift' --launch-skip "$skipn" --launch-count 4 \
      --section SpeedOfLight --section Occupancy --section LaunchStats --section WarpStateStats \
      --section SchedulerStats --section MemoryWorkloadAnalysis --section ComputeWorkloadAnalysis \
      "$BIODEM" run "$here/cases/${c}_bench.toml" --out "$OUT/ncud_$label" --device gpu > "$OUT/ncu_detail_$label.txt" 2>&1
    echo "ncu detail $label: status $?"
  }
  run_detail glass_small 24000 glass_small_entries BIODEM_GPU_FORCES=entries
  run_detail glass_small 24000 glass_small_sum_lanes BIODEM_GPU_FORCES=entries BIODEM_GPU_SUM_LANES=1
  run_detail raw 61000 raw_walk1 BIODEM_GPU_FORCES=rows BIODEM_GPU_ROW_LANES=1
fi

# ------------------------------------------------------------------------ 2. the sweep
results="$OUT/sweep.csv"
rm -f "$OUT/profile.txt"
echo "setting,engine,case,spheres,timed_steps,wall_s,us_per_step,sphere_steps_per_s,dt_s,three_revolutions_h,timed_list_builds" > "$results"
# (most telling first, so that a sweep cut short by its time limit keeps them: the default
# without the list guard (BIODEM_GPU_LIST_GUARD=0, since 2026-11-28: what the guard's test in
# every drift, its flag loads in every step kernel and its wait per advance cost); the default's
# timed choice without the candidate sets built after lease 11 (the packed walks and the body
# kernel by lanes; the difference to the default is what they gave through it); the walk with
# the body update forced and apart (on the raw drum the clumps' ForcesKickDriftGroups, not yet
# timed), the one-thread walks with their touching contacts shared across a warp
# (BIODEM_GPU_WALK_PACK=1, not yet timed; apart from the body update and with it, on the raw
# drum the clumps' groups), and the same by 2 lanes per sphere (BIODEM_GPU_PACK_SPLIT=2; with
# the body update on the glass drums only: the clumps' groups do not split), and with the body
# update by 4 (for glass_small),
# then the other changes not yet timed, between two defaults; threads per block and
# steps between checks, which changed nothing on 2026-11-26, the skins, the row walk with 2, 4
# (BIODEM_GPU_FORCES=rows) or 8 lanes and the build by one thread per row, measured in every
# lease of 2026-11-26 and 27, BIODEM_GPU_QUEUED_CHECK=0 (likewise) and the one-thread walk
# holding its own sphere alone, are left to SWEEP_SETTINGS: 29
# settings, about 220 s on the H100 as lease 9's 23 took 170)
# (a setting may set several variables, joined by "+"; so no value may contain "+")
settings=${SWEEP_SETTINGS-default BIODEM_GPU_LIST_GUARD=0 BIODEM_GPU_WALK_PACK=0+BIODEM_GPU_BODY_LANES=1 \
  BIODEM_GPU_FORCES=rows+BIODEM_GPU_ROW_LANES=1+BIODEM_GPU_WALK_KICK=1 \
  BIODEM_GPU_FORCES=rows+BIODEM_GPU_ROW_LANES=1+BIODEM_GPU_WALK_KICK=0 \
  BIODEM_GPU_FORCES=rows+BIODEM_GPU_ROW_LANES=1+BIODEM_GPU_WALK_KICK=0+BIODEM_GPU_WALK_PACK=1 \
  BIODEM_GPU_FORCES=rows+BIODEM_GPU_ROW_LANES=1+BIODEM_GPU_WALK_KICK=1+BIODEM_GPU_WALK_PACK=1 \
  BIODEM_GPU_FORCES=rows+BIODEM_GPU_ROW_LANES=1+BIODEM_GPU_WALK_KICK=0+BIODEM_GPU_WALK_PACK=1+BIODEM_GPU_PACK_SPLIT=2 \
  BIODEM_GPU_FORCES=rows+BIODEM_GPU_ROW_LANES=1+BIODEM_GPU_WALK_KICK=1+BIODEM_GPU_WALK_PACK=1+BIODEM_GPU_PACK_SPLIT=2 \
  BIODEM_GPU_FORCES=rows+BIODEM_GPU_ROW_LANES=1+BIODEM_GPU_WALK_KICK=1+BIODEM_GPU_WALK_PACK=1+BIODEM_GPU_PACK_SPLIT=4 BIODEM_GPU_RECORDS=1 \
  BIODEM_GPU_RECORDS=1+BIODEM_GPU_OWN_SPHERE=1 BIODEM_GPU_BODY_LANES=auto \
  BIODEM_GPU_RECORDS=1+BIODEM_GPU_OWN_SPHERE=1+BIODEM_GPU_BODY_LANES=auto \
  BIODEM_GPU_FORCES=rows+BIODEM_GPU_WALK_KICK=1+BIODEM_GPU_RECORDS=1 BIODEM_GPU_SUMS=fixed+BIODEM_GPU_RECORDS=1 default \
  BIODEM_GPU_SUMS=fixed BIODEM_GPU_SUMS=fixed+BIODEM_GPU_FORCES=entries \
  BIODEM_GPU_SUMS=fixed+BIODEM_GPU_FORCES=rows BIODEM_GPU_SUMS=fixed+BIODEM_GPU_FORCES=rows+BIODEM_GPU_ROW_LANES=1 \
  BIODEM_GPU_FORCES=entries BIODEM_GPU_FORCES=entries+BIODEM_GPU_PAIR_LIST=full BIODEM_GPU_SUMS=fixed+BIODEM_GPU_PAIR_LIST=full \
  BIODEM_GPU_PDL=0 BIODEM_GPU_PROFILE=1 \
  BIODEM_GPU_FORCES=entries+BIODEM_GPU_SUM_LANES=1 BIODEM_GPU_FORCES=rows+BIODEM_GPU_WALK_KICK=1 default}
[ -n "$settings" ] || exit 0
for setting in $settings; do
  envs=()
  [ "$setting" != default ] && IFS=+ read -ra envs <<< "$setting"
  env "${envs[@]}" DEVICE=gpu BIODEM="$BIODEM" OUT="$OUT/s" CPU_THREADS="" timeout 60 bash "$here/run_gpu_bench.sh" $cases > /dev/null 2>&1
  tail -n +2 "$OUT/s/gpu_results.csv" | sed "s/^/$setting,/" >> "$results"
  case "$setting" in BIODEM_GPU_PROFILE=1*)  # where the time of the whole runs went
    for c in $cases; do
      echo "$c ($setting): $(grep -h 'GPU profile' "$OUT/s/gpu_$c/run.log" 2>/dev/null || echo '(no profile line)')"
    done | tee -a "$OUT/profile.txt" ;;
  esac
done
python3 - "$results" <<'PY'
import csv, sys, collections
rows = list(csv.DictReader(open(sys.argv[1])))
cases = list(dict.fromkeys(r["case"] for r in rows))
print("us/step by setting: " + ", ".join(cases))
seen = collections.Counter()
for r in rows:
    pass
table = collections.OrderedDict()
for r in rows:
    k = r["setting"]
    seen[(k, r["case"])] += 1
    n = seen[(k, r["case"])]
    key = k if n == 1 else f"{k} ({n})"
    table.setdefault(key, {})[r["case"]] = r["us_per_step"]
for k, v in table.items():
    print(f"  {k:28s} " + "  ".join(f"{v.get(c, '-'):>8s}" for c in cases))
PY
