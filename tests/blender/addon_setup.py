"""What the add-on's Blender tests share: the arguments after '--' (--module-path DIR,
--cli QJULIA), the add-on enabled from blender/ with DIR as its module preference, a temporary
directory, and `qjulia mesh --stats` for comparison."""

import argparse
import json
import os
import subprocess
import sys
import tempfile

import addon_utils
import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
parser = argparse.ArgumentParser()
parser.add_argument("--module-path", required=True)
parser.add_argument("--cli", required=True)
ARGS = parser.parse_args(sys.argv[sys.argv.index("--") + 1:])
TMP = tempfile.mkdtemp(prefix="qjulia-blender-")

sys.path.insert(0, os.path.join(ROOT, "blender"))
assert addon_utils.enable("qjulia_blender", default_set=True) is not None, "add-on not enabled"
bpy.context.preferences.addons["qjulia_blender"].preferences.module_path = ARGS.module_path
from qjulia_blender import build  # noqa: E402  (after the add-on is enabled)

qjulia = build.load_qjulia()
assert os.path.dirname(os.path.dirname(qjulia.__file__)) == os.path.abspath(ARGS.module_path), \
    qjulia.__file__


def cli_stats(*flags):
    """The --stats of `qjulia mesh FLAGS` (the mesh itself is written to TMP and not used)."""
    stats = os.path.join(TMP, "stats.json")
    subprocess.run([ARGS.cli, "mesh", *map(str, flags), "--quiet", "--stats", stats,
                    "-o", os.path.join(TMP, "cli.ply")], check=True, stdout=subprocess.DEVNULL)
    with open(stats) as f:
        return json.load(f)
