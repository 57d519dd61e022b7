"""Renders a coloured qjulia mesh with Cycles, headless: the picture of README's Blender section.

    blender -b --factory-startup --python blender/render_gallery.py -- \
        --module-path build/python --out data/gallery/blender-newton-cubic.png

The mesh is made by the add-on (Add > Mesh > Quaternion Julia; newton-cubic, coloured by the
root each orbit goes to), so the picture shows what the add-on gives: the colour attribute
through its material.
"""

import argparse
import math
import os
import sys
import time

import addon_utils
import bpy
import numpy as np
from mathutils import Vector

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
parser = argparse.ArgumentParser()
parser.add_argument("--module-path", required=True)
parser.add_argument("--out", required=True)
parser.add_argument("--preset", default="newton-cubic")
parser.add_argument("--color", default="basin", choices=["iterations", "basin"])
parser.add_argument("--resolution", type=int, default=160)
parser.add_argument("--width", type=int, default=800)
parser.add_argument("--height", type=int, default=600)
parser.add_argument("--samples", type=int, default=128)
ARGS = parser.parse_args(sys.argv[sys.argv.index("--") + 1:])

sys.path.insert(0, os.path.join(ROOT, "blender"))
assert addon_utils.enable("qjulia_blender", default_set=True), "add-on not enabled"
bpy.context.preferences.addons["qjulia_blender"].preferences.module_path = ARGS.module_path

for obj in list(bpy.data.objects):  # the factory scene's cube, camera and light
    bpy.data.objects.remove(obj)
t0 = time.monotonic()
assert bpy.ops.mesh.qjulia_add(preset=ARGS.preset, resolution=ARGS.resolution,
                               color=ARGS.color) == {'FINISHED'}
julia = bpy.context.active_object
print(f"mesh: {julia.qjulia.summary} ({time.monotonic() - t0:.1f} s)")
# The view of README's gallery (`qjulia render --rotate -25,-35,0`): the camera looks down -z
# with y up, the mesh turned about x, then y.
julia.rotation_euler = (math.radians(-25), math.radians(-35), 0)
bpy.context.view_layer.update()
points = np.empty(3 * len(julia.data.vertices), np.float32)
julia.data.vertices.foreach_get("co", points)
points = points.reshape(-1, 3) @ np.array(julia.matrix_world.to_3x3()).T
lo, hi = points.min(axis=0), points.max(axis=0)
centre = Vector((lo + hi) / 2)
radius = float(np.linalg.norm(hi - lo) / 2)

scene = bpy.context.scene
scene.render.engine = 'CYCLES'
scene.cycles.device = 'CPU'
scene.cycles.samples = ARGS.samples
scene.cycles.use_denoising = False  # Debian builds Cycles without OpenImageDenoise
scene.render.resolution_x, scene.render.resolution_y = ARGS.width, ARGS.height
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = 'PNG'
scene.render.image_settings.color_mode = 'RGB'
scene.render.image_settings.compression = 100
scene.view_settings.view_transform = 'Standard'  # the colours as the attribute holds them
scene.render.film_transparent = False

world = bpy.data.worlds.new("qjulia world")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.9, 0.9, 0.92, 1)
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.4
scene.world = world

camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(camera)
scene.camera = camera
camera.data.lens = 60
# Far enough that the projected box fills the image with a margin.
tan_x = camera.data.sensor_width / 2 / camera.data.lens
tan_y = tan_x * ARGS.height / ARGS.width
distance = max((hi[0] - lo[0]) / 2 / tan_x, (hi[1] - lo[1]) / 2 / tan_y) * 1.1 + (hi[2] - lo[2]) / 2
camera.location = centre + Vector((0, 0, distance))

for name, direction, energy in (("key", (-0.6, 0.7, 0.9), 500), ("fill", (0.9, -0.3, 0.5), 150)):
    light = bpy.data.objects.new(name, bpy.data.lights.new(name, 'AREA'))
    light.data.energy, light.data.size = energy * (radius / 2) ** 2, radius
    light.location = centre + Vector(direction).normalized() * radius * 3
    light.rotation_euler = (centre - light.location).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(light)

scene.render.filepath = os.path.abspath(ARGS.out)
t0 = time.monotonic()
bpy.ops.render.render(write_still=True)
print(f"render: {ARGS.out} ({ARGS.width}x{ARGS.height}, {ARGS.samples} samples, "
      f"{time.monotonic() - t0:.1f} s)")
