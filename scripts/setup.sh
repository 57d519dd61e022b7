#!/usr/bin/env bash
# Installs the Debian packages qjulia needs to build and test, when they are missing.
# Usage: scripts/setup.sh [--validate]   (--validate adds the tools of ../shared/validate)
set -euo pipefail

# libclang-rt-16-dev holds clang's ASan, UBSan and libFuzzer runtimes (the fuzz build), and
# llvm-16 the llvm-symbolizer that names the functions of a sanitizer's report (the fuzz
# step's leak suppressions match those names), both of which clang-16 only recommends.
packages=(cmake g++ make ccache pkg-config
  libopenvdb-dev libboost-iostreams-dev libtbb-dev libopenmesh-dev libcgal-dev
  libtinygltf-dev libstb-dev nlohmann-json3-dev libgtest-dev lib3mf-dev libzip-dev
  libpng-dev libhwy-dev clang-16 libfuzzer-16-dev libclang-rt-16-dev llvm-16
  pybind11-dev python3-pybind11 python3-dev python3-numpy python3-pytest blender xvfb xauth
  libopenmpi-dev openmpi-bin
  libcpp-httplib-dev chromium)
# Node.js and npm (qjulia explore's page and its browser test): a Node.js already on PATH, e.g.
# one from outside Debian, is used with its own npm; otherwise Debian's.
if ! command -v node >/dev/null 2>&1; then
  packages+=(nodejs npm)
elif ! command -v npm >/dev/null 2>&1; then
  if dpkg-query -S "$(readlink -f "$(command -v node)")" 2>/dev/null | grep -q '^nodejs:' &&
    ! dpkg-query -W -f='${Version}' nodejs | grep -q nodesource; then
    packages+=(npm)
  else
    echo "setup: $(command -v node) is not Debian's Node.js and has no npm beside it" >&2
    exit 1
  fi
fi
if [[ "${1:-}" == "--validate" ]]; then
  packages+=(python3-numpy python3-scipy python3-openvdb)
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

# The page's npm packages (web/package-lock.json: three.js; puppeteer-core and the glTF
# validator for the tests) into web/node_modules, once: later builds need no network.
cmake -DNPM="$(command -v npm)" -DWEB_DIR="$(cd "$(dirname "$0")/.." && pwd)/web" \
  -P "$(dirname "$0")/../web/npm_ci.cmake"
