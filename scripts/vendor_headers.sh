#!/usr/bin/env bash
# Copies the header-only dependencies (toml++, CLI11) and GoogleTest's sources from this Debian
# machine into a folder that travels with the source tree to a GPU machine without Debian's
# packages or network (docs/gpu.md, "lean build"). Usage: bash scripts/vendor_headers.sh [DIR]
# (default: vendor/, ignored by git). Needs libtomlplusplus-dev, libcli11-dev, libgtest-dev.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-vendor}
mkdir -p "$dir"
for src in /usr/include/toml++ /usr/include/CLI /usr/src/googletest; do
  [ -e "$src" ] || { echo "missing $src: install libtomlplusplus-dev libcli11-dev libgtest-dev" >&2; exit 1; }
done
rm -rf "$dir/toml++" "$dir/CLI" "$dir/googletest"
cp -r /usr/include/toml++ "$dir/toml++"
cp -r /usr/include/CLI "$dir/CLI"
cp -r /usr/src/googletest "$dir/googletest"
du -sh "$dir"
