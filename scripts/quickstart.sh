#!/usr/bin/env bash
# README's first command: install the Debian packages, build, and run the small glass-bead drum.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
bash scripts/build.sh
./build/biodem check cases/glass_beads_small.toml > /dev/null
./build/biodem run cases/glass_beads_small.toml --out out/glass_beads_small
echo "Outputs: $(pwd)/out/glass_beads_small (series.csv, snapshots.pvd for ParaView, speed_images/*.png, run.log)"
