#!/usr/bin/env bash
# The GPU engine's check in one command (docs/gpu.md section 6; issue 17). On a bare GPU machine
# (CUDA toolkit, CMake, a compiler; no network, no Debian packages: the lean build, with the
# vendor/ folder of scripts/vendor_headers.sh copied beside the sources):
#
#   bash scripts/gpu_check.sh
#
# builds, then runs, each recorded as PASS / FAIL / SKIP in one Markdown report:
#   1. the GPU tests (tests/gpu, GpuRuns.*) on the device, with CUDA_LAUNCH_BLOCKING=1 and without;
#   2. compute-sanitizer memcheck, initcheck, racecheck and synccheck on a short drum of 40,200
#      spheres (tests/cases/gpu_check_drum40k.toml), memcheck again with the entry contact
#      kernels (BIODEM_GPU_FORCES=entries), and the other kernel sets of GPU_CHECK_SANITIZER_JOBS
#      below; run after check 6, being the slowest;
#   3. two identical runs of a cohesive needle drum, compared byte for byte (series, trace,
#      snapshots, checkpoint), and (3b) the same run with every loop on two threads
#      (BIODEM_TEST_PARALLEL_THRESHOLD=0 --threads 2) compared with them;
#      (3c) the same run with plain kernel launches instead of CUDA graphs (BIODEM_GPU_GRAPH=0),
#      and (3d) a drum whose settle phase ends on the criterion evaluated on the device, with
#      and without graphs; (3e) the same run with ReduceKick and KickDriftSpheres launched
#      separately instead of the fused ReduceKickDrift (BIODEM_GPU_FUSE=0); (3f) the needle drum
#      and the settle drum of (3d) with the bodies kept in the host's order on the device
#      instead of sorted by cell (BIODEM_GPU_SORT=0); (3g) no CUDA graph capture failed and no
#      queued path was given up in any run, and the needle and settle drums ran graphs (on a GPU); (3h) a fault injected into the device at step 3,000
#      (BIODEM_TEST_GPU_FAULT_AT_STEP; on a GPU also met inside Thrust) ends the run with one
#      error line and status 2, not std::terminate; (3l) each queued list check's read equal to
#      a second read after waiting for the stream (BIODEM_GPU_VERIFY_QUEUED=1);
#      (3i) each contact kernel set forced (the entry kernels also with their sums by the row
#      lanes, BIODEM_GPU_SUM_LANES=1, and over every row entry instead of the pair list,
#      BIODEM_GPU_PAIR_LIST=full; the one-thread walk and the entry kernels reading the spheres'
#      records, BIODEM_GPU_RECORDS=1, the walk holding its own sphere, the entry kernels with
#      the clumps' body kernel by lanes, BIODEM_GPU_BODY_LANES=auto; the clumps' walk with the
#      body update, BIODEM_GPU_WALK_KICK=1; the one-thread walks of a warp sharing their touching
#      contacts, BIODEM_GPU_WALK_PACK=1), and on a GPU the row walk with 1, 2 and 32 lanes, the
#      groups of lanes per body and the shared touching contacts, with blocks of 32 and 512
#      threads, byte-identical to (3);
#      (3j) the list build by one thread per row (BIODEM_GPU_BUILD_LANES=1) byte-identical to
#      (3), and on a GPU the grouped build with 2, 8 and 32 lanes per row;
#   4. the same run killed after step 9,001 and resumed, compared byte for byte with (3);
#   5. the same run on the CPU engine: centroid angle, kinetic energy, contacts and final body
#      positions within stated tolerances;
#      (3k, after 5) the order-free family (BIODEM_GPU_SUMS=fixed): two runs byte-identical
#      (emulated, the second on 2 threads with every kernel parallel), its row walk
#      (BIODEM_GPU_FORCES=rows) byte-identical, killed and resumed (without the variable: the
#      checkpoint's family goes on) byte-identical, within the tolerances of (5) of the CPU engine; on a GPU it also reports
#      whether the GPU's run is byte-identical to the same run on CPU threads;
#   6. a scene that forces the device neighbour list to widen its rows (a big sphere among small
#      beads): widening seen in run.log, two runs byte-identical, the build by one thread per
#      row, the single-sphere body kernel with its sums by the row lanes, the row walk with
#      the body update (BIODEM_GPU_WALK_KICK=1; also reading the spheres' records, and in one
#      thread with the warp's touching contacts shared, BIODEM_GPU_WALK_PACK=1) and the entry kernels over every row entry
#      (BIODEM_GPU_PAIR_LIST=full) byte-identical, CPU engine agreement;
#   6b. a bulk test (tests/cases/shear_box_tiny.toml: a translating gate, a sink): two runs
#      byte-identical, the retainment within 0.05 of the CPU engine's, beads removed;
#   7. bench/run_gpu_bench.sh: us/step of the three bench drums, the CPU engine on all cores
#      beside it, and the hours for three revolutions.
# It exits non-zero if any check fails.
#
# GPU_CHECK_DEVICE=gpu-emulated runs every check that needs no GPU (3-6, and 1 on CPU threads) on
# the GPU engine's kernels on CPU threads, against an existing build; CI runs it that way
# (ctest: GpuCheckScript.Emulated).
#
# Environment:
#   GPU_CHECK_DEVICE     gpu (default) or gpu-emulated
#   GPU_CHECK_BUILD_DIR  build directory (default: build-gpucheck on a GPU, build emulated)
#   GPU_CHECK_BUILD      1: configure and build first (default on a GPU), 0: use the build as is
#   GPU_CHECK_OUT        output folder (default out/gpu_check); the report is OUT/report.md
#   GPU_CHECK_SKIP_CTEST 1: skip check 1 (when this script itself runs inside ctest)
#   GPU_CHECK_SANITIZER_JOBS  the sanitizer runs of check 2 as tool:kernels (kernels: auto,
#                        entries, rows1: the row walk by one thread per sphere, sumlanes:
#                        the entry kernels with their sums by the row lanes, spheres: the
#                        same on the wide-row scene of single spheres, walkkick: the row
#                        walk with the body update on that scene, fixed: the order-free
#                        family on the 40k drum, records: the one-thread walk reading the
#                        spheres' records, own sphere held, and the clumps' body kernel by
#                        lanes, on the 40k drum, kickgroups: the clumps' row walk with the
#                        body update by groups of lanes per body, records, on the 40k
#                        drum, packed: the one-thread walks sharing their touching contacts
#                        across a warp, packedsplit and packedsplit4: the same split over 2
#                        and 4 lanes per row, packedgroups: the clumps' walk with the body
#                        update sharing them); default the sixteen of docs/gpu.md section 6,
#                        empty: none
#   GPU_CHECK_BENCH      0: skip check 7 (default 1 on a GPU, 0 emulated)
#   GPU_CHECK_THREADS    CPU threads of the CPU-engine and emulated runs (default 1)
#   CUDA_ARCH            CMAKE_CUDA_ARCHITECTURES for the build (default 90: H100/H200)
#   GPU_CHECK_TIMEOUT    seconds allowed to each run, ctest or sanitizer command (default 0: no
#                        limit); one that runs over is killed and its check recorded as FAIL
# The report is rewritten after every check, so a check machine taken back half-way still leaves
# the checks done so far in it.
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
DEVICE=${GPU_CHECK_DEVICE:-gpu}
case "$DEVICE" in gpu|gpu-emulated) ;; *) echo "GPU_CHECK_DEVICE=$DEVICE: must be gpu or gpu-emulated" >&2; exit 2 ;; esac
if [ "$DEVICE" = gpu ]; then def_build=build-gpucheck; def_do_build=1; def_bench=1; else def_build=build; def_do_build=0; def_bench=0; fi
BUILD=${GPU_CHECK_BUILD_DIR:-$def_build}
case "$BUILD" in /*) ;; *) BUILD=$root/$BUILD ;; esac
DO_BUILD=${GPU_CHECK_BUILD:-$def_do_build}
OUT=${GPU_CHECK_OUT:-$root/out/gpu_check}
BENCH=${GPU_CHECK_BENCH:-$def_bench}
THREADS=${GPU_CHECK_THREADS:-1}
TMO=()
if [ "${GPU_CHECK_TIMEOUT:-0}" != 0 ]; then TMO=(timeout --kill-after=10 "$GPU_CHECK_TIMEOUT"); fi
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
report=$OUT/report.md
logs=$OUT/logs
rm -rf "$logs" && mkdir -p "$logs"
bin=$BUILD/biodem
failures=0
device_name="(not probed yet)"
rows=()

record() {  # name status detail
  rows+=("| $1 | $2 | $3 |")
  [ "$2" = FAIL ] && failures=$((failures + 1))
  printf '%-44s %s  %s\n' "$1" "$2" "$3"
  write_report > "$report.tmp" && mv "$report.tmp" "$report"
}

run_biodem() {  # label case out extra-args... -> exit status; output in $logs/label.txt
  local label=$1 casefile=$2 out=$3
  shift 3
  rm -rf "$out"
  "${TMO[@]}" "$bin" run "$casefile" --out "$out" --threads "$THREADS" "$@" > "$logs/$label.txt" 2>&1
}

variant_same() {  # ref-dir label VAR=value... -> status 0 when the needle drum run on the GPU with
  # those variables is byte-identical to ref-dir; else prints why (3i, 3j)
  local ref=$1 label=$2 diff
  shift 2
  ( export "$@"; run_biodem "$label" "$needles" "$OUT/$label" --device gpu ) || { echo "run failed"; return 1; }
  diff=$(same_files "$ref" "$OUT/$label") || { echo "differ: $(echo $diff)"; return 1; }
}

same_files() {  # dirA dirB -> prints the files that differ or are missing; status 0 if all equal
  local a=$1 b=$2 bad=0 f
  for f in series.csv trace.csv checkpoint.bin snapshots.pvd bodies.pvd $(cd "$a" && ls snapshots/*.vtu bodies/*.vtu speed_images/*.png 2>/dev/null); do
    [ -e "$a/$f" ] || continue
    if ! cmp -s "$a/$f" "$b/$f"; then echo "$f"; bad=1; fi
  done
  return $bad
}

write_report() {  # the report so far, Markdown, on stdout
  echo "# GPU engine check"
  echo
  echo "- date: $(date -u '+%Y-%m-%d %H:%M UTC')"
  echo "- commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet 2>/dev/null || echo ' (with uncommitted changes)')"
  echo "- device: $DEVICE — $device_name"
  if command -v nvidia-smi > /dev/null 2>&1; then
    echo "- nvidia-smi: $(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null | head -n 1)"
  fi
  echo "- host: $(uname -n), $(nproc) CPU threads; runs with --threads $THREADS"
  echo
  echo "| check | result | detail |"
  echo "|---|---|---|"
  printf '%s\n' "${rows[@]}"
  if [ -f "$OUT/bench/gpu_results.csv" ]; then
    echo
    echo "## bench/run_gpu_bench.sh"
    echo
    python3 - "$OUT/bench/gpu_results.csv" <<'PY'
import csv, sys
rows = list(csv.reader(open(sys.argv[1])))
print("| " + " | ".join(rows[0]) + " |")
print("|" + "---|" * len(rows[0]))
for r in rows[1:]:
    print("| " + " | ".join(r) + " |")
PY
  fi
  echo
  echo "Logs: \`$logs\`. $failures check(s) failed."
}

# ------------------------------------------------------------------------------------- build
if [ "$DO_BUILD" = 1 ]; then
  args=(-DCMAKE_BUILD_TYPE=Release -DBIODEM_BUILD_BENCH=OFF)
  if [ "$DEVICE" = gpu ]; then args+=(-DBIODEM_WITH_CUDA=ON "-DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90}"); fi
  if [ ! -d /usr/include/toml++ ] && [ -d "$root/vendor" ]; then  # lean build (docs/gpu.md section 5)
    args+=(-DBIODEM_WITH_OPENCV=OFF "-DBIODEM_VENDOR_DIR=$root/vendor")
  fi
  if cmake -S . -B "$BUILD" "${args[@]}" > "$logs/configure.txt" 2>&1 &&
     cmake --build "$BUILD" -j"$(nproc)" > "$logs/build.txt" 2>&1; then
    record "build" PASS "$(grep -c 'warning:' "$logs/build.txt") warnings; ${args[*]}"
  else
    record "build" FAIL "see logs/build.txt"
  fi
fi
if [ ! -x "$bin" ]; then
  record "biodem binary" FAIL "$bin not found (build first, or GPU_CHECK_BUILD=1)"
fi

device_name=$(run_biodem probe tests/cases/gpu_wide_rows_tiny.toml "$OUT/probe" --device "$DEVICE" &&
  sed -n 's/.*us\/step on \(.*\), device neighbour builds.*/\1/p' "$OUT/probe/run.log")
[ -n "$device_name" ] || device_name="(the engine did not start: $(tail -n 1 "$logs/probe.txt"))"

# ------------------------------------------------------------------- 1. the GPU test tiers
if [ "${GPU_CHECK_SKIP_CTEST:-0}" = 1 ]; then
  record "1. GPU tests" SKIP "GPU_CHECK_SKIP_CTEST=1 (run by the enclosing ctest)"
else
  sel='^(GpuEngine|GpuRuns)\.|GpuEngineKilled'
  if [ "$DEVICE" = gpu ]; then
    for blocking in 1 0; do
      if CUDA_LAUNCH_BLOCKING=$blocking BIODEM_TEST_GPU=1 "${TMO[@]}" ctest --test-dir "$BUILD" -R "$sel" --no-tests=error --output-on-failure \
           > "$logs/ctest_blocking$blocking.txt" 2>&1; then
        record "1. GPU tests, CUDA_LAUNCH_BLOCKING=$blocking" PASS "$(grep -o '[0-9]*% tests passed.*' "$logs/ctest_blocking$blocking.txt" | head -n 1)"
      else
        record "1. GPU tests, CUDA_LAUNCH_BLOCKING=$blocking" FAIL "see logs/ctest_blocking$blocking.txt"
      fi
    done
  else
    if "${TMO[@]}" ctest --test-dir "$BUILD" -R "$sel" --no-tests=error --output-on-failure > "$logs/ctest_emulated.txt" 2>&1; then
      record "1. GPU tests (CPU threads)" PASS "$(grep -o '[0-9]*% tests passed.*' "$logs/ctest_emulated.txt" | head -n 1)"
    else
      record "1. GPU tests (CPU threads)" FAIL "see logs/ctest_emulated.txt"
    fi
  fi
fi

# ------------------------------------------------------------ 3.-5. the cohesive needle drum
needles=tests/cases/gpu_needles_tiny.toml
expect_same() {  # name ok(0/1) fail-detail dirA dirB pass-detail: records the byte comparison
  local name=$1 ok=$2 why=$3 a=$4 b=$5 pass=$6 diff
  if [ "$ok" != 1 ]; then
    record "$name" FAIL "$why"
  elif diff=$(same_files "$a" "$b"); then
    record "$name" PASS "$pass"
  else
    record "$name" FAIL "differ: $(echo $diff)"
  fi
}

run_biodem needles_a "$needles" "$OUT/needles_a" --device "$DEVICE"; sa=$?
run_biodem needles_b "$needles" "$OUT/needles_b" --device "$DEVICE"; sb=$?
expect_same "3. two identical runs" "$([ $sa -eq 0 ] && [ $sb -eq 0 ] && echo 1)" \
  "a run failed (logs/needles_a.txt, needles_b.txt)" "$OUT/needles_a" "$OUT/needles_b" \
  "series, trace, snapshots and checkpoint byte-identical"

# 3b. Every loop on two threads, however small (BIODEM_TEST_PARALLEL_THRESHOLD=0): emulated, the
# kernels themselves run on two OpenMP threads; on a GPU, the host's share (insertion, sampling).
BIODEM_TEST_PARALLEL_THRESHOLD=0 THREADS=2 run_biodem needles_par "$needles" "$OUT/needles_par" --device "$DEVICE"; sp=$?
expect_same "3b. same run, every loop on 2 threads" "$([ $sp -eq 0 ] && [ $sa -eq 0 ] && echo 1)" \
  "a run failed (logs/needles_par.txt)" "$OUT/needles_a" "$OUT/needles_par" "byte-identical to the 1-thread run"

# 3c. The launches between list checks as plain kernels instead of CUDA graphs
# (BIODEM_GPU_GRAPH=0): the same kernels in the same order, so the same bytes; and the same pair
# on a case whose settle phase ends on the kinetic energy criterion evaluated on the device.
# Emulated there are no graphs and both runs launch plainly.
BIODEM_GPU_GRAPH=0 run_biodem needles_plain "$needles" "$OUT/needles_plain" --device "$DEVICE"; sg=$?
expect_same "3c. same run without CUDA graphs" "$([ $sg -eq 0 ] && [ $sa -eq 0 ] && echo 1)" \
  "a run failed (logs/needles_plain.txt)" "$OUT/needles_a" "$OUT/needles_plain" "byte-identical to the run with graphs"
# 3l. The queued list checks read what the device wrote: with BIODEM_GPU_VERIFY_QUEUED=1 each
# read of the reduction queued inside a run of steps (a CUDA graph's event record) is followed by
# a wait for the whole stream and a second read, and a difference stops the run. A stale read
# changes no byte unless a sphere passes half the skin, so only this check can see one. The run
# must be byte-identical to (3) and its run.log must count queued reads (emulated the switch
# does nothing: the same run, the same count).
BIODEM_GPU_VERIFY_QUEUED=1 run_biodem needles_verify "$needles" "$OUT/needles_verify" --device "$DEVICE"; sv=$?
nq=$(grep -o 'kernel by kernel; [0-9]* list checks read' "$OUT/needles_verify/run.log" 2>/dev/null | grep -o '[0-9][0-9]*' | head -n 1)
if [ $sv -ne 0 ] || [ $sa -ne 0 ]; then
  record "3l. queued list checks verified" FAIL "a run failed (logs/needles_verify.txt)"
elif [ -z "$nq" ] || [ "$nq" -eq 0 ]; then
  record "3l. queued list checks verified" FAIL "run.log counts no queued list check read (${nq:-no line})"
elif ! diff=$(same_files "$OUT/needles_a" "$OUT/needles_verify"); then
  record "3l. queued list checks verified" FAIL "differ: $(echo $diff)"
else
  record "3l. queued list checks verified" PASS "$nq queued reads, each equal to a second read after a wait; byte-identical to (3)"
fi
# 3h. A kernel that faults (on a GPU it traps, which breaks the CUDA context; emulated the
# error it would give) ends the run with one `biodem: error: GPU engine:` line and status 3 (a
# device fault, as an internal error): not std::terminate from a buffer freed during the
# unwinding (status 134), nor a CUDA error met inside Thrust and not named (`biodem: internal
# error:`), nor a run that goes on, nor a fallback line (a queued
# check or graph given up "for the rest of the run" as if the run could go on). On a GPU also
# with the fault met first inside a Thrust reduction (BIODEM_TEST_GPU_FAULT_IN_THRUST=1).
fault_ok=1; fault_detail=""
fault_runs="needles_fault"
[ "$DEVICE" = gpu ] && fault_runs="needles_fault needles_fault_thrust"
for fr in $fault_runs; do
  in_thrust=0; [ "$fr" = needles_fault_thrust ] && in_thrust=1
  BIODEM_TEST_GPU_FAULT_AT_STEP=3000 BIODEM_TEST_GPU_FAULT_IN_THRUST=$in_thrust \
    run_biodem "$fr" "$needles" "$OUT/$fr" --device "$DEVICE"; sf=$?
  fault_line=$(grep -m1 '^biodem: error: GPU engine: ' "$logs/$fr.txt" | cut -c1-160)
  if [ $sf -eq 3 ] && [ -n "$fault_line" ] && ! grep -q 'terminate called\|for the rest of the run' "$logs/$fr.txt"; then
    fault_detail="$fault_detail${fault_detail:+; }$fr: status $sf: $fault_line"
  else
    fault_ok=0; fault_detail="$fault_detail${fault_detail:+; }$fr: status $sf, see logs/$fr.txt"
  fi
done
[ $fault_ok = 1 ] && record "3h. a device fault ends the run with one line" PASS "$fault_detail" ||
  record "3h. a device fault ends the run with one line" FAIL "$fault_detail"
# 3i. The two contact kernel sets forced give the bytes of (3); on a GPU also the row walk with
# 1, 2, 16 and 32 lanes per sphere, each with blocks of 32 and 512 threads (the default: 4
# lanes, 64 threads; emulated these switches change nothing and are not run).
BIODEM_GPU_FORCES=rows run_biodem needles_rows "$needles" "$OUT/needles_rows" --device "$DEVICE"; sr=$?
BIODEM_GPU_FORCES=entries run_biodem needles_entries "$needles" "$OUT/needles_entries" --device "$DEVICE"; se=$?
BIODEM_GPU_FORCES=entries BIODEM_GPU_SUM_LANES=1 run_biodem needles_sum_lanes "$needles" "$OUT/needles_sum_lanes" --device "$DEVICE"; sl=$?
BIODEM_GPU_FORCES=entries BIODEM_GPU_PAIR_LIST=full run_biodem needles_full_pass "$needles" "$OUT/needles_full_pass" --device "$DEVICE"; sp=$?
# (the spheres read from their records, and the one-thread walk holding its own sphere)
BIODEM_GPU_FORCES=rows BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_RECORDS=1 BIODEM_GPU_OWN_SPHERE=1 run_biodem needles_records_rows "$needles" "$OUT/needles_records_rows" --device "$DEVICE"; sq=$?
BIODEM_GPU_FORCES=entries BIODEM_GPU_RECORDS=1 BIODEM_GPU_BODY_LANES=auto run_biodem needles_records_entries "$needles" "$OUT/needles_records_entries" --device "$DEVICE"; sx=$?
# (the clumps' row walk with the body update by a group of lanes per body, two buffers)
BIODEM_GPU_FORCES=rows BIODEM_GPU_WALK_KICK=1 run_biodem needles_walk_kick "$needles" "$OUT/needles_walk_kick" --device "$DEVICE"; sk=$?
# (the one-thread walks of a warp sharing their touching contacts; emulated, groups of one lane)
BIODEM_GPU_FORCES=rows BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_WALK_PACK=1 run_biodem needles_packed "$needles" "$OUT/needles_packed" --device "$DEVICE"; sw=$?
# (and the clumps' walk with the body update by groups of lanes per body, sharing them too)
BIODEM_GPU_FORCES=rows BIODEM_GPU_WALK_KICK=1 BIODEM_GPU_WALK_PACK=1 run_biodem needles_packed_groups "$needles" "$OUT/needles_packed_groups" --device "$DEVICE"; sg=$?
lanes_ok=1; d1=""; d2=""; d3=""; d4=""; d5=""; d6=""; d7=""; d8=""; d9=""; d=""
lanes_detail="rows, entries, entries with the sums by the row lanes (BIODEM_GPU_SUM_LANES=1), entries over every row entry instead of the pair list (BIODEM_GPU_PAIR_LIST=full), the one-thread walk and the entries reading the spheres' records (BIODEM_GPU_RECORDS=1, the walk with BIODEM_GPU_OWN_SPHERE=1, the entries with the clumps' body kernel by lanes, BIODEM_GPU_BODY_LANES=auto), the walk with the body update by groups of lanes per body (BIODEM_GPU_WALK_KICK=1), the one-thread walks and the clumps' walk with the body update sharing their touching contacts across a warp (BIODEM_GPU_WALK_PACK=1) forced byte-identical to (3)"
if [ $sr -ne 0 ] || [ $se -ne 0 ] || [ $sl -ne 0 ] || [ $sp -ne 0 ] || [ $sq -ne 0 ] || [ $sx -ne 0 ] || [ $sk -ne 0 ] || [ $sw -ne 0 ] || [ $sg -ne 0 ] || [ $sa -ne 0 ]; then
  lanes_ok=0; lanes_detail="a run failed (logs/needles_rows.txt, needles_entries.txt, needles_sum_lanes.txt, needles_full_pass.txt, needles_records_rows.txt, needles_records_entries.txt, needles_walk_kick.txt, needles_packed.txt, needles_packed_groups.txt)"
elif ! d1=$(same_files "$OUT/needles_a" "$OUT/needles_rows") || ! d2=$(same_files "$OUT/needles_a" "$OUT/needles_entries") ||
     ! d3=$(same_files "$OUT/needles_a" "$OUT/needles_sum_lanes") || ! d4=$(same_files "$OUT/needles_a" "$OUT/needles_full_pass") ||
     ! d5=$(same_files "$OUT/needles_a" "$OUT/needles_records_rows") || ! d6=$(same_files "$OUT/needles_a" "$OUT/needles_records_entries") ||
     ! d7=$(same_files "$OUT/needles_a" "$OUT/needles_walk_kick") || ! d8=$(same_files "$OUT/needles_a" "$OUT/needles_packed") ||
     ! d9=$(same_files "$OUT/needles_a" "$OUT/needles_packed_groups"); then
  lanes_ok=0; lanes_detail="the kernel sets differ: $(echo $d1 $d2 $d3 $d4 $d5 $d6 $d7 $d8 $d9)"
elif ! grep -q 'BIODEM_GPU_RECORDS=1' "$OUT/needles_records_rows/run.log" || ! grep -q 'BIODEM_GPU_OWN_SPHERE=1' "$OUT/needles_records_rows/run.log"; then
  lanes_ok=0; lanes_detail="the run with BIODEM_GPU_RECORDS=1 BIODEM_GPU_OWN_SPHERE=1 does not say so in run.log"
elif ! grep -q 'by 4 lanes per body' "$OUT/needles_records_entries/run.log"; then
  lanes_ok=0; lanes_detail="the run with BIODEM_GPU_BODY_LANES=auto does not report 4 lanes per body in run.log"
elif ! grep -q 'in groups of 4 lanes per body (ForcesKickDriftGroups' "$OUT/needles_walk_kick/run.log"; then
  lanes_ok=0; lanes_detail="the run with BIODEM_GPU_WALK_KICK=1 does not report the walk with the body update by 4 lanes per body in run.log"
elif ! grep -q 'share their touching contacts across its lanes (BIODEM_GPU_WALK_PACK=1' "$OUT/needles_packed/run.log" ||
     ! grep -q 'ForcesKickDriftGroups.*share their touching contacts across its lanes (BIODEM_GPU_WALK_PACK=1' "$OUT/needles_packed_groups/run.log"; then
  lanes_ok=0; lanes_detail="a run with BIODEM_GPU_WALK_PACK=1 does not report the shared touching contacts (and the groups) in run.log"
fi
if [ "$DEVICE" = gpu ] && [ $lanes_ok = 1 ]; then
  for lanes in 1 2 16 32; do
    for block in 32 512; do
      why=$(variant_same "$OUT/needles_rows" "needles_lanes${lanes}_block$block" BIODEM_GPU_FORCES=rows \
            BIODEM_GPU_ROW_LANES=$lanes BIODEM_GPU_BLOCK=$block) ||
        { lanes_ok=0; lanes_detail="$lanes_detail; $lanes lanes, blocks of $block: $why"; }
    done
  done
  [ $lanes_ok = 1 ] && lanes_detail="$lanes_detail; row walk with 1, 2, 16, 32 lanes x blocks of 32, 512 byte-identical to 4 lanes, 64"
  # (the clumps' body kernel by 2 and 32 lanes per body, and the walk with the body update by
  # groups of 4, in blocks of 32 and 512: the groups' warp syncs at other sizes and places in a
  # warp and a block)
  for group in BIODEM_GPU_BODY_LANES=2 BIODEM_GPU_BODY_LANES=32 BIODEM_GPU_WALK_KICK=1; do
    lab=$(echo "${group#BIODEM_GPU_}" | tr 'A-Z=' 'a-z_')  # (body_lanes_2, ..., walk_kick_1)
    for block in 32 512; do
      why=$(variant_same "$OUT/needles_rows" "needles_${lab}_block$block" BIODEM_GPU_FORCES=rows \
            "$group" BIODEM_GPU_BLOCK=$block) ||
        { lanes_ok=0; lanes_detail="$lanes_detail; $group, blocks of $block: $why"; }
    done
  done
  [ $lanes_ok = 1 ] && lanes_detail="$lanes_detail; the clumps' body kernel by 2 and 32 lanes and the walk with the body update by groups of 4, x blocks of 32, 512 byte-identical"
  # (the walks sharing their touching contacts: one warp's scratch per block, and eight: blocks
  # of 512 launch it in blocks of 256)
  for block in 32 512; do
    why=$(variant_same "$OUT/needles_rows" "needles_packed_block$block" BIODEM_GPU_FORCES=rows \
          BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_WALK_PACK=1 BIODEM_GPU_BLOCK=$block) ||
      { lanes_ok=0; lanes_detail="$lanes_detail; BIODEM_GPU_WALK_PACK=1, blocks of $block: $why"; }
    why=$(variant_same "$OUT/needles_rows" "needles_packed_groups_block$block" BIODEM_GPU_FORCES=rows \
          BIODEM_GPU_WALK_KICK=1 BIODEM_GPU_WALK_PACK=1 BIODEM_GPU_BLOCK=$block) ||
      { lanes_ok=0; lanes_detail="$lanes_detail; BIODEM_GPU_WALK_KICK=1 BIODEM_GPU_WALK_PACK=1, blocks of $block: $why"; }
    # (each walk shared by 2 and by 4 lanes of the warp: BIODEM_GPU_PACK_SPLIT)
    for split in 2 4; do
      why=$(variant_same "$OUT/needles_rows" "needles_packed_split${split}_block$block" BIODEM_GPU_FORCES=rows \
            BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_WALK_KICK=0 BIODEM_GPU_WALK_PACK=1 BIODEM_GPU_PACK_SPLIT=$split BIODEM_GPU_BLOCK=$block) ||
        { lanes_ok=0; lanes_detail="$lanes_detail; BIODEM_GPU_WALK_PACK=1 BIODEM_GPU_PACK_SPLIT=$split, blocks of $block: $why"; }
      # (and the split ran: run.log names it)
      grep -q "share their touching contacts across its lanes, $split lanes per sphere" \
          "$OUT/needles_packed_split${split}_block$block/run.log" 2>/dev/null ||
        { lanes_ok=0; lanes_detail="$lanes_detail; BIODEM_GPU_PACK_SPLIT=$split, blocks of $block: run.log does not name $split lanes per sphere"; }
    done
  done
  [ $lanes_ok = 1 ] && lanes_detail="$lanes_detail; the walks sharing their touching contacts (one thread per row, by 2 and 4 lanes per row (BIODEM_GPU_PACK_SPLIT), and the clumps' groups with the body update) x blocks of 32, 512 byte-identical"
fi
[ $lanes_ok = 1 ] && record "3i. kernel sets and row-walk lanes" PASS "$lanes_detail" || record "3i. kernel sets and row-walk lanes" FAIL "$lanes_detail"
# 3j. The list build by one thread per sphere (BIODEM_GPU_BUILD_LANES=1, BuildRows) gives the
# bytes of (3), the grouped build's default; on a GPU also the grouped build with 2 lanes per
# sphere in blocks of 512 (the shared memory then limits the groups per block), 8 and 32.
BIODEM_GPU_BUILD_LANES=1 run_biodem needles_build1 "$needles" "$OUT/needles_build1" --device "$DEVICE"; sb=$?
build_ok=1; build_detail="one thread per row (BuildRows) byte-identical to the grouped build (3)"
if [ $sb -ne 0 ] || [ $sa -ne 0 ]; then
  build_ok=0; build_detail="a run failed (logs/needles_build1.txt)"
elif ! d=$(same_files "$OUT/needles_a" "$OUT/needles_build1"); then
  build_ok=0; build_detail="the list builds differ: $(echo $d)"
fi
if [ "$DEVICE" = gpu ] && [ $build_ok = 1 ]; then
  for lb in 2:512 8:128 32:128; do
    lanes=${lb%:*}; block=${lb#*:}
    why=$(variant_same "$OUT/needles_a" "needles_build${lanes}_block$block" BIODEM_GPU_BUILD_LANES=$lanes \
          BIODEM_GPU_BLOCK=$block) ||
      { build_ok=0; build_detail="$build_detail; $lanes lanes, blocks of $block: $why"; }
  done
  [ $build_ok = 1 ] && build_detail="$build_detail; grouped with 2 lanes (blocks of 512), 8 and 32 byte-identical to 16"
fi
[ $build_ok = 1 ] && record "3j. list build: grouped and one thread per row" PASS "$build_detail" ||
  record "3j. list build: grouped and one thread per row" FAIL "$build_detail"
settle=tests/cases/biomass_9_6_quick.toml
run_biodem settle_graph "$settle" "$OUT/settle_graph" --device "$DEVICE"; sc=$?
BIODEM_GPU_GRAPH=0 run_biodem settle_plain "$settle" "$OUT/settle_plain" --device "$DEVICE"; sd=$?
settle_end=$(grep -o "phase 'settle' ends at t = [^;]*" "$OUT/settle_graph/run.log" 2>/dev/null | head -n 1)
expect_same "3d. settle criterion on the device, with and without CUDA graphs" \
  "$([ $sc -eq 0 ] && [ $sd -eq 0 ] && echo 1)" "a run failed (logs/settle_graph.txt, settle_plain.txt)" \
  "$OUT/settle_graph" "$OUT/settle_plain" "byte-identical; $settle_end"

# 3e. ReduceKick and the next step's KickDriftSpheres as two kernels instead of the fused
# ReduceKickDrift (BIODEM_GPU_FUSE=0): the same operations in the same order, so the same bytes.
BIODEM_GPU_FUSE=0 run_biodem needles_unfused "$needles" "$OUT/needles_unfused" --device "$DEVICE"; su=$?
expect_same "3e. same run without the fused body kernel" "$([ $su -eq 0 ] && [ $sa -eq 0 ] && echo 1)" \
  "a run failed (logs/needles_unfused.txt)" "$OUT/needles_a" "$OUT/needles_unfused" \
  "byte-identical to the run with ReduceKickDrift"

# 3f. The bodies kept in the host's order on the device instead of sorted by cell at list builds
# (BIODEM_GPU_SORT=0), on the needle drum and on the drum whose settle phase ends on the
# criterion (its kinetic energy sums run in the host's body order either way): the same bytes.
BIODEM_GPU_SORT=0 run_biodem needles_unsorted "$needles" "$OUT/needles_unsorted" --device "$DEVICE"; sn=$?
BIODEM_GPU_SORT=0 run_biodem settle_unsorted "$settle" "$OUT/settle_unsorted" --device "$DEVICE"; ss=$?
if [ $sn -ne 0 ] || [ $ss -ne 0 ] || [ $sa -ne 0 ] || [ $sc -ne 0 ]; then
  record "3f. needle and settle drums with the bodies unsorted" FAIL "a run failed (logs/needles_unsorted.txt, settle_unsorted.txt)"
elif ! diff=$(same_files "$OUT/needles_a" "$OUT/needles_unsorted"); then
  record "3f. needle and settle drums with the bodies unsorted" FAIL "needle drum differs: $(echo $diff)"
elif ! diff=$(same_files "$OUT/settle_graph" "$OUT/settle_unsorted"); then
  record "3f. needle and settle drums with the bodies unsorted" FAIL "settle drum differs: $(echo $diff)"
else
  record "3f. needle and settle drums with the bodies unsorted" PASS "both byte-identical to the runs with the bodies sorted by cell"
fi

BIODEM_TEST_ABORT_AT_STEP=9001 run_biodem needles_kill "$needles" "$OUT/needles_kill" --device "$DEVICE"; sk=$?
"${TMO[@]}" "$bin" run "$needles" --out "$OUT/needles_kill" --threads "$THREADS" --device "$DEVICE" --resume > "$logs/needles_resume.txt" 2>&1; sr=$?
expect_same "4. kill at step 9,001 and resume" "$([ $sk -eq 137 ] && [ $sr -eq 0 ] && echo 1)" \
  "kill status $sk (137 expected), resume status $sr" "$OUT/needles_a" "$OUT/needles_kill" \
  "outputs byte-identical to the uninterrupted run"

compare_engines() {  # label cpu-dir gpu-dir alpha-tol-deg rel-tol -> prints detail; status
  python3 - "$2" "$3" "$4" "$5" <<'PY'
import csv, math, sys
cpu, gpu, alpha_tol, rel_tol = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
def cols(path):
    rows = list(csv.DictReader(open(path)))
    return {k: [float(r[k]) if r[k] not in ("", "nan") else math.nan for r in rows] for k in rows[0]}
c, g = cols(cpu + "/series.csv"), cols(gpu + "/series.csv")
bad = []
if len(c["time_s"]) != len(g["time_s"]):
    print(f"sample counts differ: {len(c['time_s'])} vs {len(g['time_s'])}"); sys.exit(1)
da = max(abs(a - b) for a, b in zip(c["alpha_deg"], g["alpha_deg"]) if not (math.isnan(a) or math.isnan(b)))
ke_c, ke_g = sum(c["kinetic_energy_j"]), sum(g["kinetic_energy_j"])
n_c, n_g = c["contacts"][-1], g["contacts"][-1]
dke = abs(ke_g - ke_c) / max(ke_c, 1e-300)
dn = abs(n_g - n_c) / max(n_c, 1.0)
msg = f"worst alpha difference {da:.3g} deg (tol {alpha_tol}), mean KE rel. diff {dke:.3g} (tol {rel_tol}), final contacts {n_c:.0f} vs {n_g:.0f} (tol {rel_tol})"
try:  # final body positions from trace.csv, where the case writes one
    def last(path):
        rows = list(csv.DictReader(open(path)))
        t = rows[-1]["time_s"]
        return {r["body_id"]: (float(r["x_m"]), float(r["y_m"]), float(r["z_m"])) for r in rows if r["time_s"] == t}
    pc, pg = last(cpu + "/trace.csv"), last(gpu + "/trace.csv")
    dx = max(math.dist(pc[k], pg[k]) for k in pc)
    msg += f", worst final body position diff {dx:.3g} m over {len(pc)} bodies"
except FileNotFoundError:
    pass
print(msg)
sys.exit(0 if da <= alpha_tol and dke <= rel_tol and dn <= rel_tol else 1)
PY
}

run_biodem needles_cpu "$needles" "$OUT/needles_cpu" --device cpu; sc=$?
if [ $sc -ne 0 ] || [ $sa -ne 0 ]; then
  record "5. needle drum vs CPU engine" FAIL "a run failed (logs/needles_cpu.txt)"
elif detail=$(compare_engines needles "$OUT/needles_cpu" "$OUT/needles_a" 0.5 0.05); then
  record "5. needle drum vs CPU engine" PASS "$detail"
else
  record "5. needle drum vs CPU engine" FAIL "$detail"
fi

# 3k. The order-free family (BIODEM_GPU_SUMS=fixed: each contact added to its spheres' sums as
# fixed-point integers, by atomic additions in whatever order the threads come): two runs
# byte-identical (on a GPU the additions race; emulated, the second on 2 CPU threads with every
# kernel parallel), a kill at step 9,001 resumed to the same bytes, and the run within the
# tolerances of (5) of the CPU engine.
BIODEM_GPU_SUMS=fixed run_biodem needles_fixed "$needles" "$OUT/needles_fixed" --device "$DEVICE"; sf1=$?
if [ "$DEVICE" = gpu ]; then
  BIODEM_GPU_SUMS=fixed run_biodem needles_fixed2 "$needles" "$OUT/needles_fixed2" --device "$DEVICE"; sf2=$?
else
  rm -rf "$OUT/needles_fixed2"
  BIODEM_GPU_SUMS=fixed BIODEM_TEST_PARALLEL_THRESHOLD=0 "${TMO[@]}" "$bin" run "$needles" --out "$OUT/needles_fixed2" \
    --threads 2 --device "$DEVICE" > "$logs/needles_fixed2.txt" 2>&1; sf2=$?
fi
BIODEM_GPU_SUMS=fixed BIODEM_GPU_FORCES=rows run_biodem needles_fixed_rows "$needles" "$OUT/needles_fixed_rows" --device "$DEVICE"; sf3=$?
BIODEM_GPU_SUMS=fixed BIODEM_TEST_ABORT_AT_STEP=9001 run_biodem needles_fixed_kill "$needles" "$OUT/needles_fixed_kill" --device "$DEVICE"; sfk=$?
# (resumed without the variable: the checkpoint's family goes on, checkpoint format 6)
env -u BIODEM_GPU_SUMS "${TMO[@]}" "$bin" run "$needles" --out "$OUT/needles_fixed_kill" --threads "$THREADS" --device "$DEVICE" \
  --resume > "$logs/needles_fixed_resume.txt" 2>&1; sfr=$?
fixed_ok=1; fixed_detail=""
if [ $sf1 -ne 0 ] || [ $sf2 -ne 0 ] || [ $sf3 -ne 0 ]; then
  fixed_ok=0; fixed_detail="a run failed (logs/needles_fixed.txt, needles_fixed2.txt, needles_fixed_rows.txt)"
elif ! grep -q 'fixed-point sums in any order' "$OUT/needles_fixed/run.log"; then
  fixed_ok=0; fixed_detail="run.log does not name the fixed-point sums"
elif ! d=$(same_files "$OUT/needles_fixed" "$OUT/needles_fixed2"); then
  fixed_ok=0; fixed_detail="two runs differ: $(echo $d)"
elif ! d=$(same_files "$OUT/needles_fixed" "$OUT/needles_fixed_rows"); then
  fixed_ok=0; fixed_detail="the family's row walk (BIODEM_GPU_FORCES=rows, ForcesFixed) differs: $(echo $d)"
elif [ $sfk -ne 137 ] || [ $sfr -ne 0 ]; then
  fixed_ok=0; fixed_detail="kill status $sfk (137 expected), resume status $sfr"
elif ! d=$(same_files "$OUT/needles_fixed" "$OUT/needles_fixed_kill"); then
  fixed_ok=0; fixed_detail="killed and resumed differs: $(echo $d)"
elif [ $sc -ne 0 ]; then
  fixed_ok=0; fixed_detail="the CPU engine's run failed (logs/needles_cpu.txt)"
elif ! d=$(compare_engines needles "$OUT/needles_cpu" "$OUT/needles_fixed" 0.5 0.05); then
  fixed_ok=0; fixed_detail="against the CPU engine: $d"
else
  fixed_detail="two runs byte-identical$([ "$DEVICE" = gpu ] || echo ' (the second on 2 threads, every kernel parallel)'), the family's row walk (BIODEM_GPU_FORCES=rows) byte-identical, killed at step 9,001 and resumed byte-identical; against the CPU engine: $d; $(grep -o 'quanta [^)]*' "$OUT/needles_fixed/run.log" | head -n 1)"
  if [ "$DEVICE" = gpu ]; then  # the same kernels on CPU threads: the same bytes? (reported, not a condition)
    BIODEM_GPU_SUMS=fixed run_biodem needles_fixed_emulated "$needles" "$OUT/needles_fixed_emulated" --device gpu-emulated
    if [ $? -ne 0 ]; then fixed_detail="$fixed_detail; the run on CPU threads failed (logs/needles_fixed_emulated.txt)"
    elif d=$(same_files "$OUT/needles_fixed" "$OUT/needles_fixed_emulated"); then fixed_detail="$fixed_detail; byte-identical to the same run on CPU threads (gpu-emulated)"
    else fixed_detail="$fixed_detail; differs from the same run on CPU threads (gpu-emulated) in: $(echo $d)"
    fi
  fi
fi
[ $fixed_ok = 1 ] && record "3k. order-free family (BIODEM_GPU_SUMS=fixed)" PASS "$fixed_detail" ||
  record "3k. order-free family (BIODEM_GPU_SUMS=fixed)" FAIL "$fixed_detail"

# ------------------------------------------------------------------------- 6. wider rows
wide=tests/cases/gpu_wide_rows_tiny.toml
run_biodem wide_a "$wide" "$OUT/wide_a" --device "$DEVICE"; wa=$?
run_biodem wide_b "$wide" "$OUT/wide_b" --device "$DEVICE"; wb=$?
run_biodem wide_cpu "$wide" "$OUT/wide_cpu" --device cpu; wc=$?
BIODEM_GPU_BUILD_LANES=1 run_biodem wide_build1 "$wide" "$OUT/wide_build1" --device "$DEVICE"; wd=$?
# (single-sphere bodies: the entry kernels' sums inside the body kernel, by the row lanes)
BIODEM_GPU_FORCES=entries BIODEM_GPU_SUM_LANES=1 run_biodem wide_sum_lanes "$wide" "$OUT/wide_sum_lanes" --device "$DEVICE"; we=$?
# (and the row walk with the body update in one kernel, the sphere motion in two buffers)
BIODEM_GPU_FORCES=rows BIODEM_GPU_WALK_KICK=1 run_biodem wide_walk_kick "$wide" "$OUT/wide_walk_kick" --device "$DEVICE"; wk=$?
# (the same with the spheres' records, in both buffers, and the walk holding its own sphere)
BIODEM_GPU_FORCES=rows BIODEM_GPU_WALK_KICK=1 BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_RECORDS=1 BIODEM_GPU_OWN_SPHERE=1 run_biodem wide_walk_kick_records "$wide" "$OUT/wide_walk_kick_records" --device "$DEVICE"; wr=$?
# (the walk in one thread with the body update sharing the warp's touching contacts, reading
# the records: the packed ForcesKickDrift and the records' centre loads of its tests)
BIODEM_GPU_FORCES=rows BIODEM_GPU_WALK_KICK=1 BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_RECORDS=1 BIODEM_GPU_WALK_PACK=1 run_biodem wide_walk_kick_packed "$wide" "$OUT/wide_walk_kick_packed" --device "$DEVICE"; wp=$?
# (the same by 2 lanes per sphere: BIODEM_GPU_PACK_SPLIT; on CPU threads one lane, as above)
BIODEM_GPU_FORCES=rows BIODEM_GPU_WALK_KICK=1 BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_WALK_PACK=1 BIODEM_GPU_PACK_SPLIT=2 run_biodem wide_walk_kick_split "$wide" "$OUT/wide_walk_kick_split" --device "$DEVICE"; ws=$?
# (the entry kernels over every row entry and wall slot, against the pair and wall-slot lists,
# across the widenings)
BIODEM_GPU_FORCES=entries BIODEM_GPU_PAIR_LIST=full run_biodem wide_full_pass "$wide" "$OUT/wide_full_pass" --device "$DEVICE"; wf=$?
if [ $wa -ne 0 ] || [ $wb -ne 0 ] || [ $wc -ne 0 ]; then
  record "6. wider-row rebuild" FAIL "a run failed (logs/wide_*.txt)"
else
  widen=$(sed -n 's/.*row widenings \([0-9]*\) (row capacity \([0-9]*\)).*/\1 \2/p' "$OUT/wide_a/run.log")
  n_widen=${widen% *}
  detail="row widenings ${n_widen:-?}, capacity ${widen#* }"
  ok=1
  [ -n "$n_widen" ] && [ "$n_widen" -ge 1 ] || { ok=0; detail="$detail (no widening seen)"; }
  if diff=$(same_files "$OUT/wide_a" "$OUT/wide_b"); then detail="$detail; two runs byte-identical"; else ok=0; detail="$detail; runs differ: $(echo $diff)"; fi
  if [ $wd -ne 0 ]; then ok=0; detail="$detail; the run with BIODEM_GPU_BUILD_LANES=1 failed"
  elif diff=$(same_files "$OUT/wide_a" "$OUT/wide_build1"); then detail="$detail; BuildRows (BIODEM_GPU_BUILD_LANES=1) byte-identical"
  else ok=0; detail="$detail; BuildRows differs: $(echo $diff)"; fi
  if [ $we -ne 0 ]; then ok=0; detail="$detail; the run with BIODEM_GPU_SUM_LANES=1 failed"
  elif diff=$(same_files "$OUT/wide_a" "$OUT/wide_sum_lanes"); then detail="$detail; entry sums by the row lanes (BIODEM_GPU_SUM_LANES=1) byte-identical"
  else ok=0; detail="$detail; entry sums by the row lanes differ: $(echo $diff)"; fi
  if [ $wk -ne 0 ]; then ok=0; detail="$detail; the run with BIODEM_GPU_WALK_KICK=1 failed"
  elif ! grep -q 'ForcesKickDrift' "$OUT/wide_walk_kick/run.log"; then ok=0; detail="$detail; BIODEM_GPU_WALK_KICK=1 did not run ForcesKickDrift"
  elif diff=$(same_files "$OUT/wide_a" "$OUT/wide_walk_kick"); then detail="$detail; row walk with the body update (BIODEM_GPU_WALK_KICK=1) byte-identical"
  else ok=0; detail="$detail; row walk with the body update differs: $(echo $diff)"; fi
  if [ $wr -ne 0 ]; then ok=0; detail="$detail; the run with BIODEM_GPU_RECORDS=1 failed"
  elif diff=$(same_files "$OUT/wide_a" "$OUT/wide_walk_kick_records"); then detail="$detail; the same reading the spheres' records, own sphere held (BIODEM_GPU_RECORDS=1, BIODEM_GPU_OWN_SPHERE=1) byte-identical"
  else ok=0; detail="$detail; the walk with the body update reading the records differs: $(echo $diff)"; fi
  if [ $wp -ne 0 ]; then ok=0; detail="$detail; the run with BIODEM_GPU_WALK_PACK=1 failed"
  elif ! grep -q 'ForcesKickDrift.*BIODEM_GPU_WALK_PACK=1;' "$OUT/wide_walk_kick_packed/run.log"; then ok=0; detail="$detail; BIODEM_GPU_WALK_PACK=1 with the body update not reported in run.log"
  elif diff=$(same_files "$OUT/wide_a" "$OUT/wide_walk_kick_packed"); then detail="$detail; the walk with the body update sharing the warp's touching contacts, records (BIODEM_GPU_WALK_PACK=1, BIODEM_GPU_RECORDS=1) byte-identical"
  else ok=0; detail="$detail; the packed walk with the body update differs: $(echo $diff)"; fi
  if [ $ws -ne 0 ]; then ok=0; detail="$detail; the run with BIODEM_GPU_PACK_SPLIT=2 failed"
  elif ! grep -q 'ForcesKickDrift.*share their touching contacts across its lanes, 2 lanes per sphere' "$OUT/wide_walk_kick_split/run.log"; then
    ok=0; detail="$detail; BIODEM_GPU_PACK_SPLIT=2 with the body update not reported in run.log"
  elif diff=$(same_files "$OUT/wide_a" "$OUT/wide_walk_kick_split"); then detail="$detail; the same by 2 lanes per sphere (BIODEM_GPU_PACK_SPLIT=2) byte-identical"
  else ok=0; detail="$detail; the packed walk with the body update by 2 lanes per sphere differs: $(echo $diff)"; fi
  if [ $wf -ne 0 ]; then ok=0; detail="$detail; the run with BIODEM_GPU_PAIR_LIST=full failed"
  elif diff=$(same_files "$OUT/wide_a" "$OUT/wide_full_pass"); then detail="$detail; entry kernels over every entry (BIODEM_GPU_PAIR_LIST=full) byte-identical"
  else ok=0; detail="$detail; entry kernels over every entry differ: $(echo $diff)"; fi
  if cmp_detail=$(compare_engines wide "$OUT/wide_cpu" "$OUT/wide_a" 0.5 0.05); then detail="$detail; vs CPU: $cmp_detail"; else ok=0; detail="$detail; vs CPU: $cmp_detail"; fi
  [ $ok = 1 ] && record "6. wider-row rebuild" PASS "$detail" || record "6. wider-row rebuild" FAIL "$detail"
fi

# ------------------------------------------------------- 6b. a bulk test: moving walls and sinks
# The tiny shear box (700 beads; its gate is a translating wall, the beads that flow out fall
# into a sink): two runs on the device byte-identical, and the retainment within 0.05 of the
# CPU engine's (measured on CPU threads: 0.6629 against 0.6686), beads removed by the sink.
shear=tests/cases/shear_box_tiny.toml
run_biodem shear_a "$shear" "$OUT/shear_a" --device "$DEVICE"; sa=$?
run_biodem shear_b "$shear" "$OUT/shear_b" --device "$DEVICE"; sb=$?
run_biodem shear_cpu "$shear" "$OUT/shear_cpu" --device cpu; sc=$?
if [ $sa -ne 0 ] || [ $sb -ne 0 ] || [ $sc -ne 0 ]; then
  record "6b. bulk test (shear box)" FAIL "a run failed (logs/shear_*.txt)"
else
  ret() { sed -n 's/^retainment_ratio,\([^,]*\),.*/\1/p' "$1/responses.csv"; }
  sunk() { sed -n 's/^sinks removed \([0-9]*\) bodies.*/\1/p' "$1/run.log"; }
  r_gpu=$(ret "$OUT/shear_a"); r_cpu=$(ret "$OUT/shear_cpu"); n_gpu=$(sunk "$OUT/shear_a"); n_cpu=$(sunk "$OUT/shear_cpu")
  detail="retainment $r_gpu (CPU engine $r_cpu), sink removed ${n_gpu:-?} beads (CPU engine ${n_cpu:-?})"
  ok=1
  if diff=$(same_files "$OUT/shear_a" "$OUT/shear_b") && cmp -s "$OUT/shear_a/responses.csv" "$OUT/shear_b/responses.csv"; then
    detail="$detail; two runs byte-identical"
  else ok=0; detail="$detail; runs differ: $(echo $diff)"; fi
  python3 -c "import sys; sys.exit(0 if abs(float('$r_gpu') - float('$r_cpu')) <= 0.05 else 1)" 2> /dev/null ||
    { ok=0; detail="$detail; retainment more than 0.05 from the CPU engine's"; }
  [ "${n_gpu:-0}" -gt 0 ] || { ok=0; detail="$detail; the sink removed nothing"; }
  [ $ok = 1 ] && record "6b. bulk test (shear box)" PASS "$detail" || record "6b. bulk test (shear box)" FAIL "$detail"
fi

# 3g. The graphs were captured and ran, and no run gave up a queued path. A capture that fails
# (an operation in the steps that a CUDA graph cannot hold) falls back to plain launches with one
# line on stderr, and a queued list check that fails falls back to waiting ones ("for the rest of
# the run"): the same bytes but slower, so no byte comparison sees either. Every run above is
# read for those lines (not the runs with faults injected or graphs off), and run.log's count of
# the runs of steps launched as graphs must be above 0 in the needle and settle drums' runs (the
# settle criterion's graphs). Emulated there are no graphs: the count must be 0 there.
graph_ok=1; graph_detail=""
for f in "$logs"/*.txt; do
  case "$(basename "$f")" in ctest_*|build*|*fault*|*plain*|sanitizer_*|bench*) continue ;; esac
  if line=$(grep -h -m1 'CUDA graph capture failed\|for the rest of the run' "$f"); then
    graph_ok=0; graph_detail="$graph_detail $(basename "$f"): $(echo "$line" | cut -c1-140);"
  fi
done
for run in needles_a settle_graph; do
  n=$(grep -o 'GPU runs of steps: [0-9]* launched as CUDA graphs' "$OUT/$run/run.log" 2>/dev/null | grep -o '[0-9][0-9]*' | head -n 1)
  if [ -z "$n" ]; then
    graph_ok=0; graph_detail="$graph_detail $run: no 'GPU runs of steps' line in run.log;"
  elif [ "$DEVICE" = gpu ] && [ "$n" -eq 0 ]; then
    graph_ok=0; graph_detail="$graph_detail $run: no run of steps launched as a graph;"
  elif [ "$DEVICE" != gpu ] && [ "$n" -ne 0 ]; then
    graph_ok=0; graph_detail="$graph_detail $run: $n graph runs on CPU threads;"
  else
    graph_detail="$graph_detail $run: $n graph runs;"
  fi
done
[ $graph_ok = 1 ] && record "3g. CUDA graphs ran, no fallback" PASS "no capture failure or fallback line;$graph_detail" ||
  record "3g. CUDA graphs ran, no fallback" FAIL "$graph_detail"

# -------------------------------------------------------------------- 2. compute-sanitizer (run after 6: the slowest check)
if [ "$DEVICE" = gpu ]; then
  san=$(command -v compute-sanitizer || echo "${CUDA_HOME:-/usr/local/cuda}/bin/compute-sanitizer")
  # The 40k drum runs the row-walk contact kernel by default (BIODEM_GPU_FORCES=auto picks it
  # from 15,000 spheres): memcheck and initcheck run again with the entry kernels.
  # (memcheck and racecheck with the entry kernels' sums by the row lanes, sumlanes, clean in
  # leases 7-9 on code unchanged since, are left to GPU_CHECK_SANITIZER_JOBS since 2026-11-27, for
  # the three runs of the walks sharing their touching contacts. The racecheck and synccheck of
  # the walk split over 4 lanes per row, the synccheck of the records and the clumps' body
  # kernel by lanes, and the racecheck of the clumps' packed walk with the body update have never
  # run on a GPU: right after the first memcheck since 2026-11-28, so that a lease cut short
  # keeps them. The last two: the grouped list build at 2 lanes per sphere in blocks of 512 on
  # the wide-row scene, groups of lanes in warps filled otherwise than by default.)
  for job in ${GPU_CHECK_SANITIZER_JOBS-memcheck:auto racecheck:packedsplit4 synccheck:packedsplit4 synccheck:records racecheck:packedgroups initcheck:auto racecheck:auto synccheck:auto memcheck:entries memcheck:walkkick memcheck:fixed memcheck:records memcheck:kickgroups synccheck:kickgroups racecheck:packed memcheck:packedgroups synccheck:packedgroups racecheck:build2 synccheck:build2}; do
    tool=${job%:*} forces=${job#*:}
    scene=tests/cases/gpu_check_drum40k.toml scene_name="40,200 spheres"
    case "$forces" in
      entries) what=", entry kernels"; envs=(BIODEM_GPU_FORCES=entries) ;;
      rows1) what=", row walk in one thread per sphere"; envs=(BIODEM_GPU_FORCES=rows BIODEM_GPU_ROW_LANES=1) ;;
      sumlanes) what=", entry kernels with the sums by the row lanes"; envs=(BIODEM_GPU_FORCES=entries BIODEM_GPU_SUM_LANES=1) ;;
      spheres) what=", entry kernels with the sums by the row lanes in the body kernel"
               envs=(BIODEM_GPU_FORCES=entries BIODEM_GPU_SUM_LANES=1)
               scene=tests/cases/gpu_wide_rows_tiny.toml scene_name="the wide-row scene, single spheres" ;;
      walkkick) what=", row walk with the row lanes and the body update (two buffers)"
                envs=(BIODEM_GPU_FORCES=rows BIODEM_GPU_WALK_KICK=1)
                scene=tests/cases/gpu_wide_rows_tiny.toml scene_name="the wide-row scene, single spheres" ;;
      kickgroups) what=", the clumps' row walk with the body update by groups of lanes per body (two buffers), records"
                  envs=(BIODEM_GPU_FORCES=rows BIODEM_GPU_WALK_KICK=1 BIODEM_GPU_RECORDS=1) ;;
      fixed) what=", order-free family (fixed-point sums by atomic additions)"; envs=(BIODEM_GPU_SUMS=fixed) ;;
      packed) what=", one-thread walks sharing their touching contacts across a warp (shared memory)"
              envs=(BIODEM_GPU_FORCES=rows BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_WALK_PACK=1) ;;
      packedsplit) what=", one-thread walks sharing their touching contacts across a warp, 2 lanes per row"
                   envs=(BIODEM_GPU_FORCES=rows BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_WALK_PACK=1 BIODEM_GPU_PACK_SPLIT=2) ;;
      packedsplit4) what=", one-thread walks sharing their touching contacts across a warp, 4 lanes per row"
                    envs=(BIODEM_GPU_FORCES=rows BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_WALK_PACK=1 BIODEM_GPU_PACK_SPLIT=4) ;;
      packedgroups) what=", the clumps' walk with the body update by groups, sharing the warp's touching contacts"
                    envs=(BIODEM_GPU_FORCES=rows BIODEM_GPU_WALK_KICK=1 BIODEM_GPU_WALK_PACK=1) ;;
      build2) what=", the grouped list build at 2 lanes per sphere, blocks of 512"
              envs=(BIODEM_GPU_BUILD_LANES=2 BIODEM_GPU_BLOCK=512)
              scene=tests/cases/gpu_wide_rows_tiny.toml scene_name="the wide-row scene, single spheres" ;;
      records) what=", row walk in one thread reading the spheres' records, own sphere held, the clumps' body kernel by lanes"
               envs=(BIODEM_GPU_FORCES=rows BIODEM_GPU_ROW_LANES=1 BIODEM_GPU_RECORDS=1 BIODEM_GPU_OWN_SPHERE=1 BIODEM_GPU_BODY_LANES=auto) ;;
      *) what=""; envs=(BIODEM_GPU_FORCES=$forces) ;;
    esac
    name="2. compute-sanitizer $tool ($scene_name$what)"
    if [ ! -x "$san" ]; then record "$name" FAIL "compute-sanitizer not found"; continue; fi
    rm -rf "$OUT/san_${tool}_$forces"
    if env "${envs[@]}" "${TMO[@]}" "$san" --tool "$tool" --error-exitcode 99 "$bin" run "$scene" \
         --out "$OUT/san_${tool}_$forces" --device gpu > "$logs/sanitizer_${tool}_$forces.txt" 2>&1; then
      record "$name" PASS "$(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' "$logs/sanitizer_${tool}_$forces.txt" | tail -n 1)"
    else
      record "$name" FAIL "see logs/sanitizer_${tool}_$forces.txt"
    fi
  done
else
  record "2. compute-sanitizer" SKIP "needs a GPU"
fi

# ----------------------------------------------------------------------------- 7. bench
if [ "$BENCH" = 1 ]; then
  if DEVICE=$DEVICE BIODEM="$bin" OUT="$OUT/bench" CPU_THREADS="${CPU_THREADS-$(nproc)}" \
       bash bench/run_gpu_bench.sh > "$logs/bench.txt" 2>&1; then
    record "7. bench/run_gpu_bench.sh" PASS "table below"
  else
    record "7. bench/run_gpu_bench.sh" FAIL "see logs/bench.txt"
  fi
else
  record "7. bench/run_gpu_bench.sh" SKIP "GPU_CHECK_BENCH=0"
fi

# ---------------------------------------------------------------------------- the report
write_report > "$report.tmp" && mv "$report.tmp" "$report"
echo "report: $report ($failures failed)"
[ $failures -eq 0 ]
