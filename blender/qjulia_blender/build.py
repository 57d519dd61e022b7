"""Finding the qjulia module, meshing on a worker thread, and turning its meshes into Blender
meshes with a colour attribute and a material that shows it."""

import os
import sys
import threading

import bpy
import numpy as np

COLOR_ATTRIBUTE = "qjulia_color"
MATERIAL = "qjulia colours"
# Written by scripts/install_blender_addon.sh: the directory that holds the package qjulia.
MODULE_PATH_FILE = os.path.join(os.path.dirname(__file__), "module_path.txt")


def module_dirs():
    """Where the package qjulia may be: the preference, then the directory recorded at install."""
    dirs = []
    addon = bpy.context.preferences.addons.get(__package__)
    if addon and addon.preferences and addon.preferences.module_path:
        dirs.append(bpy.path.abspath(addon.preferences.module_path))
    if os.path.isfile(MODULE_PATH_FILE):
        with open(MODULE_PATH_FILE) as f:
            dirs.append(f.read().strip())
    return dirs


def load_qjulia():
    """The qjulia module (built against /usr/bin/python3, whose ABI Blender's Python shares),
    from module_dirs() or else from sys.path. Raises ImportError saying how to install it."""
    if "qjulia" in sys.modules:
        return sys.modules["qjulia"]
    for d in module_dirs():
        if os.path.isfile(os.path.join(d, "qjulia", "__init__.py")):
            if d not in sys.path:
                sys.path.insert(0, d)
            break
    try:
        import qjulia
    except ImportError as e:
        raise ImportError(
            f"the qjulia Python module was not found ({e}; looked in "
            f"{module_dirs() or 'no directory'} and sys.path): build it (cmake --build build "
            "--target qjulia_python gives build/python) and set its directory in Preferences > "
            "Add-ons > Quaternion Julia, or run scripts/install_blender_addon.sh") from e
    return qjulia


class MeshJob:
    """qjulia.mesh(params) on a worker thread: the interface stays live, the thread holds the
    GIL only for moments. Poll done, stage and fraction; cancel() stops it within a second
    (error is then qjulia.Cancelled)."""

    def __init__(self, qjulia, params):
        self.token = qjulia.CancelToken()
        self.stage, self.fraction = "", 0.0
        self.result = self.error = None
        self._thread = threading.Thread(target=self._run, args=(qjulia, params), daemon=True)

    def start(self):
        self._thread.start()
        return self

    def _run(self, qjulia, params):
        try:
            self.result = qjulia.mesh(params, progress=self._progress, cancel=self.token)
        except BaseException as e:  # handed to the main thread, which reports it
            self.error = e

    def _progress(self, stage, fraction):
        self.stage, self.fraction = stage, fraction

    @property
    def done(self):
        return not self._thread.is_alive()

    def cancel(self):
        self.token.request()

    def wait(self, timeout=None):
        self._thread.join(timeout)
        return self.done


def mesh_data(name, m):
    """A Blender mesh of the qjulia.Mesh `m`: its vertices and triangles (smooth shaded) and,
    when it has colours, the point colour attribute COLOR_ATTRIBUTE (linear RGB)."""
    me = bpy.data.meshes.new(name)
    nv, nf = len(m.vertices), len(m.faces)
    me.vertices.add(nv)
    me.vertices.foreach_set("co", m.vertices.ravel())
    me.loops.add(3 * nf)
    me.loops.foreach_set("vertex_index", m.faces.ravel().astype(np.int32))
    me.polygons.add(nf)
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * nf, 3, dtype=np.int32))
    me.polygons.foreach_set("loop_total", np.full(nf, 3, np.int32))
    me.polygons.foreach_set("use_smooth", np.ones(nf, bool))
    me.update(calc_edges=True)
    if m.colors is not None:
        attribute = me.color_attributes.new(COLOR_ATTRIBUTE, 'FLOAT_COLOR', 'POINT')
        rgba = np.ones((nv, 4), np.float32)
        rgba[:, :3] = m.colors
        attribute.data.foreach_set("color", rgba.ravel())
        me.color_attributes.active_color = attribute
    return me


def color_material():
    """The material that shows COLOR_ATTRIBUTE (Color Attribute -> Principled Base Color), so
    the colours appear in Material Preview and in renders."""
    mat = bpy.data.materials.get(MATERIAL)
    if mat is None:
        mat = bpy.data.materials.new(MATERIAL)
        mat.use_nodes = True
        nodes = mat.node_tree.nodes
        bsdf = next(n for n in nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
        bsdf.inputs["Roughness"].default_value = 0.4
        attribute = nodes.new("ShaderNodeVertexColor")
        attribute.layer_name = COLOR_ATTRIBUTE
        attribute.location = (bsdf.location.x - 300, bsdf.location.y)
        mat.node_tree.links.new(attribute.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def set_data(obj, m):
    """Replaces the mesh of `obj` by `m` (keeping the mesh's name), with the colour material
    when `m` has colours."""
    old = obj.data
    name = old.name if old else obj.name
    obj.data = mesh_data(name, m)
    if old is not None and old.users == 0:
        bpy.data.meshes.remove(old)
        obj.data.name = name
    obj.data.materials.clear()
    if m.colors is not None:
        obj.data.materials.append(color_material())


def use_millimetres(scene):
    """Scene units: millimetres, one Blender unit = 1 mm (the mesh is in mm after size_mm)."""
    units = scene.unit_settings
    units.system = 'METRIC'
    units.length_unit = 'MILLIMETERS'
    units.scale_length = 0.001


def summary(stats):
    closed = "closed" if stats["closed"] else "OPEN"
    return (f"{stats['vertices']} vertices, {stats['faces']} faces, {closed}, "
            f"{stats['timings']['total']:.2f} s")
