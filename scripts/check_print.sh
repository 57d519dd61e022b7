#!/usr/bin/env bash
# Checks a print-ready mesh with ../shared/validate/mesh_report.py: classic-julia at --size 80mm
# as STL must be watertight and its longest side 80 mm (+-0.05). Prints "N passed, N failed".
# usage: scripts/check_print.sh [--qjulia BIN] [--resolution N]
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
QJULIA=$ROOT/build/bin/qjulia
RESOLUTION=256
while (($#)); do
  case "$1" in
    --qjulia) QJULIA=$2; shift 2 ;;
    --resolution) RESOLUTION=$2; shift 2 ;;
    *) echo "check_print.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
REPORT=$(cd "$ROOT/.." && pwd)/shared/validate/mesh_report.py
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
passed=0 failed=0
"$QJULIA" mesh --preset classic-julia --resolution "$RESOLUTION" --size 80mm --quiet \
  -o "$OUT/julia80.stl" >/dev/null || { echo "FAIL  qjulia mesh --size 80mm" >&2; exit 1; }
if /usr/bin/python3 "$REPORT" --require-watertight --json "$OUT/julia80.stl" >"$OUT/report.json"; then
  echo "PASS  julia80.stl mesh_report --require-watertight"; passed=$((passed + 1))
else
  echo "FAIL  julia80.stl mesh_report --require-watertight" >&2; failed=$((failed + 1))
fi
if /usr/bin/python3 -c '
import json, sys
size = max(json.load(open(sys.argv[1]))["bbox_size"])
print(f"longest side {size:.4f} mm")
sys.exit(0 if abs(size - 80) <= 0.05 else 1)' "$OUT/report.json"; then
  echo "PASS  julia80.stl longest side 80 mm"; passed=$((passed + 1))
else
  echo "FAIL  julia80.stl longest side 80 mm" >&2; failed=$((failed + 1))
fi
echo "check_print: $passed passed, $failed failed"
((failed == 0))
