"""qjulia in Python: meshes of quaternionic Julia sets, numpy in and numpy out.

    import qjulia
    m = qjulia.mesh(preset="classic-julia", resolution=128, mesh={"color": "iterations"})
    print(m.vertices.shape, m.faces.shape, m.stats["volume"], m.stats["closed"])
    m.save("julia.glb")

Parameters are those of a parameter file of `qjulia mesh` (README.md, "Parameter file"): a
dict of its keys, or the path of a file, or a preset. Keyword overrides are the file's
top-level keys; a nested section given as a dict updates that section key by key
(slice={"axes": "rmp"}, mesh={"faces": 20000}, constants={"c": [-0.2, 0.8, 0, 0]}), any other
value replaces the key, and None removes it (its default applies). As with the CLI's --axes and
--fixed, slice axes or fixed given alone replace a general slice.

The work runs with the GIL released. Ctrl-C (KeyboardInterrupt) stops a long call within a
second; so do a progress callback that returns False and a requested CancelToken (both raise
qjulia.Cancelled). Bad input raises ValueError with the message of the CLI, a refusal by the
memory estimate MemoryError, a file that cannot be read or written OSError.
"""

import json
import math
import numbers
import os
from collections.abc import Mapping

from . import _core
from ._core import Cancelled, CancelToken, Mesh, save_png

__all__ = ["mesh", "params", "presets", "load", "compare", "render", "save_png", "Mesh",
           "CancelToken", "Cancelled"]
__version__ = _core.version()

# The sections of a parameter file that an override given as a dict updates key by key.
_SECTIONS = ("constants", "slice", "bounds", "mesh", "print")
# The least max_memory, as for --max-memory.
_MIN_MEMORY = 1 << 20
# The most samples compare() takes per surface, as for --samples.
_MOST_SAMPLES = _core.MOST_COMPARE_SAMPLES


def presets():
    """The built-in presets as {name: description}, in the order `qjulia presets` lists them."""
    return {name: _core.preset_description(name) for name in _core.preset_names()}


def _json_value(value):
    """numpy scalars and arrays inside a parameter dict, as JSON numbers and lists."""
    tolist = getattr(value, "tolist", None)
    if tolist is None:
        raise TypeError(f"parameter value {value!r} ({type(value).__name__}) is not a number, "
                        "string, bool, list or dict")
    return tolist()


def _base(params, preset):
    if params is not None and preset is not None:
        raise ValueError("give either params or preset, not both")
    if preset is not None:
        if not isinstance(preset, str):
            raise TypeError(f"preset must be a preset's name (presets()), not "
                            f"{type(preset).__name__}")
        return json.loads(_core.preset_json(preset))
    if params is None:
        return json.loads(_core.preset_json("newton-cubic"))
    if isinstance(params, (str, os.PathLike)):
        return json.loads(_core.params_file_json(os.fspath(params)))
    if isinstance(params, Mapping):
        return {key: dict(value) if isinstance(value, Mapping) else value
                for key, value in params.items()}
    raise TypeError("params must be a dict like a parameter file, the path of one, or None; "
                    f"not {type(params).__name__}")


def _merge(base, overrides):
    """The parameter file `base` with the overrides applied (see the module's docstring)."""
    out = dict(base)
    for key, value in overrides.items():
        if value is None:
            out.pop(key, None)
        elif key in _SECTIONS and isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            section = dict(out[key])
            if key == "slice" and {"axes", "fixed"} & value.keys() and \
                    not {"origin", "directions"} & value.keys():
                section.pop("origin", None)  # as --axes / --fixed: the slice by axes again
                section.pop("directions", None)
            section.update(value)
            out[key] = section
        else:
            out[key] = value
    return out


def _non_finite(value, path):
    """The path and value of the first NaN or infinity in a parameter value, or None."""
    if isinstance(value, Mapping):
        items = ((f"{path}.{key}" if path else str(key), v) for key, v in value.items())
    elif isinstance(value, (list, tuple)):
        items = ((f"{path}[{i}]", v) for i, v in enumerate(value))
    elif isinstance(value, (str, bool, int)) or value is None:
        return None
    elif isinstance(value, float):
        return None if math.isfinite(value) else (path, value)
    else:
        return _non_finite(_json_value(value), path)
    for item_path, item in items:
        found = _non_finite(item, item_path)
        if found:
            return found
    return None


def _params_json(params, preset, overrides):
    merged = _merge(_base(params, preset), overrides)
    try:
        return json.dumps(merged, default=_json_value, allow_nan=False)
    except ValueError:  # JSON has no NaN or infinity: name the key rather than fail to parse
        found = _non_finite(merged, "")
        if found is None:
            raise
        raise ValueError(f"parameters: '{found[0]}' is {found[1]}: the parameters must be finite "
                         "numbers") from None


def params(preset=None, **overrides):
    """The parameter file (a dict, complete and checked) of `preset` (default: newton-cubic)
    with the overrides, as `qjulia params --preset NAME ...` prints it."""
    return json.loads(_core.normalize_params(_params_json(None, preset, overrides)))


def _memory_bytes(max_memory):
    if max_memory is None:
        return None
    if isinstance(max_memory, bool):
        raise TypeError("max_memory must be a number of bytes or a size such as \"4G\"")
    if isinstance(max_memory, int):
        if max_memory < _MIN_MEMORY:
            raise ValueError(f"max_memory: expected at least 1M ({_MIN_MEMORY} bytes), "
                             f"got {max_memory}")
        return max_memory
    return _core.parse_memory_size(str(max_memory), "max_memory")


def mesh(params=None, *, preset=None, progress=None, cancel=None, vdb=False, dense=False,
         max_memory=None, **overrides):
    """Meshes a Julia set: the whole pipeline of `qjulia mesh`, in-process.

    params:     a dict shaped like a parameter file, or the path of one or of a mesh file
                qjulia wrote (its recorded parameters; not with preset)
    preset:     a built-in preset's name (presets()); neither: newton-cubic
    overrides:  top-level keys of the parameter file (see the module's docstring)
    progress:   callable(stage, fraction), called on this thread about every 50 ms while the
                work advances; returning False cancels (Cancelled)
    cancel:     a CancelToken; request() from any thread cancels (Cancelled)
    vdb:        keep the sampled grid, so that save("grid.vdb") works
    dense:      evaluate every grid point (the validation path of --dense)
    max_memory: the memory the run may use, bytes (at least 1M) or "4G"; a run that the memory
                estimate says needs more raises MemoryError before the work

    Returns a Mesh: .vertices, .faces, .normals, .colors (numpy views), .stats (the --stats
    dict), .params, .save(path). An empty solid gives a mesh with no faces (stats faces 0).
    """
    text = _params_json(params, preset, overrides)
    return _core.run_mesh(text, progress=progress, cancel=cancel, dense=dense, vdb=vdb,
                          max_memory=_memory_bytes(max_memory))


def load(path):
    """Reads a mesh file (.glb .gltf .obj .ply .stl .3mf) with the parameters it records."""
    return _core.read_mesh(os.fspath(path))


def _as_mesh(value, name):
    """(Mesh, label): a Mesh as it is, a path read, a (vertices, faces) pair made a Mesh."""
    if isinstance(value, Mesh):
        return value, name
    if isinstance(value, (str, os.PathLike)):
        return load(value), os.fspath(value)
    if isinstance(value, tuple) and len(value) == 2:
        return Mesh(*value), name
    raise TypeError(f"{name}: expected a qjulia.Mesh, a (vertices, faces) pair of arrays or the "
                    f"path of a mesh file, not {type(value).__name__}")


def compare(a, b, *, samples=None, seed=None, progress=None, cancel=None):
    """Compares two surfaces (Mesh, (vertices, faces) arrays, or mesh file paths): the dict of
    `qjulia compare A B --json` (measures of each, distances both ways, Hausdorff distance).

    samples: surface samples per surface (every vertex, then random points up to this many)
    seed:    of the random samples (the same meshes and seed give the same result)
    """
    for name, value in (("samples", samples), ("seed", seed)):
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise TypeError(f"{name} must be an integer, not {type(value).__name__}")
        if value < 0 or value > (_MOST_SAMPLES if name == "samples" else 2**64 - 1):
            raise ValueError(f"{name}: expected an integer in 0.."
                             f"{_MOST_SAMPLES if name == 'samples' else 2**64 - 1}, not {value}")
    mesh_a, name_a = _as_mesh(a, "a")
    mesh_b, name_b = _as_mesh(b, "b")
    text = _core.compare(mesh_a, mesh_b, name_a=name_a, name_b=name_b,
                         samples=None if samples is None else int(samples),
                         seed=None if seed is None else int(seed), progress=progress,
                         cancel=cancel)
    return json.loads(text)


def render(mesh, **options):
    """Draws a mesh (as for compare()) as `qjulia render` does: an H x W x 3 uint8 array.

    options (the library's defaults where absent): width, height, shading ("simple",
    "lambert", "phong"), lights (directions towards them), ambient, specular, shininess,
    rotate (degrees about X, Y, Z), background (0..255 RGB), color (linear RGB where the mesh
    has no colours), vertex_colors, framing ("box", "sphere"), margin, supersample.
    """
    return _core.render(_as_mesh(mesh, "mesh")[0], **options)
