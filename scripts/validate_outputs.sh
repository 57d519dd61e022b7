#!/usr/bin/env bash
# Checks the meshes `qjulia mesh` writes with the real clients of ../shared/validate:
#   - Khronos glTF-Validator (gltf_validate.sh --strict: 0 errors AND 0 warnings) on .glb and
#     .gltf, with and without --color;
#   - mesh_report.py --require-watertight on every format (.glb .gltf .obj .ply .stl .3mf).
# For every preset (or those given). Prints one line per check and a summary; exits 1 when any
# check fails, 2 on a usage error.
#
# usage: scripts/validate_outputs.sh [--qjulia BIN] [--presets "a b ..."] [--resolution N]
#                                    [--color MODE] [--out DIR] [--validate-dir DIR]
#   --qjulia BIN       the qjulia executable (default: build/bin/qjulia)
#   --resolution N     override the presets' resolution (faster runs), default: the preset's
#   --color MODE       the colour mode of the coloured runs (default: iterations)
#   --out DIR          keep the meshes and logs there (default: a temporary directory, removed)
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
QJULIA=$ROOT/build/bin/qjulia
VALIDATE=$(cd "$ROOT/.." && pwd)/shared/validate
PRESETS=""
RESOLUTION=""
COLOR=iterations
OUT=""
while (($#)); do
  case "$1" in
    --qjulia) QJULIA=$2; shift 2 ;;
    --presets) PRESETS=$2; shift 2 ;;
    --resolution) RESOLUTION=$2; shift 2 ;;
    --color) COLOR=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --validate-dir) VALIDATE=$2; shift 2 ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "validate_outputs.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
[[ -x $QJULIA ]] || { echo "validate_outputs.sh: $QJULIA not found (build the qjulia_cli target, or --qjulia BIN)" >&2; exit 2; }
[[ -x $VALIDATE/gltf_validate.sh && -f $VALIDATE/mesh_report.py ]] || { echo "validate_outputs.sh: validators not found in $VALIDATE (--validate-dir DIR)" >&2; exit 2; }
PY=/usr/bin/python3  # has numpy; python3 on PATH may not
if [[ -z $OUT ]]; then
  OUT=$(mktemp -d)
  trap 'rm -rf "$OUT"' EXIT
fi
mkdir -p "$OUT"
if [[ -z $PRESETS ]]; then
  PRESETS=$("$QJULIA" presets | awk 'NF {print $1}')
  [[ -n $PRESETS ]] || PRESETS=$(cd "$ROOT/data/presets" && ls *.json | sed 's/\.json$//')
fi

pass=0
fail=0
failures=()
check() {  # check NAME LOG cmd...: runs cmd, logs its output, records the result
  local name=$1 log=$2
  shift 2
  if "$@" >"$log" 2>&1; then
    pass=$((pass + 1))
    printf 'PASS  %s\n' "$name"
  else
    fail=$((fail + 1))
    failures+=("$name (log: $log)")
    printf 'FAIL  %s\n' "$name"
    grep -E 'errors=|RESULT|watertight|boundary|error|Error' "$log" | head -5 | sed 's/^/      /'
  fi
}

extra=()
[[ -n $RESOLUTION ]] && extra+=(--resolution "$RESOLUTION")
for preset in $PRESETS; do
  for colored in no yes; do
    if [[ $colored == yes ]]; then
      formats=(glb gltf obj ply)
      cargs=(--color "$COLOR")
      tag=$preset-color
    else
      formats=(glb gltf obj ply stl 3mf)
      cargs=()
      tag=$preset
    fi
    for fmt in "${formats[@]}"; do
      file=$OUT/$tag.$fmt
      log=$OUT/$tag.$fmt
      if ! "$QJULIA" mesh --preset "$preset" "${extra[@]}" "${cargs[@]}" --quiet -o "$file" \
          >"$log.mesh.log" 2>&1; then
        fail=$((fail + 1))
        failures+=("$tag.$fmt: qjulia mesh failed (log: $log.mesh.log)")
        printf 'FAIL  %s: qjulia mesh failed: %s\n' "$tag.$fmt" "$(tail -1 "$log.mesh.log")"
        continue
      fi
      if [[ $fmt == glb || $fmt == gltf ]]; then
        check "$tag.$fmt gltf_validate --strict" "$log.gltf_validate.log" \
          "$VALIDATE/gltf_validate.sh" --strict "$file"
      fi
      check "$tag.$fmt mesh_report --require-watertight" "$log.mesh_report.log" \
        "$PY" "$VALIDATE/mesh_report.py" --require-watertight "$file"
    done
  done
done

echo
echo "validate_outputs: $pass passed, $fail failed (presets: $(echo $PRESETS | tr '\n' ' '))"
for f in "${failures[@]}"; do echo "  failed: $f"; done
((fail == 0))
