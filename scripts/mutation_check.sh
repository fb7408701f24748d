#!/usr/bin/env bash
# Mutation check: does the test suite fail on a wrong law? Each mutant of scripts/mutants.py (a
# sign, a factor of 2, a wrong radius, frame or pair of materials) is applied alone to a clone of
# the committed HEAD, the clone is rebuilt (CPU engine only) and the unit and physics tests are
# run (with MUTATION_TIERS="unit physics regression", the regression tier too). A mutant is
# KILLED when a test fails or crashes, SURVIVED when every test passes; a survivor is a missing
# test. Not part of CI (a header mutant costs about 2.5 minutes to rebuild on 2 cores); see
# README.md, "Reliability" ("Tests that fail on a wrong law").
#
#   bash scripts/mutation_check.sh                 every mutant
#   bash scripts/mutation_check.sh 01 24c 29       these ones
#
# MUTATION_WORK (default /tmp/biodem_mutants): the clone (src/), build, logs and results.tsv; an
# existing clone is reset to this checkout's HEAD and its build is reused.
# MUTATION_FULL=1: run every test of a tier instead of stopping at the first failure (to list
# all the tests a mutant fails). MUTATION_JOBS: build jobs (default: all cores).
# Exit status: 0 when no mutant survived, 1 otherwise; 2 when the unmutated build fails its tests.
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
work="${MUTATION_WORK:-/tmp/biodem_mutants}"
tiers="${MUTATION_TIERS:-unit physics}"
jobs="${MUTATION_JOBS:-$(nproc)}"
src="$work/src" build="$work/build" logs="$work/logs" results="$work/results.tsv"
mkdir -p "$logs"

if [ -d "$src/.git" ]; then
  git -C "$src" fetch -q "$here" HEAD && git -C "$src" reset -q --hard FETCH_HEAD && git -C "$src" clean -qfd
else
  git clone -q "$here" "$src"
fi
echo "mutation check of $(git -C "$src" rev-parse --short HEAD) in $work (tiers: $tiers)"
cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=Release -DBIODEM_WITH_CUDA=OFF -DBIODEM_BUILD_BENCH=OFF \
  > "$logs/configure.log" 2>&1 || { echo "configure failed: $logs/configure.log"; exit 2; }
targets="biodem"
for t in $tiers; do targets="$targets biodem_${t}_tests"; done
build() { cmake --build "$build" -j"$jobs" --target $targets > "$1" 2>&1; }

fail_fast="--gtest_fail_fast"
[ "${MUTATION_FULL:-0}" = 1 ] && fail_fast=""
run_tier() {  # tier log -> PASS | FAIL: names [n failed] | TIMEOUT | CRASH
  (cd "$build/tests" && timeout 1200 "./biodem_$1_tests" --gtest_brief=1 $fail_fast > "$2" 2>&1)
  local rc=$?
  local failed n
  failed=$(grep -E '^\[  FAILED  \] [A-Za-z0-9_/.]+' "$2" | grep -v 'listed below' |
           sed -E 's/^\[  FAILED  \] ([^ ,]+).*/\1/' | sort -u)
  n=$(printf '%s' "$failed" | grep -c . || true)
  if [ $rc -eq 0 ]; then echo "PASS"
  elif [ $rc -eq 124 ]; then echo "TIMEOUT"
  elif [ "$n" -gt 0 ]; then echo "FAIL: $(printf '%s\n' "$failed" | head -3 | tr '\n' ' ')[$n failed]"
  else echo "CRASH (rc $rc)"; fi
}

ids=("$@")
[ ${#ids[@]} -eq 0 ] && mapfile -t ids < <(python3 "$src/scripts/mutants.py" list | cut -f1)
ids=(baseline "${ids[@]}")
survivors=0
printf 'mutant\twhere\tverdict\ttests\tseconds\n' > "$results"
for id in "${ids[@]}"; do
  t0=$(date +%s)
  where="-"
  if [ "$id" != baseline ]; then
    where=$(python3 "$src/scripts/mutants.py" apply "$id" "$src") || { printf '%s\t-\tNOT APPLIED\n' "$id" >> "$results"; continue; }
  fi
  verdict="" tests=""
  if ! build "$logs/$id.build.log"; then
    verdict="BUILD FAILED"
  else
    for t in $tiers; do
      r=$(run_tier "$t" "$logs/$id.$t.log")
      tests="$tests$t: $r; "
      if [ "$r" != PASS ]; then verdict=KILLED; [ "${MUTATION_FULL:-0}" = 1 ] || break; fi
    done
    [ -z "$verdict" ] && verdict=SURVIVED
  fi
  git -C "$src" checkout -q -- .
  if [ "$id" = baseline ]; then
    if [ "$verdict" != SURVIVED ]; then echo "the unmutated build fails its tests ($tests); see $logs"; exit 2; fi
    verdict="all tests pass"
  elif [ "$verdict" = SURVIVED ]; then
    survivors=$((survivors + 1))
  fi
  printf '%s\t%s\t%s\t%s\t%s\n' "$id" "$where" "$verdict" "$tests" "$(($(date +%s) - t0))" | tee -a "$results"
done
echo "mutants: $((${#ids[@]} - 1)), survived: $survivors; table: $results"
[ $survivors -eq 0 ]
