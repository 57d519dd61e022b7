#!/usr/bin/env bash
# Builds the Python module (build/python) and installs the Blender add-on: copies blender/qjulia_blender
# into Blender's user add-on directory, records there where the module is, and enables the
# add-on in the user preferences. Run it again after changing or rebuilding either.
#
# usage: scripts/install_blender_addon.sh [--no-build]   (BLENDER=path overrides `blender`)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BLENDER=${BLENDER:-blender}
if [[ ${1:-} != --no-build ]]; then
  "$ROOT/scripts/build.sh" qjulia_python
fi
[[ -f $ROOT/build/python/qjulia/__init__.py ]] ||
  { echo "install_blender_addon.sh: $ROOT/build/python/qjulia is missing (build it first)" >&2; exit 2; }
command -v "$BLENDER" >/dev/null ||
  { echo "install_blender_addon.sh: blender not installed (apt-get install blender)" >&2; exit 2; }

addons=$("$BLENDER" -b --factory-startup --python-expr \
  'import bpy; print("ADDONS=" + bpy.utils.user_resource("SCRIPTS", path="addons", create=True))' \
  2>/dev/null | sed -n 's/^ADDONS=//p')
[[ -n $addons ]] || { echo "install_blender_addon.sh: cannot find Blender's add-on directory" >&2; exit 1; }
rm -rf "$addons/qjulia_blender"
cp -r "$ROOT/blender/qjulia_blender" "$addons/"
find "$addons/qjulia_blender" -name __pycache__ -prune -exec rm -rf {} +
echo "$ROOT/build/python" >"$addons/qjulia_blender/module_path.txt"

# Enables it in the user's preferences (kept, unlike --factory-startup), and checks that the
# compiled module loads inside Blender.
"$BLENDER" -b --python-exit-code 1 --python-expr '
import addon_utils, bpy
assert addon_utils.enable("qjulia_blender", default_set=True), "the add-on did not load"
from qjulia_blender import build
print("qjulia", build.load_qjulia().__version__, "loads in Blender")
bpy.ops.wm.save_userpref()
' 2>&1 | grep -E "^qjulia|Error|error" || true
"$BLENDER" -b --python-exit-code 1 --python-expr \
  'import addon_utils; assert addon_utils.check("qjulia_blender")[1], "not enabled"' >/dev/null
echo "installed: $addons/qjulia_blender (module: $ROOT/build/python)"
