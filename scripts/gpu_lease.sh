#!/usr/bin/env bash
# The GPU check inside a short lease of a bare GPU machine (docs/gpu.md section 6): the lean CUDA
# build is made beforehand on the Debian machine (it needs no GPU to compile), carried over with
# the source tree, and this script spends the lease on running, not compiling:
#
#   on the Debian machine:  bash scripts/gpu_lease.sh --prepare [--fmad]   # devcarry/
#   on the GPU machine:     bash scripts/gpu_lease.sh                      # GPU_LEASE_OUT
#
# --prepare makes the lean CUDA build (build-gpu/, sm_90, no OpenCV, pagmo or MPI) and copies
# what the runs need into devcarry/ (ignored by git): the binaries and ctest's files, the CUDA
# runtime, libgomp and libstdc++ (used only if the GPU machine's own are missing), the path the
# build was configured in; --fmad adds a biodem built with -fmad=true, and GPU_LEASE_VARIANTS
# ("NAME=FLAG ...") a biodem per entry built with one more CUDA flag, benched beside the default.
#
# On the GPU machine, in order, each under its own time limit, so that a lease cut short still
# leaves the most important figures: (0) the device and a smoke run; (1) "bench":
# bench/run_gpu_bench.sh on the GPU with the CPU engine on all cores beside it, then the same GPU
# runs with the order-free family (BIODEM_GPU_SUMS=fixed), with each contact kernel set forced
# (BIODEM_GPU_FORCES=entries, =rows) and, when prepared
# with --fmad, the -fmad=true build; (2) "check": scripts/gpu_check.sh on the carried build (GPU
# tests, determinism, kill-and-resume, CPU agreement, wider rows, compute-sanitizer last);
# (1b) "sass": bench/gpu_sass.sh (the step kernels' SASS and ncu's stall samples per instruction,
# for sessions without a GPU to read; in lease.tgz); (3) "sweep": bench/run_gpu_sweep.sh (ncu kernel durations, launch settings, skins);
# (4) "scaling": bench/run_scaling.sh, the CPU engine at 1-16 threads on the raw drum with a
# shortened settle; (5) "bulk": the raw-biomass heap of the calibration (11,100 spheres, a
# lifted cylinder and a sink) on the GPU, its phases' wall times and responses
# (GPU_LEASE_BULK_S, default 150). Results in GPU_LEASE_OUT (default out/gpu_lease): report.md, the CSV files,
# lease.log, and everything in lease.tgz.
#
# Environment: GPU_LEASE_STEPS (default "bench check"), GPU_LEASE_OUT, GPU_LEASE_RETURN (a folder
# that gets only the report, the CSV files, the log and lease.tgz, for a lease that brings back
# few files), GPU_LEASE_CHECK_S (seconds for gpu_check.sh, default 260), GPU_LEASE_BENCH_S and
# GPU_LEASE_BENCH2_S (the first and each further bench, default 200 and 60), GPU_LEASE_SASS_S (300;
# GPU_LEASE_SASS_NCU_S, 90, for each of its four ncu runs), GPU_LEASE_SWEEP_S
# (200), GPU_LEASE_SWEEP_SETTINGS (run_gpu_sweep.sh's SWEEP_SETTINGS), GPU_LEASE_SCALING_S (120),
# GPU_LEASE_CPU_THREADS (CPU engine threads beside the GPU bench; default all, empty: none),
# GPU_LEASE_SOURCE_DIR (where the build was configured; default: devcarry/source_dir),
# GPU_LEASE_TOTAL_S (the whole call's limit, e.g. the device call's timeout: each step's limit is
# then cut so that the steps end GPU_LEASE_RESERVE_S, default 30, before it, and the report, log
# and CSV files go to GPU_LEASE_RETURN after each step, so that a call killed at its limit still
# brings back what it measured).
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"

if [ "${1:-}" = --prepare ]; then  # on the Debian machine, with CUDA and scripts/deps.sh's packages
  set -e
  [ -d vendor ] || bash scripts/vendor_headers.sh vendor
  common=(-DCMAKE_BUILD_TYPE=Release -DBIODEM_WITH_OPENCV=OFF -DBIODEM_PREFER_VENDOR=ON "-DBIODEM_VENDOR_DIR=$root/vendor"
          -DBIODEM_WITH_CUDA=ON -DCMAKE_CUDA_ARCHITECTURES=90 -DBIODEM_BUILD_BENCH=OFF
          -DCMAKE_DISABLE_FIND_PACKAGE_Pagmo=ON -DCMAKE_DISABLE_FIND_PACKAGE_MPI=ON)
  cmake -S . -B build-gpu "${common[@]}" > /dev/null
  cmake --build build-gpu -j"$(nproc)"
  rm -rf devcarry && mkdir -p devcarry/lib
  if [ "${2:-}" = --fmad ]; then  # a second biodem with -fmad=true, for the comparison of docs/gpu.md
    cmake -S . -B build-gpu-fmad "${common[@]}" -DBIODEM_BUILD_TESTS=OFF -DBIODEM_CUDA_FMAD=ON > /dev/null
    cmake --build build-gpu-fmad -j"$(nproc)" --target biodem
    mkdir -p devcarry/fmad && cp build-gpu-fmad/biodem devcarry/fmad/biodem
  fi
  # GPU_LEASE_VARIANTS="NAME=FLAG ...": a biodem per entry with one more CUDA compile flag (a
  # compile-time kernel choice to time beside the default, e.g. chunk4=-DBIODEM_GPU_SUM_CHUNK=4)
  for v in ${GPU_LEASE_VARIANTS:-}; do
    name=${v%%=*} flag=${v#*=}
    cmake -S . -B "build-gpu-$name" "${common[@]}" -DBIODEM_BUILD_TESTS=OFF "-DCMAKE_CUDA_FLAGS=$flag" > /dev/null
    cmake --build "build-gpu-$name" -j"$(nproc)" --target biodem
    mkdir -p "devcarry/variants/$name" && cp "build-gpu-$name/biodem" "devcarry/variants/$name/biodem"
    echo "$flag" > "devcarry/variants/$name/flag"
  done
  # the build without objects and archives (ctest's files, the test and program binaries)
  cp -a build-gpu devcarry/
  rm -rf devcarry/build-gpu/vendor_googletest devcarry/build-gpu/CMakeFiles devcarry/build-gpu/tests/out_* devcarry/build-gpu/tests/CMakeFiles
  find devcarry/build-gpu \( -name '*.o' -o -name '*.a' \) -delete
  # (biodem-full only runs video and calibrate, which nothing on the GPU machine runs: 12 MB of
  # the 64 MB a call may carry)
  rm -f devcarry/build-gpu/biodem-full
  for lib in $(ldd build-gpu/biodem | awk '/cudart|gomp|stdc\+\+/ {print $3}'); do cp -L "$lib" devcarry/lib/; done
  echo "$root" > devcarry/source_dir
  du -sh devcarry
  echo "carry devcarry (ignored by git) with the call; run: bash scripts/gpu_lease.sh"
  exit 0
fi

O=${GPU_LEASE_OUT:-$root/out/gpu_lease}
mkdir -p "$O"
O=$(cd "$O" && pwd)
[ -d devcarry ] || { echo "no devcarry/: run bash scripts/gpu_lease.sh --prepare on the build machine first" >&2; exit 2; }
# The carried build holds absolute paths of the checkout it was configured in: make that path
# lead here.
src=${GPU_LEASE_SOURCE_DIR:-$(cat devcarry/source_dir)}
if [ "$src" != "$root" ]; then
  if [ ! -e "$src" ]; then mkdir -p "$(dirname "$src")" && ln -s "$root" "$src"; fi
  if [ "$(cd "$src" 2>/dev/null && pwd -P)" != "$(pwd -P)" ]; then
    echo "the carried build was configured in $src, which is another folder on this machine: run --prepare in a checkout whose path is free here, or move $src away" >&2
    exit 2
  fi
  cd "$src" || exit 2
fi
if [ -d devcarry/build-gpu ]; then rm -rf build-gpu && mv devcarry/build-gpu build-gpu; fi
if ! build-gpu/biodem --help > /dev/null 2>&1; then export LD_LIBRARY_PATH=$PWD/devcarry/lib; fi
t0=$(date +%s)
stamp() { echo "[$(( $(date +%s) - t0 )) s] $*" | tee -a "$O/lease.log"; }
# A step's limit: its own (the argument), cut to what GPU_LEASE_TOTAL_S leaves (at least 1 s).
lim() {
  local want=$1 left
  if [ -n "${GPU_LEASE_TOTAL_S:-}" ]; then
    left=$(( GPU_LEASE_TOTAL_S - ${GPU_LEASE_RESERVE_S:-30} - ($(date +%s) - t0) ))
    [ "$left" -lt 1 ] && left=1
    [ "$want" -gt "$left" ] && want=$left
  fi
  echo "$want"
}
# The results so far to GPU_LEASE_RETURN (the report, the log, the CSV files; lease.tgz at the end).
collect() {
  cp "$O/check/report.md" "$O/report.md" 2>/dev/null
  variant_benches=$(cd "$O" && ls -d bench_*/ 2>/dev/null | tr -d / | grep -v '^bench_\(entries\|rows\|fmad\|fixed\)$' | tr '\n' ' ')
  for b in bench bench_fixed bench_entries bench_rows bench_fmad $variant_benches; do cp "$O/$b/gpu_results.csv" "$O/${b}_results.csv" 2>/dev/null; done
  cp "$O/sweep/sweep.csv" "$O/sweep_results.csv" 2>/dev/null
  if [ -n "${GPU_LEASE_RETURN:-}" ]; then
    mkdir -p "$GPU_LEASE_RETURN"
    cp "$O"/report.md "$O"/lease.log "$O"/*_results.csv "$GPU_LEASE_RETURN"/ 2>/dev/null
  fi
  return 0
}

stamp "0. device"
{ nvidia-smi; nvcc --version; uname -a; nproc; ldd build-gpu/biodem; } > "$O/env.txt" 2>&1
timeout 60 build-gpu/biodem run tests/cases/gpu_needles_tiny.toml --out "$O/smoke" --device gpu > "$O/smoke.txt" 2>&1
smoke=$?
stamp "smoke run: status $smoke ($(tail -n 1 "$O/smoke.txt"))"
grep -h 'us/step on\|graph\|CUDA' "$O/smoke/run.log" "$O/smoke.txt" 2>/dev/null | head -n 5 | tee -a "$O/lease.log"

check_tmo=90
want() { case " ${GPU_LEASE_STEPS:-bench check} " in *" $1 "*) return 0 ;; *) return 1 ;; esac; }
if [ $smoke -ne 0 ]; then  # the engine does not run: no timings; the checks, with short limits, say where
  stamp "1. bench skipped (the smoke run failed)"
  check_tmo=30
elif want bench; then
stamp "1. bench: GPU and the CPU engine on $(nproc) threads"
DEVICE=gpu BIODEM=build-gpu/biodem OUT="$O/bench" CPU_THREADS="${GPU_LEASE_CPU_THREADS-$(nproc)}" timeout "$(lim "${GPU_LEASE_BENCH_S:-200}")" bash bench/run_gpu_bench.sh > "$O/bench.txt" 2>&1
stamp "bench: status $?"
BIODEM_GPU_SUMS=fixed DEVICE=gpu BIODEM=build-gpu/biodem OUT="$O/bench_fixed" CPU_THREADS="" timeout "$(lim "${GPU_LEASE_BENCH2_S:-60}")" bash bench/run_gpu_bench.sh > "$O/bench_fixed.txt" 2>&1
stamp "bench with the order-free family (BIODEM_GPU_SUMS=fixed): status $?"
BIODEM_GPU_FORCES=entries DEVICE=gpu BIODEM=build-gpu/biodem OUT="$O/bench_entries" CPU_THREADS="" timeout "$(lim "${GPU_LEASE_BENCH2_S:-60}")" bash bench/run_gpu_bench.sh > "$O/bench_entries.txt" 2>&1
stamp "bench with the entry force kernels (BIODEM_GPU_FORCES=entries): status $?"
if [ -x devcarry/fmad/biodem ]; then  # made by --prepare --fmad
  DEVICE=gpu BIODEM=devcarry/fmad/biodem OUT="$O/bench_fmad" CPU_THREADS="" timeout "$(lim "${GPU_LEASE_BENCH2_S:-60}")" bash bench/run_gpu_bench.sh > "$O/bench_fmad.txt" 2>&1
  stamp "bench -fmad=true: status $?"
fi
for vb in devcarry/variants/*/biodem; do  # made by --prepare with GPU_LEASE_VARIANTS
  [ -x "$vb" ] || continue
  name=$(basename "$(dirname "$vb")")
  DEVICE=gpu BIODEM=$vb OUT="$O/bench_$name" CPU_THREADS="" timeout "$(lim "${GPU_LEASE_BENCH2_S:-60}")" bash bench/run_gpu_bench.sh > "$O/bench_$name.txt" 2>&1
  stamp "bench variant $name ($(cat "$(dirname "$vb")/flag")): status $?"
  BIODEM_GPU_FORCES=entries DEVICE=gpu BIODEM=$vb OUT="$O/bench_${name}_entries" CPU_THREADS="" timeout "$(lim "${GPU_LEASE_BENCH2_S:-60}")" bash bench/run_gpu_bench.sh > "$O/bench_${name}_entries.txt" 2>&1
  stamp "bench variant $name, entry kernels forced: status $?"
done
BIODEM_GPU_FORCES=rows DEVICE=gpu BIODEM=build-gpu/biodem OUT="$O/bench_rows" CPU_THREADS="" timeout "$(lim "${GPU_LEASE_BENCH2_S:-60}")" bash bench/run_gpu_bench.sh > "$O/bench_rows.txt" 2>&1
stamp "bench with the row-walk force kernel (BIODEM_GPU_FORCES=rows): status $?"
collect
fi

if [ $smoke -eq 0 ] && want sass; then  # what the kernels are made of and where they wait, per instruction
  stamp "1b. bench/gpu_sass.sh: SASS of the step kernels, ncu stall samples per instruction"
  BIODEM=build-gpu/biodem OUT="$O/sass" SASS_NCU_S="${GPU_LEASE_SASS_NCU_S:-90}" timeout "$(lim "${GPU_LEASE_SASS_S:-300}")" bash bench/gpu_sass.sh > "$O/sass.txt" 2>&1
  stamp "sass: status $? ($(grep -h '^SASS:\|^ncu' "$O/sass.txt" | tr '\n' ';'))"
  collect
fi
if want check; then
  stamp "2. scripts/gpu_check.sh"
  GPU_CHECK_BUILD=0 GPU_CHECK_BUILD_DIR=build-gpu GPU_CHECK_BENCH=0 GPU_CHECK_TIMEOUT=$check_tmo GPU_CHECK_OUT="$O/check" \
    timeout "$(lim "${GPU_LEASE_CHECK_S:-260}")" bash scripts/gpu_check.sh > "$O/check.txt" 2>&1
  stamp "gpu_check: status $?"
  collect
fi
if [ $smoke -eq 0 ] && want sweep; then
  stamp "3. bench/run_gpu_sweep.sh: kernel durations, launch settings"
  sweep_env=()
  [ -n "${GPU_LEASE_SWEEP_SETTINGS+set}" ] && sweep_env=("SWEEP_SETTINGS=$GPU_LEASE_SWEEP_SETTINGS")
  env "${sweep_env[@]}" BIODEM=build-gpu/biodem OUT="$O/sweep" timeout "$(lim "${GPU_LEASE_SWEEP_S:-200}")" bash bench/run_gpu_sweep.sh > "$O/sweep.txt" 2>&1
  stamp "sweep: status $?"
  collect
fi
if want scaling; then  # issue 18: the CPU engine at 1-16 threads, raw drum with a 3,000-step settle
  stamp "4. bench/run_scaling.sh (CPU engine, raw drum, settle shortened to 3,000 steps)"
  sed 's/^steps = 30000/steps = 3000/' bench/cases/raw_bench.toml > "$O/raw_scaling.toml"
  BIODEM=build-gpu/biodem OUT="$O/scaling" timeout "$(lim "${GPU_LEASE_SCALING_S:-120}")" bash bench/run_scaling.sh "$O/raw_scaling.toml" > "$O/scaling.txt" 2>&1
  stamp "scaling: status $?"
  cp "$O"/scaling/scaling_*.csv "$O/scaling_results.csv" 2>/dev/null
fi

if want bulk; then  # the raw-biomass heap of the calibration (3,700 needles, 11,100 spheres) on the GPU
  stamp "5. bulk test on the GPU: the raw heap (cases/calibration/base_raw.toml + heap_raw.toml)"
  cat cases/calibration/base_raw.toml cases/calibration/heap_raw.toml > "$O/raw_heap.toml"
  s0=$(date +%s)
  timeout "$(lim "${GPU_LEASE_BULK_S:-150}")" build-gpu/biodem run "$O/raw_heap.toml" --out "$O/raw_heap" --device gpu > "$O/raw_heap.txt" 2>&1
  stamp "raw heap: status $? after $(( $(date +%s) - s0 )) s (the CPU engine: 25-49 min on one core, docs/calibration.md)"
  grep -h "phase '.*' ends\|sinks removed\|WARNING" "$O/raw_heap/run.log" 2>/dev/null | cut -c1-200 | tee -a "$O/lease.log"
  cp "$O/raw_heap/responses.csv" "$O/raw_heap_results.csv" 2>/dev/null
fi

collect
(cd "$O" && tar czf lease.tgz --exclude '*.vtu' --exclude '*.ncu-rep' --exclude 'lease.tgz' --exclude 'checkpoint*.bin' . 2>/dev/null)
if [ -n "${GPU_LEASE_RETURN:-}" ]; then
  mkdir -p "$GPU_LEASE_RETURN"
  cp "$O"/report.md "$O"/lease.log "$O"/lease.tgz "$O"/*_results.csv "$GPU_LEASE_RETURN"/ 2>/dev/null
fi
echo; cat "$O/lease.log"; echo
for b in bench bench_fixed bench_entries bench_rows bench_fmad $variant_benches; do [ -f "$O/${b}_results.csv" ] && { echo "== $b"; cat "$O/${b}_results.csv"; }; done
# (which kernels the default runs picked, and the list builds: run.log of each bench drum)
for f in "$O"/bench/gpu_*/run.log "$O"/bench_fixed/gpu_*/run.log; do
  [ -f "$f" ] && { echo "== $(basename "$(dirname "$(dirname "$f")")")/$(basename "$(dirname "$f")")"; grep -h 'GPU contact kernels\|GPU list build\|list builds (one per' "$f" | cut -c1-300
    # (the timed choice's sets, one per line: name, median, chosen or dropped)
    grep -h 'GPU contact kernels' "$f" | sed -n 's/.*each set: \[\(.*\)\] (.*/\1/p' | sed 's/; /\n/g' | sed 's/^/   /' | cut -c1-170; }
done
[ -f "$O/sweep.txt" ] && { echo "== sweep"; grep -v '^ncu' "$O/sweep.txt" | grep -v '^==PROF==' | cut -c1-120; }
[ -f "$O/sweep/profile.txt" ] && { echo "== profile (BIODEM_GPU_PROFILE=1)"; cat "$O/sweep/profile.txt"; }
[ -f "$O/scaling.txt" ] && { echo "== scaling"; cat "$O/scaling_results.csv" 2>/dev/null; tail -n 12 "$O/scaling.txt"; }
echo; sed -n '/^| check/,/^$/p' "$O/report.md" 2>/dev/null | cut -c1-220
