"""The parameters of a qjulia mesh as Blender properties: defined once (fields()) for the
object (Object.qjulia, where Regenerate makes the mesh again at another resolution or iteration
count) and for the Add operator's options, with one conversion to and from a parameter file
and one layout."""

import json
import struct

import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty,
                       IntProperty, StringProperty)

MODES = [
    ("julia", "Julia", "h0 is the sampled point; the constants are fixed"),
    ("mandelbrot", "Mandelbrot", "The sampled point is the constant c; h0 is the start"),
]
METHODS = [
    ("escape", "Escape", "In the solid when |h_k| <= R for every k (filled-in Julia sets)"),
    ("cutoff", "Cut-off", "In the solid when |h_k - h_(k-1)| >= R for every k (A. Rosa: also "
     "rational maps such as Newton's)"),
]
COLORS = [
    ("iterations", "Iterations", "Vertex colours by the iteration count of the orbit"),
    ("basin", "Basin", "Vertex colours by the attractor the orbit goes to"),
    ("none", "None", "No vertex colours"),
]

# The fields a preset (or a parameter file) sets, in the panels' order ...
PRESET_FIELDS = ("formula", "constants", "mode", "method", "iterations", "bailout",
                 "bounds_min", "bounds_max", "axes", "fixed")
# ... and all fields, in the panels' order.
FIELDS = ("formula", "constants", "mode", "method", "iterations", "bailout", "resolution",
          "bounds_min", "bounds_max", "axes", "fixed", "color", "size_mm")


def fields(options=None):
    """The bpy properties of FIELDS (annotations for a PropertyGroup or an Operator): one
    definition, so the object's panel and the Add operator offer the same ranges. `options`:
    the properties' options (the operator's are {'SKIP_SAVE'}: each Add starts afresh)."""
    o = {} if options is None else {"options": set(options)}
    return {
        "formula": StringProperty(name="Formula", description="e.g. h^2+c, (2*h^3+1)/(3*h^2)",
                                  **o),
        "constants": StringProperty(
            name="Constants", description="Quaternion constants: NAME = w, x, y, z; ...", **o),
        "mode": EnumProperty(name="Mode", items=MODES, default="julia", **o),
        "method": EnumProperty(name="Method", items=METHODS, default="cutoff", **o),
        "iterations": IntProperty(name="Iterations", description="N", min=1, max=100000,
                                  soft_max=200, default=12, **o),
        "bailout": FloatProperty(name="Bailout",
                                 description="R: bailout radius or cut-off rate",
                                 min=1e-9, default=0.01, precision=4, **o),
        "resolution": IntProperty(name="Resolution",
                                  description="Voxels along the longest side of the box",
                                  min=2, max=4096, soft_min=16, soft_max=512, default=96, **o),
        "bounds_min": FloatVectorProperty(name="Bounds Min", size=3, default=(-2, -2, -2), **o),
        "bounds_max": FloatVectorProperty(name="Bounds Max", size=3, default=(2, 2, 2), **o),
        "axes": StringProperty(
            name="Slice Axes", default="rmn", maxlen=3,
            description="The quaternion components of x, y, z (three of r m n p); empty: the "
                        "general slice of the parameter file", **o),
        "fixed": FloatProperty(name="Fixed", description="The value of the fourth component",
                               **o),
        "color": EnumProperty(name="Colouring", items=COLORS, default="iterations", **o),
        "size_mm": FloatProperty(
            name="Size", description="Longest side in millimetres (0: model units); sets the "
                                     "scene's units to millimetres", min=0, default=0,
            precision=1, **o),
    }


def draw_fields(layout, props):
    """The fields of `props` (the object's parameters or the Add operator), in FIELDS' order."""
    layout.use_property_split = True
    for name in FIELDS:
        layout.prop(props, name)


def _number(v):
    """The shortest text that reads back as the same float ("0" rather than "0.0")."""
    text = repr(float(v))
    return text[:-2] if text.endswith(".0") else text


def format_constants(constants):
    """{"c": [w, x, y, z]} as "c = w, x, y, z; ..." (the text field of the panel); it reads
    back as the same numbers."""
    return "; ".join(f"{name} = " + ", ".join(_number(v) for v in value)
                     for name, value in constants.items())


def parse_constants(text):
    """The inverse of format_constants(); a real number alone is the quaternion (r, 0, 0, 0).
    Raises ValueError naming the part that is not NAME = w, x, y, z."""
    constants = {}
    for part in filter(None, (p.strip() for p in text.split(";"))):
        name, sep, values = part.partition("=")
        try:
            numbers = [float(v) for v in values.split(",")]
        except ValueError:
            numbers = []
        if not sep or not name.strip() or len(numbers) not in (1, 4):
            raise ValueError(f"constants: expected NAME = w, x, y, z (or NAME = real), "
                             f"not '{part}'")
        constants[name.strip()] = numbers if len(numbers) == 4 else [numbers[0], 0, 0, 0]
    return constants


class QJuliaParams(bpy.types.PropertyGroup):
    __annotations__ = {
        "made": BoolProperty(name="Made by qjulia", default=False),
        "preset": StringProperty(name="Preset", description="The preset it was made from"),
        **fields(),
        "params_json": StringProperty(
            name="Parameter File", options={'HIDDEN'},
            description="The whole parameter file of the last mesh (JSON)"),
        "summary": StringProperty(name="Mesh", options={'HIDDEN'}),
    }


def _single(x):
    """x rounded to single precision, as a FloatProperty keeps it."""
    return struct.unpack("f", struct.pack("f", x))[0]


def _kept(shown, exact):
    """The parameter file's number `exact` where the field still shows it (in single
    precision), else the field's value: an unchanged field keeps the file's value exactly
    (0.01, not 0.009999999776), so the mesh is the one `qjulia mesh` makes of the file."""
    try:
        return exact if _single(exact) == shown else shown
    except (TypeError, OverflowError, struct.error):
        return shown


def to_params(props, base=None):
    """The parameter file (a dict) of the fields of `props` over `base` (default: the file
    stored on the object, props.params_json). Raises ValueError for bad constants."""
    if base is None:
        base = json.loads(props.params_json) if props.params_json else {}
    params = dict(base)
    bounds = base.get("bounds") or {}
    params.update(formula=props.formula, constants=parse_constants(props.constants),
                  mode=props.mode, method=props.method, iterations=props.iterations,
                  bailout=_kept(props.bailout, base.get("bailout")),
                  resolution=props.resolution,
                  bounds={end: [_kept(v, exact) for v, exact in
                                zip(getattr(props, "bounds_" + end), bounds.get(end) or [None] * 3)]
                          for end in ("min", "max")})
    if props.axes:
        fixed = _kept(props.fixed, (base.get("slice") or {}).get("fixed"))
        params["slice"] = {"axes": props.axes, "fixed": fixed}
    params["mesh"] = dict(params.get("mesh", {}), color=props.color)
    printing = dict(params.get("print", {}))
    size_mm = _kept(props.size_mm, printing.pop("size_mm", None))
    if props.size_mm > 0:
        printing["size_mm"] = size_mm
    params["print"] = printing
    return params


def fill(props, params, names=FIELDS):
    """Sets the fields `names` of `props` from a complete parameter file (qjulia.params(),
    Mesh.params)."""
    values = {
        "formula": params["formula"],
        "constants": format_constants(params["constants"]),
        "mode": params["mode"],
        "method": params["method"],
        "iterations": params["iterations"],
        "bailout": params["bailout"],
        "resolution": params["resolution"],
        "bounds_min": params["bounds"]["min"],
        "bounds_max": params["bounds"]["max"],
        "axes": params["slice"].get("axes", ""),
        "fixed": params["slice"].get("fixed", 0.0),
        "color": params["mesh"]["color"],
        "size_mm": params["print"].get("size_mm") or 0.0,
    }
    for name in names:
        setattr(props, name, values[name])


def from_params(props, params, preset=None):
    """Stores a mesh's complete parameter file on the object: every field, and the whole file
    (for what the fields do not show: start, clip planes, decimation, a general slice)."""
    if preset is not None:
        props.preset = preset
    fill(props, params)
    props.params_json = json.dumps(params)


def register():
    bpy.utils.register_class(QJuliaParams)
    bpy.types.Object.qjulia = bpy.props.PointerProperty(type=QJuliaParams)


def unregister():
    del bpy.types.Object.qjulia
    bpy.utils.unregister_class(QJuliaParams)
