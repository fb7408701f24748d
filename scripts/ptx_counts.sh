#!/usr/bin/env bash
# Static PTX instruction counts of the GPU engine's kernels, without a GPU: compiles
# src/gpu/device_engine_cuda.cu to PTX (compute_90, the build's flags) and prints, per kernel
# whose name contains PATTERN, its instructions, double-precision operations, divisions and
# square roots, loads, stores (atomics included) and branches. A proxy for the length of a
# thread's path on sessions without a GPU (docs/gpu.md section 4); the counts are of the whole
# kernel (every branch), before ptxas, so compare one kernel before and after a change.
#
#   bash scripts/ptx_counts.sh [PATTERN] [PTX_FILE]
#   PATTERN: e.g. ReduceKickDrift (default: the step kernels); PTX_FILE: where the PTX goes
#   (default /tmp/biodem_engine.ptx; an existing file newer than the sources is reused).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
pattern=${1:-for_each}
ptx=${2:-/tmp/biodem_engine.ptx}
nvcc=${NVCC:-$(command -v nvcc || echo /usr/local/cuda/bin/nvcc)}
[ -x "$nvcc" ] || { echo "ptx_counts.sh: no nvcc (set NVCC or put CUDA's bin on PATH)" >&2; exit 2; }
if [ ! -f "$ptx" ] || [ -n "$(find "$here/src" -newer "$ptx" -name '*.hpp' -o -newer "$ptx" -name '*.cu' | head -1)" ]; then
  cccl=$(dirname "$nvcc")/../include/cccl
  "$nvcc" -I"$here/src" -isystem "$cccl" -DBIODEM_WITH_CUDA -O3 -DNDEBUG -arch=compute_90 --expt-relaxed-constexpr \
    -fmad=false -std=c++20 -ptx "$here/src/gpu/device_engine_cuda.cu" -o "$ptx"
fi
python3 - "$ptx" "$pattern" <<'EOF'
import re, subprocess, sys
src = open(sys.argv[1]).read()
pattern = sys.argv[2]
entries = []
for m in re.finditer(r'\.entry\s+(\S+)\(', src):
    i = src.index('{', m.end())
    depth, j = 0, i
    while True:
        if src[j] == '{':
            depth += 1
        elif src[j] == '}':
            depth -= 1
            if depth == 0:
                break
        j += 1
    entries.append((m.group(1), src[i:j]))
names = subprocess.run(['c++filt'], input='\n'.join(e[0] for e in entries), capture_output=True, text=True).stdout.split('\n')
op = lambda l, p: re.match(r'(@!?%p\d+\s+)?' + p, l) is not None
rows = []
for (mangled, body), name in zip(entries, names):
    if pattern not in name or 'cub::' in name:
        continue
    ins = [l.strip() for l in body.split('\n')]
    ins = [l for l in ins if l and not l.startswith(('.', '//', '{', '}')) and not l.endswith(':')]
    k = re.search(r'(for_each_\w+)<(?:biodem::gpu::)?(?:cuda_device::)?(\w+(?:<[^<>]*>)?)', name)
    label = f"{k.group(2)} ({k.group(1)})" if k else name
    rows.append((label[:64], len(ins),
                 sum(op(l, r'(fma|mul|add|sub|div|sqrt|rcp|neg|abs|min|max|setp)\S*\.f64') for l in ins),
                 sum(op(l, r'(div|rcp|sqrt)\S*\.f64') for l in ins),
                 sum(op(l, r'ld\.') for l in ins), sum(op(l, r'(st|red|atom)\.') for l in ins),
                 sum(op(l, r'bra') for l in ins)))
print(f"{'kernel':64s} {'instr':>6s} {'f64':>5s} {'div/sqrt':>8s} {'loads':>6s} {'stores':>6s} {'branches':>8s}")
for r in sorted(set(rows)):
    print(f"{r[0]:64s} {r[1]:6d} {r[2]:5d} {r[3]:8d} {r[4]:6d} {r[5]:6d} {r[6]:8d}")
EOF
