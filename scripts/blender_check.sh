#!/usr/bin/env bash
# Imports the meshes `qjulia mesh` writes into Blender (../shared/validate/blender_import.sh,
# Blender's own importers, headless) and compares Blender's vertex and face counts with
# qjulia's --stats. Formats: .glb .obj .ply .stl (Blender 3.4 has no 3MF importer).
# Prints one line per import and a summary; exits 1 when any import fails, is not watertight or
# disagrees on the counts, 2 on a usage error (or when blender is not installed).
#
# usage: scripts/blender_check.sh [--qjulia BIN] [--presets "a b ..."] [--resolution N]
#                                 [--out DIR] [--validate-dir DIR]
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
QJULIA=$ROOT/build/bin/qjulia
VALIDATE=$(cd "$ROOT/.." && pwd)/shared/validate
PRESETS=""
RESOLUTION=""
OUT=""
while (($#)); do
  case "$1" in
    --qjulia) QJULIA=$2; shift 2 ;;
    --presets) PRESETS=$2; shift 2 ;;
    --resolution) RESOLUTION=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --validate-dir) VALIDATE=$2; shift 2 ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    *) echo "blender_check.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
[[ -x $QJULIA ]] || { echo "blender_check.sh: $QJULIA not found (build qjulia_cli, or --qjulia BIN)" >&2; exit 2; }
command -v "${BLENDER:-blender}" >/dev/null || { echo "blender_check.sh: blender not installed (apt-get install blender)" >&2; exit 2; }
[[ -x $VALIDATE/blender_import.sh ]] || { echo "blender_check.sh: $VALIDATE/blender_import.sh not found" >&2; exit 2; }
PY=/usr/bin/python3
if [[ -z $OUT ]]; then
  OUT=$(mktemp -d)
  trap 'rm -rf "$OUT"' EXIT
fi
mkdir -p "$OUT"
if [[ -z $PRESETS ]]; then
  PRESETS=$("$QJULIA" presets | awk 'NF {print $1}')
fi
extra=()
[[ -n $RESOLUTION ]] && extra+=(--resolution "$RESOLUTION")

pass=0
fail=0
failures=()
printf '%-28s %-5s %10s %10s %10s %10s  %s\n' preset fmt "V qjulia" "V blender" "F qjulia" "F blender" result
for preset in $PRESETS; do
  for fmt in glb obj ply stl; do
    file=$OUT/$preset.$fmt
    stats=$OUT/$preset.$fmt.stats.json
    if ! "$QJULIA" mesh --preset "$preset" "${extra[@]}" --quiet --stats "$stats" -o "$file" \
        >"$file.mesh.log" 2>&1; then
      fail=$((fail + 1)); failures+=("$preset.$fmt: qjulia mesh failed ($(tail -1 "$file.mesh.log"))")
      printf '%-28s %-5s %s\n' "$preset" "$fmt" "qjulia mesh FAILED"
      continue
    fi
    read -r qv qf < <("$PY" -c 'import json,sys; s=json.load(open(sys.argv[1])); print(s["vertices"], s["faces"])' "$stats")
    "$VALIDATE/blender_import.sh" --require-watertight "$file" >"$file.blender.log" 2>&1
    rc=$?
    line=$(grep -E '^total: ' "$file.blender.log" | head -1)
    bv=$(sed -nE 's/.* V=([0-9]+).*/\1/p' <<<"$line")
    bf=$(sed -nE 's/.* F=([0-9]+).*/\1/p' <<<"$line")
    result=OK
    if ((rc != 0)); then
      result="blender_import exit $rc: $(grep -E 'RESULT|rror' "$file.blender.log" | tail -1)"
    elif [[ "$bv" != "$qv" || "$bf" != "$qf" ]]; then
      result="counts differ"
      # STL has no indices: distinct vertices at one position are welded, and the triangles
      # between them (zero-length edges) become degenerate and are dropped by Blender.
      [[ $fmt == stl ]] && result+=" (distinct vertices at equal positions? mesh_report.py on the .glb: 'duplicated positions')"
    fi
    printf '%-28s %-5s %10s %10s %10s %10s  %s\n' "$preset" "$fmt" "$qv" "${bv:-?}" "$qf" "${bf:-?}" "$result"
    if [[ $result == OK ]]; then
      pass=$((pass + 1))
    else
      fail=$((fail + 1)); failures+=("$preset.$fmt: $result (log: $file.blender.log)")
    fi
  done
done
echo
echo "blender_check: $pass passed, $fail failed"
for f in "${failures[@]}"; do echo "  failed: $f"; done
((fail == 0))
