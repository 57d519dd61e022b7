"""Shared fixtures of the qjulia module's tests: the CLI to compare with, and a PNG reader.

ctest runs them as `/usr/bin/python3 -m pytest tests/python` with PYTHONPATH=build/python and
QJULIA_CLI=build/bin/qjulia (tests/CMakeLists.txt).
"""

import json
import os
import struct
import subprocess
import zlib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
CLI = os.environ.get("QJULIA_CLI", str(ROOT / "build" / "bin" / "qjulia"))

# The figures of the run: time, memory, and the estimate (it depends on the memory available
# and on the output formats, which a Python call does not name).
RUN_KEYS = ("timings", "peak_rss_bytes", "estimate")


def run_cli(*args, check=True):
    """Runs the qjulia command; returns the CompletedProcess (text)."""
    result = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    if check and result.returncode != 0:
        raise AssertionError(f"qjulia {' '.join(map(str, args))} failed ({result.returncode}): "
                             f"{result.stderr}")
    return result


def cli_error(*args):
    """The message of a command that fails with exit code 2, without the 'qjulia CMD: ' prefix."""
    result = run_cli(*args, check=False)
    assert result.returncode == 2, result
    line = result.stderr.strip().splitlines()[-1]
    prefix = f"qjulia {args[0]}: "
    assert line.startswith(prefix), line
    return line[len(prefix):]


def cli_stats(tmp_path, *args, out="cli.ply"):
    """--stats of `qjulia mesh ARGS -o tmp_path/out`, and the path of the mesh."""
    stats = tmp_path / (out + ".stats.json")
    run_cli("mesh", *args, "--quiet", "--stats", stats, "-o", tmp_path / out)
    return json.loads(stats.read_text()), tmp_path / out


def mesh_figures(stats):
    """The stats without the figures of the run (time, memory)."""
    return {k: v for k, v in stats.items() if k not in RUN_KEYS}


def read_png(path):
    """An 8-bit RGB or grey, non-interlaced PNG (what write_png writes) as H x W x 3 uint8."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    width, height, depth, color_type, _, _, interlace = header
    assert depth == 8 and interlace == 0 and color_type in (0, 2), header
    channels = 3 if color_type == 2 else 1
    stride = width * channels
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(height, stride + 1)
    out = np.zeros((height, stride), np.int32)
    for y in range(height):
        kind, line = raw[y, 0], raw[y, 1:].astype(np.int32)
        up = out[y - 1] if y else np.zeros(stride, np.int32)
        if kind in (0, 2):
            out[y] = (line + (up if kind == 2 else 0)) & 255
        else:  # 1 sub, 3 average, 4 Paeth: each byte depends on the one left of it
            row = out[y]
            for x in range(stride):
                left = row[x - channels] if x >= channels else 0
                if kind == 1:
                    pred = left
                elif kind == 3:
                    pred = (left + up[x]) // 2
                else:
                    upper_left = up[x - channels] if x >= channels else 0
                    p = left + up[x] - upper_left
                    pa, pb, pc = abs(p - left), abs(p - up[x]), abs(p - upper_left)
                    pred = left if pa <= pb and pa <= pc else up[x] if pb <= pc else upper_left
                row[x] = (line[x] + pred) & 255
    image = out.astype(np.uint8).reshape(height, width, channels)
    return np.repeat(image, 3, axis=2) if channels == 1 else image

