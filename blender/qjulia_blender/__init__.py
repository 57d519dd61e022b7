"""Quaternion Julia: meshes of quaternionic Julia sets made in-process by the qjulia library.

Add > Mesh > Quaternion Julia offers the presets, and its options panel (F9) every parameter,
filled from the preset; the parameters live on the object (Properties > Object > Quaternion
Julia, the same fields), where Regenerate makes the mesh again. The compiled
module qjulia is found through the directory scripts/install_blender_addon.sh records, or the
add-on's preference. See docs/blender.md.
"""

bl_info = {
    "name": "Quaternion Julia (qjulia)",
    "author": "qjulia",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Add > Mesh > Quaternion Julia; Properties > Object > Quaternion Julia",
    "description": "Meshes quaternionic Julia sets (escape-time and cut-off methods) with qjulia",
    "category": "Add Mesh",
}

import bpy
from bpy.props import StringProperty

from . import build, operators, params


class QJuliaPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    module_path: StringProperty(
        name="qjulia Module Directory", subtype='DIR_PATH',
        description="The directory that holds the package qjulia (build/python of a qjulia "
                    "build); empty: the one recorded at install, else Python's path")

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "module_path")
        try:
            qjulia = build.load_qjulia()
            layout.label(text=f"qjulia {qjulia.__version__}: {qjulia.__file__}", icon='CHECKMARK')
        except ImportError as e:
            layout.label(text=str(e), icon='ERROR')


class QJULIA_MT_add(bpy.types.Menu):
    bl_idname = "QJULIA_MT_add"
    bl_label = "Quaternion Julia"

    def draw(self, context):
        layout = self.layout
        try:
            presets = build.load_qjulia().presets()
        except ImportError:
            layout.label(text="qjulia module not found: see the add-on's preferences",
                         icon='ERROR')
            return
        for name, description in presets.items():
            layout.operator(operators.QJULIA_OT_add.bl_idname, text=name).preset = name


class QJULIA_PT_object(bpy.types.Panel):
    bl_label = "Quaternion Julia"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.qjulia.made

    def draw(self, context):
        p = context.object.qjulia
        layout = self.layout
        layout.label(text=f"Preset: {p.preset}")
        params.draw_fields(layout, p)
        layout.operator(operators.QJULIA_OT_regenerate.bl_idname, icon='FILE_REFRESH')
        if p.summary:
            layout.label(text=p.summary)


def draw_add_menu(self, context):
    self.layout.menu(QJULIA_MT_add.bl_idname, icon='OUTLINER_OB_META')


classes = (QJuliaPreferences, *operators.classes, QJULIA_MT_add, QJULIA_PT_object)


def register():
    params.register()
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.VIEW3D_MT_mesh_add.append(draw_add_menu)


def unregister():
    bpy.types.VIEW3D_MT_mesh_add.remove(draw_add_menu)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
    params.unregister()
