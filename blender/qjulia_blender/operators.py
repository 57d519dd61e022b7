"""Add > Mesh > Quaternion Julia and Regenerate: modal operators that mesh on a worker thread
with the progress in the status bar (Esc cancels); execute() meshes at once (scripts,
background mode)."""

import json

import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty, StringProperty

from . import build, params


class _Meshing:
    """The modal part both operators share: run a MeshJob, show its progress, Esc cancels."""

    _job = None
    _timer = None

    def run_modal(self, context, parameters):
        self._job = build.MeshJob(build.load_qjulia(), parameters).start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        self._show(context)
        return {'RUNNING_MODAL'}

    def _show(self, context):
        job = self._job
        text = f"qjulia: {job.stage or 'starting'} {job.fraction:.0%}"
        if job.token.requested:
            text += "  (cancelling)"
        context.workspace.status_text_set(text + "   Esc: cancel")

    def modal(self, context, event):
        if event.type == 'ESC' and event.value == 'PRESS':
            self._job.cancel()
            self._show(context)
            return {'RUNNING_MODAL'}
        if event.type == 'TIMER' and self._job.done:
            context.window_manager.event_timer_remove(self._timer)
            context.workspace.status_text_set(None)
            return self.finish(context, self._job.result, self._job.error)
        if event.type == 'TIMER':
            self._show(context)
        return {'PASS_THROUGH'}  # the interface stays live while the mesh is made

    def mesh_now(self, context, parameters):
        qjulia = build.load_qjulia()
        try:
            return self.finish(context, qjulia.mesh(parameters), None)
        except Exception as e:  # reported like the errors of the modal run
            return self.finish(context, None, e)

    def finish(self, context, result, error):
        """Reports `error` or an empty solid; otherwise calls self.use(context, result)."""
        if error is not None:
            if type(error).__name__ == "Cancelled":
                self.report({'INFO'}, "qjulia: cancelled")
            else:
                self.report({'ERROR'}, f"qjulia: {error}")
            return {'CANCELLED'}
        if result.stats["faces"] == 0:
            self.report({'WARNING'}, "qjulia: the solid is empty with these parameters (check "
                                     "the bailout, the iterations and the bounds)")
            return {'CANCELLED'}
        obj = self.use(context, result)
        if obj is None:
            self.report({'WARNING'}, "qjulia: the object was removed while its mesh was made")
            return {'CANCELLED'}
        obj.qjulia.made = True
        params.from_params(obj.qjulia, result.params)
        obj.qjulia.summary = build.summary(result.stats)
        if result.unit == "mm":
            build.use_millimetres(context.scene)
        self.report({'INFO'}, f"qjulia: {obj.name}: {obj.qjulia.summary}")
        return {'FINISHED'}


class QJULIA_OT_add(_Meshing, bpy.types.Operator):
    """Add a mesh of a quaternionic Julia set"""
    bl_idname = "mesh.qjulia_add"
    bl_label = "Quaternion Julia"
    bl_options = {'UNDO'}

    preset: StringProperty(name="Preset", default="newton-cubic",
                           description="A built-in preset (qjulia presets)")
    params_json: StringProperty(name="Parameter File",
                                description="A whole parameter file (JSON) instead of the preset")
    resolution: IntProperty(name="Resolution", min=2, max=4096, default=96,
                            description="Voxels along the longest side of the box")
    color: EnumProperty(name="Colouring", items=params.COLORS, default="iterations")
    size_mm: FloatProperty(name="Size", min=0, default=0,
                           description="Longest side in millimetres (0: model units)")

    def parameters(self):
        qjulia = build.load_qjulia()
        base = json.loads(self.params_json) if self.params_json else qjulia.params(self.preset)
        p = dict(base, resolution=self.resolution)
        p["mesh"] = dict(base.get("mesh", {}), color=self.color)
        if self.size_mm > 0:
            p["print"] = dict(base.get("print", {}), size_mm=self.size_mm)
        return p

    def invoke(self, context, event):
        if context.window is None:  # no window (background): no modal run
            return self.execute(context)
        try:
            return self.run_modal(context, self.parameters())
        except (ImportError, ValueError) as e:
            self.report({'ERROR'}, f"qjulia: {e}")
            return {'CANCELLED'}

    def execute(self, context):
        try:
            parameters = self.parameters()
        except (ImportError, ValueError) as e:
            self.report({'ERROR'}, f"qjulia: {e}")
            return {'CANCELLED'}
        return self.mesh_now(context, parameters)

    def use(self, context, result):
        name = self.preset if not self.params_json else "qjulia"
        obj = bpy.data.objects.new(name, build.mesh_data(name, result))
        if result.colors is not None:
            obj.data.materials.append(build.color_material())
        context.collection.objects.link(obj)
        obj.location = context.scene.cursor.location
        for other in context.selected_objects:
            other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        obj.qjulia.preset = name
        return obj


class QJULIA_OT_regenerate(_Meshing, bpy.types.Operator):
    """Make the mesh of the active qjulia object again from the parameters on it"""
    bl_idname = "object.qjulia_regenerate"
    bl_label = "Regenerate"
    bl_options = {'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and obj.type == 'MESH' and obj.qjulia.made

    def invoke(self, context, event):
        if context.window is None:
            return self.execute(context)
        try:
            parameters = params.to_params(context.active_object.qjulia)
            self._target = context.active_object.name
            return self.run_modal(context, parameters)
        except (ImportError, ValueError) as e:
            self.report({'ERROR'}, f"qjulia: {e}")
            return {'CANCELLED'}

    def execute(self, context):
        try:
            parameters = params.to_params(context.active_object.qjulia)
        except ValueError as e:
            self.report({'ERROR'}, f"qjulia: {e}")
            return {'CANCELLED'}
        self._target = context.active_object.name
        return self.mesh_now(context, parameters)

    def use(self, context, result):
        obj = bpy.data.objects.get(self._target)
        if obj is not None:
            build.set_data(obj, result)
        return obj


classes = (QJULIA_OT_add, QJULIA_OT_regenerate)
