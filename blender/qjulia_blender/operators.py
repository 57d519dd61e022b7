"""Add > Mesh > Quaternion Julia and Regenerate: modal operators that mesh on a worker thread
with the progress in the status bar (Esc cancels); execute() meshes at once (scripts,
background mode, and the Add operator's options panel, Adjust Last Operation)."""

import json

import bpy
from bpy.props import EnumProperty, StringProperty

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
        """Meshes on this thread (execute(): scripts, background mode and the options panel,
        whose changes Blender applies through execute()); the mouse cursor shows the progress."""
        qjulia = build.load_qjulia()
        wm = context.window_manager
        wm.progress_begin(0, 1)
        try:
            result = qjulia.mesh(parameters, progress=lambda stage, f: wm.progress_update(f))
        except Exception as e:  # reported like the errors of the modal run
            return self.finish(context, None, e)
        finally:
            wm.progress_end()
        return self.finish(context, result, None)

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


_preset_items = []  # Blender keeps no copy of a dynamic enum's strings: they live here


def preset_items(self, context):
    """The presets for the Add operator's menu, from the module (none while it is not found)."""
    if not _preset_items:
        try:
            presets = build.load_qjulia().presets()
        except ImportError:
            return []
        _preset_items.extend((name, name, description) for name, description in presets.items())
    return _preset_items


class QJULIA_OT_add(_Meshing, bpy.types.Operator):
    """Add a mesh of a quaternionic Julia set"""
    bl_idname = "mesh.qjulia_add"
    bl_label = "Quaternion Julia"
    bl_options = {'REGISTER', 'UNDO'}

    # The object's fields (params.fields()) and what they start from; SKIP_SAVE: each Add
    # starts from its preset, not from the values of the previous Add.
    __annotations__ = {
        "preset": EnumProperty(name="Preset", items=preset_items, options={'SKIP_SAVE'},
                               description="A built-in preset (qjulia presets): choosing one "
                                           "fills the fields below"),
        **params.fields(options={'SKIP_SAVE'}),
        "params_json": StringProperty(
            name="Parameter File", options={'SKIP_SAVE'},
            description="A whole parameter file (JSON) instead of the preset"),
        "source": StringProperty(
            name="Filled From", options={'HIDDEN', 'SKIP_SAVE'},
            description="The preset or parameter file the fields were last filled from"),
    }

    def parameters(self):
        """The parameter file to mesh: the fields over the preset (or the parameter file).
        The fields a preset sets are filled from it when it is chosen: on the first run those
        the caller did not give, when another preset is chosen in the options panel all of
        them; a field edited afterwards overrides the preset's value. Resolution, colouring
        and size are the operator's own."""
        qjulia = build.load_qjulia()
        if self.params_json:
            given = json.loads(self.params_json)
            if not isinstance(given, dict):
                raise ValueError("parameter file: expected a JSON object")
            base = qjulia.params(**given)  # complete: what the file leaves out at its default
            if "description" not in given:
                base.pop("description", None)  # (that of the default preset)
        else:
            base = qjulia.params(self.preset)
        source = self.params_json or self.preset
        if source != self.source:
            names = [name for name in params.PRESET_FIELDS
                     if self.source or not self.properties.is_property_set(name)]
            params.fill(self, base, names)
            self.source = source
        return params.to_params(self, base)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        row = layout.row()
        row.enabled = not self.params_json
        row.prop(self, "preset")
        params.draw_fields(layout, self)
        layout.prop(self, "params_json")

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
