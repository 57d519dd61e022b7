#!/usr/bin/env bash
# Installs the build (build/, or $1) into an empty prefix, builds examples/consumer against it
# with find_package(qjulia), runs it and checks the unit ball's volume; runs the installed CLI.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" >/dev/null
cmake -S examples/consumer -B "$work/consumer" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/consumer" -j "$(nproc)" >/dev/null
out=$("$work/consumer/consumer")
echo "check_install: $out"
# The mesh of the unit ball at resolution 32 lies within 3% of 4/3 pi.
echo "$out" | awk '{ for (i = 1; i < NF; ++i) if ($i == "volume") v = $(i + 1) }
  END { d = v - 4.18879; if (d < 0) d = -d; exit !(v != "" && d < 0.03 * 4.18879) }' ||
  { echo "check_install: wrong volume" >&2; exit 1; }
"$work/prefix/bin/qjulia" version
test -f "$work/prefix/include/qjulia/pipeline/pipeline.h"
echo "check_install: ok ($(find "$work/prefix" -type f | wc -l) files installed)"
