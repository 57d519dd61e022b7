#!/usr/bin/env bash
# Installs the Debian packages qjulia needs to build and test, when they are missing.
# Usage: scripts/setup.sh [--validate]   (--validate adds the tools of ../shared/validate)
set -euo pipefail

packages=(cmake g++ make ccache pkg-config
  libopenvdb-dev libboost-iostreams-dev libtbb-dev libopenmesh-dev libcgal-dev
  libtinygltf-dev libstb-dev nlohmann-json3-dev libgtest-dev lib3mf-dev libzip-dev
  libmeshoptimizer-dev libpng-dev libhwy-dev clang-16 libfuzzer-16-dev
  pybind11-dev python3-pybind11 python3-dev python3-numpy python3-pytest blender xvfb xauth
  libopenmpi-dev openmpi-bin)
if [[ "${1:-}" == "--validate" ]]; then
  packages+=(python3-numpy python3-scipy python3-openvdb)
  command -v node >/dev/null 2>&1 || packages+=(nodejs npm)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  sudo_cmd=()
  [[ $(id -u) -ne 0 ]] && sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >&2
fi
