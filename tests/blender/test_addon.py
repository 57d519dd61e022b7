"""Headless test of the Blender add-on, run by ctest:

    blender -b --factory-startup --python-exit-code 1 --python tests/blender/test_addon.py -- \
        --module-path build/python --cli build/bin/qjulia

Enables the add-on from blender/, makes newton-cubic and classic-julia at small resolutions and
checks the objects against `qjulia mesh --stats` for the same parameters: vertex, face and edge
counts, watertight (bmesh), the colour attribute and the material that shows it; then
Regenerate, the size in millimetres, the parameters kept in a saved .blend, and the
cancellation of the worker job behind the modal operators.
"""

import atexit
import json
import os
import shutil
import sys
import time

import bmesh
import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from addon_setup import TMP, build, cli_stats, qjulia  # noqa: E402  (enables the add-on)

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


# Add > Mesh > Quaternion Julia, for both methods.
for preset, resolution in (("newton-cubic", 32), ("classic-julia", 48)):
    assert bpy.ops.mesh.qjulia_add(preset=preset, resolution=resolution) == {'FINISHED'}
    obj = bpy.context.active_object
    assert obj.qjulia.made and obj.qjulia.preset == preset
    assert obj.qjulia.resolution == resolution
    assert obj.qjulia.params_json and json.loads(obj.qjulia.params_json)["resolution"] == resolution
    check_object(obj, cli_stats("--preset", preset, "--resolution", resolution,
                                "--color", "iterations"))
    print(f"add {preset} at {resolution}: {obj.qjulia.summary}")

# Regenerate the active object (classic-julia) at another resolution and iteration count.
julia = bpy.context.active_object
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
