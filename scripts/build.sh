#!/usr/bin/env bash
# Configures and builds qjulia (Release) in build/. Usage: scripts/build.sh [cmake target...]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)" ${1:+--target "$@"}
