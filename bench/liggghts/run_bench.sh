#!/bin/sh
# Timing runs of the LIGGGHTS 3.8.0 reference drums at 1 and 2 MPI ranks.
#
#   sh run_bench.sh [suffix] [case ...]        cases: glass glass_small raw (default: all three)
#
# Each run:  timeout $TIMEOUT mpirun --allow-run-as-root -np N liggghts -in in.drum_<case> ...
# writing logs/<case>_np<N><suffix>.log (LIGGGHTS log), .screen (stdout/stderr) and
# logs/com_<case>_np<N><suffix>.txt.  Summarise with:  python3 parse_logs.py logs/*.log
#
# Steps per case (settle, then timed rotation run; "Loop time" of the rotation run is the figure):
#   glass        nsettle 30000  nrot 10000   (the 100 mm bed comes to rest ~0.3 s = 20,000 steps)
#   glass_small  nsettle 10000  nrot 20000
#   raw          nsettle 30000  nrot  2000   (the 400 mm bed needs ~0.3 s to come to rest)
#
# Environment overrides:
#   NPS="1 2"          rank counts to run
#   TIMEOUT=590        wall-clock limit per run [s].  The raw case at 1 rank (30,000 settle steps)
#                      needs roughly 10-15 min on the 2-core VM: run it with TIMEOUT=1500.
#   NSETTLE=, NROT=    override the step counts above for every case
#   SKINF=1.0          neighbour skin as a fraction of the particle radius (1.0 = d/2, the
#                      recommended value; 0.25 = d/8, biodem's default; 0.5 = d/4 before)
#   NICE="nice -n 10"  prefix for the run (set NICE= to run at normal priority)
#   LIGGGHTS=liggghts  binary
set -u
cd "$(dirname "$0")" || exit 1

suffix=${1:-}
[ $# -gt 0 ] && shift
cases=${*:-glass glass_small raw}
NPS=${NPS:-1 2}
TIMEOUT=${TIMEOUT:-590}
NICE=${NICE-nice -n 10}
LIGGGHTS=${LIGGGHTS:-liggghts}

mkdir -p logs

for c in $cases; do
    case $c in
        glass)       ns=30000; nr=10000 ;;
        glass_small) ns=10000; nr=20000 ;;
        raw)         ns=30000; nr=2000 ;;
        *) echo "unknown case '$c' (glass, glass_small, raw)" >&2; exit 2 ;;
    esac
    ns=${NSETTLE:-$ns}
    nr=${NROT:-$nr}
    for np in $NPS; do
        tag=${c}_np${np}${suffix}
        echo "== $tag: nsettle $ns nrot $nr, $np rank(s), timeout $TIMEOUT s  ($(date '+%F %T'))"
        start=$(date +%s)
        $NICE timeout "$TIMEOUT" mpirun --allow-run-as-root -np "$np" "$LIGGGHTS" -in "in.drum_$c" \
            -var nsettle "$ns" -var nrot "$nr" -var tag "$tag" -var skinf "${SKINF:-1.0}" -log "logs/$tag.log" \
            > "logs/$tag.screen" 2>&1
        rc=$?
        [ -f "com_$tag.txt" ] && mv "com_$tag.txt" logs/
        echo "   exit $rc after $(( $(date +%s) - start )) s$( [ $rc -eq 124 ] && echo ' (TIMEOUT)')"
        grep "^Loop time" "logs/$tag.log" | sed 's/^/   /'
    done
done
