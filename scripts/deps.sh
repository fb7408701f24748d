#!/usr/bin/env bash
# Installs the Debian packages biodem needs to build, test and plot (see README, "Dependencies").
set -euo pipefail
PKGS=(build-essential cmake pkg-config
      libtomlplusplus-dev libcli11-dev libgtest-dev libbenchmark-dev libomp-dev libopencv-dev libpng-dev libthrust-dev
      python3 python3-vtk9 libpagmo-dev libopenmpi-dev openmpi-bin)
missing=()
for p in "${PKGS[@]}"; do dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p"); done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
