#!/usr/bin/env bash
# Fuzzes the case parser and the checkpoint reader with libFuzzer (issue 10, item 8;
# tests/fuzz/). Builds the harnesses with clang into build-fuzz/ (ASan + UBSan + libFuzzer) and
# runs each for SECONDS (default 60), starting from the committed corpus.
#   scripts/fuzz.sh [SECONDS] [TARGET...]      TARGET: case_parser, checkpoint (default: both)
# Inputs that reach new code are kept in build-fuzz/corpus/TARGET/ (not committed; copy the
# interesting ones to tests/fuzz/corpus/TARGET/). A finding stops the run, leaves the input as
# build-fuzz/crash-* (or timeout-*, oom-*) and makes this script exit non-zero; replay it with
#   build-fuzz/tests/fuzz/fuzz_TARGET build-fuzz/crash-...
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(case_parser checkpoint)
cxx=${FUZZ_CXX:-clang++-14}
cmake -S . -B build-fuzz -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DBIODEM_FUZZ=ON \
  -DBIODEM_BUILD_TESTS=OFF -DBIODEM_BUILD_BENCH=OFF -DBIODEM_WITH_CUDA=OFF > build-fuzz-configure.log
for t in "${targets[@]}"; do cmake --build build-fuzz -j"$(nproc)" --target "fuzz_$t"; done
status=0
for t in "${targets[@]}"; do
  mkdir -p "build-fuzz/corpus/$t"
  dict=()
  [ -f "tests/fuzz/$t.dict" ] && dict=(-dict="tests/fuzz/$t.dict")
  echo "== fuzz_$t for ${secs} s"
  "build-fuzz/tests/fuzz/fuzz_$t" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -max_len=16384 \
    -artifact_prefix=build-fuzz/ "${dict[@]}" "build-fuzz/corpus/$t" "tests/fuzz/corpus/$t" || status=1
done
exit $status
