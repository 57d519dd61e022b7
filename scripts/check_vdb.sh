#!/usr/bin/env bash
# Checks that the grid `qjulia mesh --vdb` writes reads back with Debian's python3-openvdb
# (module pyopenvdb, as Blender's and Houdini's importers see it): one float grid, named F,
# holding the parameters. Prints "N passed, N failed"; exits 1 on a failure.
# usage: scripts/check_vdb.sh [--qjulia BIN]
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
QJULIA=$ROOT/build/bin/qjulia
[[ ${1:-} == --qjulia ]] && QJULIA=$2
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
passed=0 failed=0
for preset in unit-ball newton-cubic; do
  if "$QJULIA" mesh --preset "$preset" --resolution 48 --quiet -o "$OUT/$preset.ply" \
       --vdb "$OUT/$preset.vdb" >/dev/null &&
     /usr/bin/python3 - "$OUT/$preset.vdb" <<'PY'
import sys, json
import pyopenvdb as vdb
grids, meta = vdb.readAll(sys.argv[1])
assert len(grids) == 1, f"{len(grids)} grids"
g = grids[0]
assert type(g).__name__ == "FloatGrid", type(g).__name__
assert g.name == "F", g.name
assert g.activeVoxelCount() > 0
params = json.loads(g.metadata["qjulia_parameters"])
assert "formula" in params and "method" in params
print(f"{sys.argv[1]}: one FloatGrid 'F', {g.activeVoxelCount()} active voxels, method {params['method']}")
PY
  then passed=$((passed + 1)); else echo "FAIL  $preset.vdb" >&2; failed=$((failed + 1)); fi
done
echo "check_vdb: $passed passed, $failed failed"
((failed == 0))
