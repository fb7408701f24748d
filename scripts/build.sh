#!/usr/bin/env bash
# Configures and builds biodem (Release, warnings on) into ./build.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@" > build-configure.log
cmake --build build -j"$(nproc)"
