"""The parameters of a qjulia object, stored on the object (Object.qjulia), so that it can be
made again at another resolution or iteration count (Regenerate)."""

import json

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


def format_constants(constants):
    """{"c": [w, x, y, z]} as "c = w, x, y, z; ..." (the text field of the panel)."""
    return "; ".join(f"{name} = " + ", ".join(f"{v:g}" for v in value)
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
    made: BoolProperty(name="Made by qjulia", default=False)
    preset: StringProperty(name="Preset", description="The preset it was made from")
    formula: StringProperty(name="Formula", description="e.g. h^2+c, (2*h^3+1)/(3*h^2)")
    constants: StringProperty(
        name="Constants", description="Quaternion constants: NAME = w, x, y, z; ...")
    mode: EnumProperty(name="Mode", items=MODES, default="julia")
    method: EnumProperty(name="Method", items=METHODS, default="cutoff")
    iterations: IntProperty(name="Iterations", description="N", min=1, max=100000,
                            soft_max=200, default=12)
    bailout: FloatProperty(name="Bailout", description="R: bailout radius or cut-off rate",
                           min=1e-9, default=0.01, precision=4)
    resolution: IntProperty(name="Resolution",
                            description="Voxels along the longest side of the box",
                            min=2, max=4096, soft_min=16, soft_max=512, default=96)
    bounds_min: FloatVectorProperty(name="Bounds Min", size=3, default=(-2, -2, -2))
    bounds_max: FloatVectorProperty(name="Bounds Max", size=3, default=(2, 2, 2))
    axes: StringProperty(
        name="Slice Axes", default="rmn", maxlen=3,
        description="The quaternion components of x, y, z (three of r m n p); empty: the "
                    "general slice of the parameter file")
    fixed: FloatProperty(name="Fixed", description="The value of the fourth component")
    color: EnumProperty(name="Colouring", items=COLORS, default="iterations")
    size_mm: FloatProperty(
        name="Size", description="Longest side in millimetres (0: model units); sets the "
                                 "scene's units to millimetres", min=0, default=0,
        precision=1)
    params_json: StringProperty(
        name="Parameter File", options={'HIDDEN'},
        description="The whole parameter file of the last mesh (JSON)")
    summary: StringProperty(name="Mesh", options={'HIDDEN'})


def to_params(props):
    """The parameter file (a dict) of `props`: the stored file with the panel's fields over it."""
    params = json.loads(props.params_json) if props.params_json else {}
    params.update(formula=props.formula, constants=parse_constants(props.constants),
                  mode=props.mode, method=props.method, iterations=props.iterations,
                  bailout=props.bailout, resolution=props.resolution,
                  bounds={"min": list(props.bounds_min), "max": list(props.bounds_max)})
    if props.axes:
        params["slice"] = {"axes": props.axes, "fixed": props.fixed}
    params["mesh"] = dict(params.get("mesh", {}), color=props.color)
    printing = dict(params.get("print", {}))
    printing.pop("size_mm", None)
    if props.size_mm > 0:
        printing["size_mm"] = props.size_mm
    params["print"] = printing
    return params


def from_params(props, params, preset=None):
    """Fills `props` from a complete parameter file (qjulia.params(), Mesh.params)."""
    if preset is not None:
        props.preset = preset
    props.formula = params["formula"]
    props.constants = format_constants(params["constants"])
    props.mode = params["mode"]
    props.method = params["method"]
    props.iterations = params["iterations"]
    props.bailout = params["bailout"]
    props.resolution = params["resolution"]
    props.bounds_min = params["bounds"]["min"]
    props.bounds_max = params["bounds"]["max"]
    props.axes = params["slice"].get("axes", "")
    props.fixed = params["slice"].get("fixed", 0.0)
    props.color = params["mesh"]["color"]
    props.size_mm = params["print"].get("size_mm") or 0.0
    props.params_json = json.dumps(params)


def register():
    bpy.utils.register_class(QJuliaParams)
    bpy.types.Object.qjulia = bpy.props.PointerProperty(type=QJuliaParams)


def unregister():
    del bpy.types.Object.qjulia
    bpy.utils.unregister_class(QJuliaParams)
