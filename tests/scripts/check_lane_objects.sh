#!/usr/bin/env bash
# The pair and wall passes' and the bodies' (single spheres and clumps) AVX2 and AVX-512F files
# (src/sim/{pair,wall}_pass_lanes{4,8}.cpp, src/sim/body_lanes{4,8}.cpp) and
# the list build's AVX-512F candidate scan (src/neighbor/candidate_scan_avx512.cpp) are
# compiled for instruction sets the baseline build does not assume. If one of them defined an
# ordinary inline function (a Vec3 operator, a scalar contact law) as a weak symbol, the linker
# could keep that copy for the whole program, and a CPU without AVX2 would stop on an illegal
# instruction. So every global symbol they define must belong to their own SIMD types.
# Usage: check_lane_objects.sh libbiodem_core.a
set -euo pipefail
lib=$1
members=$(ar t "$lib" | grep -E '((pair|wall)_pass_lanes(4|8)|body_lanes(4|8)|candidate_scan_avx512)\.cpp\.o$' || true)
if [ -z "$members" ]; then echo "no AVX lane objects in $lib (not an x86-64 build): nothing to check"; exit 0; fi
bad=$(nm -C -A --defined-only "$lib" 2>/dev/null | grep -E '((pair|wall)_pass_lanes(4|8)|body_lanes(4|8)|candidate_scan_avx512)\.cpp\.o:' |
      awk '$(NF-1) ~ /^[TWVu]$/ || $2 ~ /^[TWVu]$/' |
      grep -v -E 'simd|_VecBuiltin|_VecBltnBtmsk|evaluate_batch_lanes|evaluate_wall_batch_lanes|advance_(sphere|clump)_bodies_lanes|scan_candidates_avx512|DW\.ref\.__gxx_personality' || true)
if [ -n "$bad" ]; then
  echo "AVX lane objects define symbols that baseline code could bind to:"
  echo "$bad"
  exit 1
fi
echo "AVX lane objects: every defined global symbol is lane-typed ($(echo "$members" | wc -l) objects)"
