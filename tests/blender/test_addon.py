"""Headless test of the Blender add-on, run by ctest:

    blender -b --factory-startup --python-exit-code 1 --python tests/blender/test_addon.py -- \
        --module-path build/python --cli build/bin/qjulia

Enables the add-on from blender/, makes newton-cubic and classic-julia at small resolutions and
checks the objects against `qjulia mesh --stats` for the same parameters: vertex, face and edge
counts, watertight (bmesh), the colour attribute and the material that shows it; then Add with
fields that differ from the preset (stored on the object), the preset refilling the fields, bad
fields refused as Regenerate refuses them, Regenerate, the size in millimetres, the parameters
kept in a saved .blend, and the cancellation of the worker job behind the modal operators.
"""

import atexit
import json
import os
import shutil
import struct
import sys
import time
import types

import bmesh
import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from addon_setup import TMP, build, cli_stats, qjulia  # noqa: E402  (enables the add-on)
from qjulia_blender import operators, params  # noqa: E402

atexit.register(shutil.rmtree, TMP, True)


def check_object(obj, stats, colored=True):
    me = obj.data
    name = f"{obj.name} ({obj.qjulia.preset} at {obj.qjulia.resolution})"
    assert len(me.vertices) == stats["vertices"], (name, len(me.vertices), stats["vertices"])
    assert len(me.polygons) == stats["faces"], (name, len(me.polygons), stats["faces"])
    assert len(me.edges) == stats["edges"], (name, len(me.edges), stats["edges"])
    assert all(p.loop_total == 3 for p in me.polygons)
    bm = bmesh.new()
    bm.from_mesh(me)
    try:
        assert all(len(e.link_faces) == 2 and e.is_manifold for e in bm.edges), \
            f"{name}: an edge without exactly two faces"
        assert not any(e.is_boundary for e in bm.edges), f"{name}: open"
        assert all(v.is_manifold for v in bm.verts), f"{name}: a non-manifold vertex"
        assert len(bm.verts) - len(bm.edges) + len(bm.faces) == stats["euler"]
    finally:
        bm.free()
    attribute = me.color_attributes.get(build.COLOR_ATTRIBUTE)
    if not colored:
        assert attribute is None and not me.materials
        return
    assert attribute is not None, f"{name}: no colour attribute"
    assert attribute.domain == 'POINT' and attribute.data_type == 'FLOAT_COLOR'
    assert len(attribute.data) == len(me.vertices)
    colours = {tuple(round(c, 4) for c in d.color[:3]) for d in attribute.data}
    assert len(colours) > 1, f"{name}: one colour only"
    mat = obj.active_material
    assert mat is not None and mat.use_nodes, f"{name}: no material"
    node = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeVertexColor")
    assert node.layer_name == attribute.name
    assert any(link.from_node == node and link.to_socket.name == "Base Color"
               for link in mat.node_tree.links), "the colour attribute is not the base colour"


# Add > Mesh > Quaternion Julia, for both methods and for bounds that single precision does
# not hold exactly (-2.1): the object stores the preset's parameter file exactly.
for preset, resolution in (("newton-cubic", 32), ("classic-julia", 48),
                           ("quaternion-mandelbrot", 36)):
    assert bpy.ops.mesh.qjulia_add(preset=preset, resolution=resolution) == {'FINISHED'}
    obj = bpy.context.active_object
    assert obj.qjulia.made and obj.qjulia.preset == preset
    assert obj.qjulia.resolution == resolution
    assert json.loads(obj.qjulia.params_json) == \
        qjulia.params(preset, resolution=resolution, mesh={"color": "iterations"})
    check_object(obj, cli_stats("--preset", preset, "--resolution", resolution,
                                "--color", "iterations"))
    print(f"add {preset} at {resolution}: {obj.qjulia.summary}")

# The Add operator offers every field of the object's panel, with one definition: the same
# names, ranges and defaults.
add_rna = bpy.ops.mesh.qjulia_add.get_rna_type().properties
object_rna = bpy.types.Object.bl_rna.properties["qjulia"].fixed_type.properties
for name in params.FIELDS:
    a, o = add_rna[name], object_rna[name]
    assert (a.type, a.name, a.description) == (o.type, o.name, o.description), name
    for key in ("hard_min", "hard_max", "default", "length", "enum_items"):
        if hasattr(o, key):
            assert (key == "enum_items" and [i.identifier for i in getattr(a, key)] ==
                    [i.identifier for i in getattr(o, key)]) or \
                getattr(a, key) == getattr(o, key), (name, key)
assert [item[0] for item in operators.preset_items(None, bpy.context)] == list(qjulia.presets())


def check_stored(obj, **fields):
    """The fields on the object equal `fields` and the whole parameter file stored with them
    (which Regenerate starts from) holds the same values exactly: where a field shows a preset's
    number in single precision, the file keeps the preset's (bailout 0.01, not 0.0099999998)."""
    p = obj.qjulia
    exact = types.SimpleNamespace()
    params.fill(exact, json.loads(p.params_json))
    for name, value in fields.items():
        got = getattr(exact if name in params.FIELDS else p, name)
        got = tuple(got) if name.startswith("bounds") else got
        assert got == value, (name, got, value)
    for name in params.FIELDS:
        shown, stored = getattr(p, name), getattr(exact, name)
        if isinstance(stored, float):
            assert shown == struct.unpack("f", struct.pack("f", stored))[0], (name, shown)
        elif name.startswith("bounds"):
            assert tuple(shown) == tuple(struct.unpack("3f", struct.pack("3f", *stored))), name
        else:
            assert shown == stored, (name, shown, stored)


# Add with fields that differ from the preset (values exact in float32, as Blender keeps them):
# the mesh is that of the CLI with the same flags, and the fields are stored on the object.
typed = dict(formula="h^3+c", constants="c = -0.5, 0.375, 0, 0", iterations=7, bailout=3.0,
             bounds_min=(-1.375, -1.25, -1.125), bounds_max=(1.25, 1.375, 1.5), axes="rmp",
             fixed=0.125)
assert bpy.ops.mesh.qjulia_add(preset="classic-julia", resolution=40, **typed) == {'FINISHED'}
obj = bpy.context.active_object
typed_flags = ("--formula", "h^3+c", "--const", "c=-0.5,0.375,0,0", "--iterations", 7,
               "--bailout", 3, "--bounds=-1.375,-1.25,-1.125,1.25,1.375,1.5", "--axes", "rmp",
               "--fixed", 0.125)
check_object(obj, cli_stats("--preset", "classic-julia", *typed_flags, "--resolution", 40,
                            "--color", "iterations"))
check_stored(obj, preset="classic-julia", resolution=40, mode="julia", method="escape", **typed)
print(f"add with typed fields: {obj.qjulia.summary}")
# Regenerate keeps them (at another resolution).
obj.qjulia.resolution = 32
assert bpy.ops.object.qjulia_regenerate() == {'FINISHED'}
check_object(obj, cli_stats("--preset", "classic-julia", *typed_flags, "--resolution", 32,
                            "--color", "iterations"))
check_stored(obj, resolution=32, **typed)

# Method, bailout, iterations and bounds of newton-cubic changed; the Mandelbrot mode of
# classic-julia.
changed = dict(method="escape", bailout=2.0, iterations=9, bounds_min=(-1.75, -1.75, -1.5),
               bounds_max=(1.75, 1.75, 1.5))
assert bpy.ops.mesh.qjulia_add(preset="newton-cubic", resolution=36, color="none",
                               **changed) == {'FINISHED'}
obj = bpy.context.active_object
check_object(obj, cli_stats("--preset", "newton-cubic", "--method", "escape", "--bailout", 2,
                            "--iterations", 9, "--bounds=-1.75,-1.75,-1.5,1.75,1.75,1.5",
                            "--resolution", 36), colored=False)
check_stored(obj, preset="newton-cubic", formula="(2*h^3+1)/(3*h^2)", constants="",
             color="none", **changed)
mandelbrot = dict(mode="mandelbrot", bounds_min=(-2.125, -1.25, -1.25),
                  bounds_max=(0.75, 1.25, 1.25))
assert bpy.ops.mesh.qjulia_add(preset="classic-julia", resolution=36, **mandelbrot) == \
    {'FINISHED'}
obj = bpy.context.active_object
check_object(obj, cli_stats("--preset", "classic-julia", "--mode", "mandelbrot",
                            "--bounds=-2.125,-1.25,-1.25,0.75,1.25,1.25", "--resolution", 36,
                            "--color", "iterations"))
check_stored(obj, iterations=10, bailout=4.0, **mandelbrot)

# What the options panel (Adjust Last Operation) does: Blender calls execute() again with the
# changed options; `source` is the preset the fields were filled from. Another preset refills
# every field it sets; a field edited under the same preset is kept.
assert bpy.ops.mesh.qjulia_add(preset="newton-cubic", source="classic-julia", resolution=32,
                               formula="h^2+c", iterations=5, bailout=3.0) == {'FINISHED'}
obj = bpy.context.active_object
check_stored(obj, preset="newton-cubic", formula="(2*h^3+1)/(3*h^2)", iterations=12,
             bailout=0.01, method="cutoff", bounds_min=(-2, -2, -2))
check_object(obj, cli_stats("--preset", "newton-cubic", "--resolution", 32, "--color",
                            "iterations"))
assert bpy.ops.mesh.qjulia_add(preset="classic-julia", source="classic-julia", resolution=32,
                               formula="h^2+c", constants="c = -0.2, 0.8, 0, 0", iterations=5,
                               method="escape", bailout=4.0, bounds_min=(-1.5, -1.5, -1.5),
                               bounds_max=(1.5, 1.5, 1.5)) == {'FINISHED'}
obj = bpy.context.active_object
check_stored(obj, preset="classic-julia", iterations=5)
check_object(obj, cli_stats("--preset", "classic-julia", "--iterations", 5, "--resolution", 32,
                            "--color", "iterations"))

# A parameter file instead of the preset fills the fields as a preset does.
path = os.path.join(TMP, "params.json")
with open(path, "w") as f:
    json.dump({"formula": "h^2+c", "constants": {"c": [-0.125, 0.75, 0, 0]}, "method": "escape",
               "bailout": 4, "iterations": 8, "resolution": 32, "mesh": {"color": "iterations"},
               "bounds": {"min": [-1.5, -1.5, -1.5], "max": [1.5, 1.5, 1.5]}}, f)
with open(path) as f:
    assert bpy.ops.mesh.qjulia_add(params_json=f.read(), resolution=32) == {'FINISHED'}
obj = bpy.context.active_object
check_object(obj, cli_stats(path))
check_stored(obj, preset="qjulia", formula="h^2+c", constants="c = -0.125, 0.75, 0, 0",
             iterations=8)

# Bad fields are refused with the messages of the object's panel (Regenerate); no object is
# added and the object keeps its mesh.
objects, faces = len(bpy.data.objects), len(obj.data.polygons)
for fields, message in (({"constants": "c = 1, 2"},
                         "qjulia: constants: expected NAME = w, x, y, z (or NAME = real), not "
                         "'c = 1, 2'"),
                        ({"formula": "h^^2"}, "formula 1:3: expected a literal real exponent"),
                        ({"bounds_min": (3, 0, 0)}, "'bounds' min must be < max")):
    errors = []
    for run in ("add", "regenerate"):
        try:
            if run == "add":
                bpy.ops.mesh.qjulia_add(preset="classic-julia", resolution=16, **fields)
            else:
                saved = {name: getattr(obj.qjulia, name) for name in fields}
                for name, value in fields.items():
                    setattr(obj.qjulia, name, value)
                try:
                    bpy.ops.object.qjulia_regenerate()
                finally:
                    for name, value in saved.items():
                        setattr(obj.qjulia, name, value)
            raise AssertionError(f"{run}: {fields} was not refused")
        except RuntimeError as e:
            assert message in str(e), e
            errors.append(str(e))
    assert errors[0] == errors[1], errors
    print(f"refused {fields}: {errors[0].strip()}")
assert len(bpy.data.objects) == objects and len(obj.data.polygons) == faces

# Regenerate classic-julia at another resolution and iteration count.
julia = bpy.data.objects["classic-julia"]
bpy.context.view_layer.objects.active = julia
meshes = len(bpy.data.meshes)
julia.qjulia.resolution = 40
julia.qjulia.iterations = 8
assert bpy.ops.object.qjulia_regenerate() == {'FINISHED'}
check_object(julia, cli_stats("--preset", "classic-julia", "--resolution", 40, "--iterations", 8,
                              "--color", "iterations"))
julia.qjulia.color = 'none'
assert bpy.ops.object.qjulia_regenerate() == {'FINISHED'}
check_object(julia, cli_stats("--preset", "classic-julia", "--resolution", 40, "--iterations", 8),
             colored=False)
assert len(bpy.data.meshes) == meshes, "the replaced meshes are left behind"
print(f"regenerate: {julia.qjulia.summary}")

# A size in millimetres sets the object's dimensions with the scene's units in millimetres.
assert bpy.ops.mesh.qjulia_add(preset="classic-julia", resolution=28, size_mm=80) == {'FINISHED'}
sized = bpy.context.active_object
assert abs(max(sized.dimensions) - 80) < 1e-3, tuple(sized.dimensions)
units = bpy.context.scene.unit_settings
assert units.length_unit == 'MILLIMETERS' and abs(units.scale_length - 0.001) < 1e-9  # float32
check_object(sized, cli_stats("--preset", "classic-julia", "--resolution", 28, "--size", "80mm",
                              "--color", "iterations"))

# Bad parameters are reported as an error (which bpy.ops raises in a script), with the CLI's
# message; the object keeps its mesh.
julia.qjulia.formula = "h^^2"
bpy.context.view_layer.objects.active = julia
faces = len(julia.data.polygons)
try:
    bpy.ops.object.qjulia_regenerate()
    raise AssertionError("a bad formula was not reported")
except RuntimeError as e:
    assert "formula 1:3: expected a literal real exponent" in str(e), e
assert len(julia.data.polygons) == faces
julia.qjulia.formula = "h^2+c"

# The parameters live on the object: saved with the .blend and Regenerate works after loading.
path = os.path.join(TMP, "scene.blend")
name = julia.name
bpy.ops.wm.save_as_mainfile(filepath=path)
bpy.ops.wm.open_mainfile(filepath=path)
julia = bpy.data.objects[name]
assert julia.qjulia.made and julia.qjulia.resolution == 40 and julia.qjulia.iterations == 8
bpy.context.view_layer.objects.active = julia
julia.qjulia.resolution = 32
assert bpy.ops.object.qjulia_regenerate() == {'FINISHED'}
check_object(julia, cli_stats("--preset", "classic-julia", "--resolution", 32, "--iterations", 8),
             colored=False)

# The job behind the modal operators: progress from the worker thread; cancel() stops it. (The
# library stops within 0.1 to 0.2 s mostly, but took up to 2.4 s under heavy load just after
# sampling began, docs/python.md; uncancelled, this job runs for tens of seconds.)
job = build.MeshJob(qjulia, qjulia.params("newton-cubic", resolution=512)).start()
deadline = time.monotonic() + 10
while not job.stage and time.monotonic() < deadline:
    time.sleep(0.02)
# The first stages: the memory estimate, then sampling.
assert job.stage in ("estimate", "sample") and not job.done, (job.stage, job.done)
cancelled = time.monotonic()
job.cancel()
assert job.wait(timeout=5)
assert isinstance(job.error, qjulia.Cancelled) and job.result is None, job.error
print(f"job cancelled after {time.monotonic() - cancelled:.2f} s")
assert time.monotonic() - cancelled < 5

print("qjulia Blender add-on: all checks passed")
