#!/bin/sh
# Side-by-side small cohesive raw-needle drum: biodem (drum_peer.toml) and LIGGGHTS 3.8.0
# (../liggghts/in.drum_raw with the variables below), seeds 1, 2, 3 each. README.md in this folder.
#
#   sh run_drum_peer.sh                  run everything (one simulation at a time), then compare
#   COMPARE_ONLY=1 sh run_drum_peer.sh   compare the outputs already in $OUT again
#
# THE CHECK. alpha(t) is the centroid angle (SPEC 6; LIGGGHTS: alpha = 180 - angle of its com
# file), sampled at 20 Hz in both codes at the same instants. Over the rotation window (samples
# from the start of rotation, t = T_SETTLE, to the end):
#   - alpha before the first avalanche = the running maximum of alpha at the first sample that
#     lies more than DROP_DEG (default 1 deg) below it (the first drop larger than 1 deg);
#   - mean alpha = the mean of the samples after the start of rotation (t > T_SETTLE).
# Per code, the mean over the seeds and the spread (sample standard deviation over the seeds).
# The script exits 1 when either mean (alpha before the first avalanche, or mean alpha) differs
# between the codes by more than TOL_DEG (default 2 deg); exits 2 when a run fails, its series is
# missing, or a seed has no first avalanche within the window.
#
# Each run is single-threaded (biodem --threads 1, LIGGGHTS serial without mpirun) and runs under
# $NICE, one after the other. Environment:
#   BIODEM=../../build/biodem  LIGGGHTS=liggghts  OUT=runs  SEEDS="1 2 3"  CODES="biodem liggghts"
#   NICE="nice -n 10"  NSETTLE=25000  NROT=250000  (steps of 1e-5 s; short trials: NSETTLE=2000
#   NROT=3000)  DROP_DEG=1.0  TOL_DEG=2.0  COMPARE_ONLY=
set -u
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
BIODEM=${BIODEM:-$root/build/biodem}
LIGGGHTS=${LIGGGHTS:-liggghts}
OUT=${OUT:-$here/runs}
SEEDS=${SEEDS:-1 2 3}
CODES=${CODES:-biodem liggghts}
NICE=${NICE-nice -n 10}
NSETTLE=${NSETTLE:-25000}
NROT=${NROT:-250000}
DROP_DEG=${DROP_DEG:-1.0}
TOL_DEG=${TOL_DEG:-2.0}
COMPARE_ONLY=${COMPARE_ONLY:-}

# The scene (must match drum_peer.toml): 1,000 needles, R 0.055 m, W 0.02 m, 10 rpm, dt 1e-5 s.
NCLUMP=1000
R=0.055
W=0.02
RPM=10
DT=1e-5
T_SETTLE=$(python3 -c "print('%.10g' % ($NSETTLE * $DT))")
T_ROT=$(python3 -c "print('%.10g' % ($NROT * $DT))")

# LIGGGHTS insertion seeds (primes) for seeds 1-6; seed 1 is in.drum_raw's default
iseed() { case $1 in 1) echo 49979693 ;; 2) echo 67867967 ;; 3) echo 86028121 ;; 4) echo 104395303 ;;
          5) echo 122949829 ;; 6) echo 141650963 ;; *) echo "" ;; esac; }

mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
fail=0

for seed in $SEEDS; do
    for code in $CODES; do
        d=$OUT/${code}_s$seed
        [ -n "$COMPARE_ONLY" ] && continue
        rm -rf "$d"
        mkdir -p "$d"
        echo "== $code seed $seed  ($(date -u '+%F %T') UTC)"
        start=$(date +%s)
        if [ "$code" = biodem ]; then
            sed -e "s/^seed = 1 /seed = $seed /" \
                -e "s/^duration_s = 0\.25\( .*\)\{0,1\}$/duration_s = $T_SETTLE\1/" \
                -e "s/^duration_s = 2\.5\( .*\)\{0,1\}$/duration_s = $T_ROT\1/" "$here/drum_peer.toml" > "$d/case.toml"
            $NICE "$BIODEM" run "$d/case.toml" --out "$d/out" --threads 1 > "$d/screen.txt" 2>&1
        else
            is=$(iseed "$seed")
            [ -n "$is" ] || { echo "   no LIGGGHTS insertion seed for seed $seed" >&2; fail=2; continue; }
            cp "$root/bench/liggghts/plate.stl" "$d/"
            (cd "$d" && $NICE "$LIGGGHTS" -in "$root/bench/liggghts/in.drum_raw" -var nclump $NCLUMP \
                -var R $R -var W $W -var rpm $RPM -var nsettle "$NSETTLE" -var nrot "$NROT" \
                -var iseed "$is" -var tag "s$seed" -log log.liggghts > screen.txt 2>&1)
        fi
        rc=$?
        echo "$(( $(date +%s) - start ))" > "$d/wall_s"
        echo "   exit $rc after $(cat "$d/wall_s") s"
        [ $rc -eq 0 ] || fail=2
    done
done

python3 - "$OUT" "$SEEDS" "$CODES" "$T_SETTLE" "$DROP_DEG" "$TOL_DEG" "$NCLUMP" <<'EOF'
import math, os, re, statistics, sys
out, seeds, codes, t_settle, drop, tol = sys.argv[1], sys.argv[2].split(), sys.argv[3].split(), \
    float(sys.argv[4]), float(sys.argv[5]), float(sys.argv[6])
NCLUMP = int(sys.argv[7])
status = 0

def series(code, seed):
    d = os.path.join(out, "%s_s%s" % (code, seed))
    rows = []
    if code == "biodem":
        p = os.path.join(d, "out", "series.csv")
        if not os.path.exists(p):
            return None, d
        lines = open(p).read().split("\n")
        head = lines[0].split(",")
        it, ia = head.index("time_s"), head.index("alpha_deg")
        for l in lines[1:]:
            if l.strip():
                f = l.split(",")
                rows.append((float(f[it]), float(f[ia])))
    else:
        p = os.path.join(d, "com_s%s.txt" % seed)
        if not os.path.exists(p):
            return None, d
        for l in open(p):
            if l.strip() and not l.startswith("#"):
                t, x, y, ang = map(float, l.split()[:4])
                rows.append((t, 180.0 - ang))
    return rows, d

def inserted(code, d):
    """(bodies inserted, waves) from the run's log; None when not found."""
    if code == "biodem":
        p = os.path.join(d, "out", "run.log")
        if not os.path.exists(p):
            return None
        waves = re.findall(r"^insertion wave (\d+) at t = \S+ s: \d+ particles \(total (\d+) of", open(p).read(), re.M)
        return (int(waves[-1][1]), len(waves)) if waves else None
    p = os.path.join(d, "screen.txt")
    n = re.findall(r"inserted (\d+) particle templates", open(p).read()) if os.path.exists(p) else []
    return (sum(map(int, n)), len(n)) if n else None

def measure(rows):
    rot = [(t, a) for t, a in rows if t >= t_settle - 1e-9]
    mean = statistics.mean([a for t, a in rot if t > t_settle + 1e-9])
    m, tm, first = -1e9, None, None
    for t, a in rot:
        if a > m:
            m, tm = a, t
        elif a < m - drop:
            first = (m, tm, t, a)
            break
    return mean, first, rot[-1][0], rot[0][1]

res = {}
print("\n%-9s %4s %7s %10s %8s %8s %9s %9s %8s %7s" % ("code", "seed", "alpha0", "alpha_av", "t_peak", "t_drop",
      "alpha_dr", "mean", "t_end", "wall"))
print("%-9s %4s %7s %10s %8s %8s %9s %9s %8s %7s" % ("", "", "deg", "deg", "s", "s", "deg", "deg", "s", "s"))
for c in codes:
    for s in seeds:
        rows, d = series(c, s)
        wall = open(os.path.join(d, "wall_s")).read().strip() if os.path.exists(os.path.join(d, "wall_s")) else "-"
        if not rows or rows[-1][0] <= t_settle:
            print("%-9s %4s   no series after the settle phase (%s)" % (c, s, d))
            status = 2
            continue
        ins = inserted(c, d)
        if ins is None or ins != (NCLUMP, 1):
            print("%-9s %4s   insertion: %s (expected %d bodies in one wave)" % (c, s, ins, NCLUMP))
            status = 2
        mean, first, tend, a0 = measure(rows)
        if first is None:
            print("%-9s %4s %7.2f %10s %8s %8s %9s %9.2f %8.2f %7s   (no drop > %g deg)" % (c, s, a0, "-", "-", "-", "-",
                  mean, tend, wall, drop))
            status = 2
            res.setdefault(c, []).append((float("nan"), mean))
            continue
        print("%-9s %4s %7.2f %10.2f %8.2f %8.2f %9.2f %9.2f %8.2f %7s" % (c, s, a0, first[0], first[1], first[2],
              first[3], mean, tend, wall))
        res.setdefault(c, []).append((first[0], mean))

def ms(v):
    v = [x for x in v if math.isfinite(x)]
    if not v:
        return float("nan"), float("nan"), 0
    return statistics.mean(v), (statistics.stdev(v) if len(v) > 1 else float("nan")), len(v)

print()
summ = {}
for c, r in res.items():
    a, sa, na = ms([x[0] for x in r])
    b, sb, nb = ms([x[1] for x in r])
    summ[c] = (a, b)
    print("%-9s alpha before the first avalanche %.2f deg (seed SD %.2f, %d seeds); mean alpha %.2f deg (seed SD %.2f, %d seeds)"
          % (c, a, sa, na, b, sb, nb))
if "biodem" in summ and "liggghts" in summ:
    da = summ["biodem"][0] - summ["liggghts"][0]
    db = summ["biodem"][1] - summ["liggghts"][1]
    oka = math.isfinite(da) and abs(da) <= tol
    okb = math.isfinite(db) and abs(db) <= tol
    print("difference biodem - LIGGGHTS: alpha before the first avalanche %+.2f deg (%s), mean alpha %+.2f deg (%s); allowed %g deg"
          % (da, "PASS" if oka else "FAIL", db, "PASS" if okb else "FAIL", tol))
    if not (oka and okb) and status == 0:
        status = 1
sys.exit(status)
EOF
rc=$?
[ $fail -ne 0 ] && exit $fail
exit $rc
