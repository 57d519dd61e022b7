"""The add-on's modal operators in a real Blender window (on Xvfb), run by ctest:

    xvfb-run -a -s "-screen 0 800x600x24" blender --factory-startup --enable-event-simulate \
        --python tests/blender/test_modal.py -- --module-path build/python --cli build/bin/qjulia

Add > Mesh > Quaternion Julia invoked as from the menu: the operator runs modally, the
interface keeps handling events while the mesh is made (an application timer keeps firing), the
status bar shows the progress, and the object equals `qjulia mesh --stats`. The options
panel (Adjust Last Operation) makes it again with another preset and with edited fields. Then
a long Regenerate is cancelled by a simulated Esc: it stops within a second and the object keeps its
mesh. Exits 0 when every check passed, 1 otherwise.
"""

import json
import os
import shutil
import sys
import time
import traceback

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from addon_setup import TMP, build, cli_stats, qjulia  # noqa: E402  (enables the add-on)
from qjulia_blender import operators  # noqa: E402

# What the operators show in the status bar, and their jobs.
shown = []
_show = operators._Meshing._show


def spy_show(self, context):
    _show(self, context)
    shown.append((self._job, self._job.stage, self._job.fraction, self._job.token.requested))


operators._Meshing._show = spy_show
cancelled_at = []
_cancel = build.MeshJob.cancel


def spy_cancel(self):
    cancelled_at.append(time.monotonic())
    _cancel(self)


build.MeshJob.cancel = spy_cancel
ended_at = {}
_run = build.MeshJob._run


def spy_run(self, *args):
    _run(self, *args)
    ended_at[self] = time.monotonic()


build.MeshJob._run = spy_run


def view3d():
    window = bpy.context.window_manager.windows[0]
    area = next(a for a in window.screen.areas if a.type == 'VIEW_3D')
    region = next(r for r in area.regions if r.type == 'WINDOW')
    return dict(window=window, screen=window.screen, area=area, region=region)


def steps():
    """The test; yields the seconds to wait before it goes on (the event loop runs meanwhile)."""
    ui = view3d()
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    bpy.ops.ed.undo_push(message="empty scene")  # what the options panel's redo returns to
    # The first seconds of a window draw slowly (software OpenGL compiles its shaders).
    ticks = [time.monotonic()]
    while len(ticks) < 10 or max(b - a for a, b in zip(ticks[-10:], ticks[-9:])) > 0.1:
        assert ticks[-1] - ticks[0] < 60, "the window never became responsive"
        yield 0.02
        ticks.append(time.monotonic())
    # Long enough to watch: at 128 the sampling ended before the first status update and the
    # whole run took about 0.4 s, so one slow redraw read as a freeze.
    resolution = 192
    with bpy.context.temp_override(**ui):
        assert bpy.ops.mesh.qjulia_add('INVOKE_DEFAULT', preset="newton-cubic",
                                       resolution=resolution) == {'RUNNING_MODAL'}
    job = shown[0][0]
    ticks = [time.monotonic()]
    while not job.done:  # the interface handles events meanwhile: this timer keeps firing
        yield 0.02
        ticks.append(time.monotonic())
    # The operator makes the Blender object on the main thread as soon as its own timer sees the
    # job done, which may be before this timer does: that second is not meshing, so the ticks end
    # where the job ended.
    ended = ended_at[job]
    ticks = [t for t in ticks if t < ended] + [ended]
    gaps = [b - a for a, b in zip(ticks, ticks[1:])]
    print(f"add: {len(ticks)} timer ticks in {ticks[-1] - ticks[0]:.2f} s of meshing, "
          f"longest gap {max(gaps):.3f} s; {len(shown)} status updates")
    # Frozen, it would see one or two ticks in all (the machine is shared: no tight bound).
    assert len(ticks) >= 8 and max(gaps) < 0.5 * (ticks[-1] - ticks[0]), \
        f"the interface froze while the mesh was made: gaps {[round(g, 2) for g in gaps]}"
    fractions = [f for _, stage, f, _ in shown if stage == "sample"]
    assert len(shown) >= 3 and fractions, shown
    while not bpy.data.objects:
        yield 0.05
    obj = bpy.data.objects[0]
    stats = cli_stats("--preset", "newton-cubic", "--resolution", resolution, "--color",
                      "iterations")
    assert (len(obj.data.vertices), len(obj.data.polygons)) == (stats["vertices"], stats["faces"])
    assert obj.data.color_attributes.get(build.COLOR_ATTRIBUTE) and obj.active_material

    # The options panel (Adjust Last Operation): Blender undoes the Add and runs its execute()
    # again with the changed options (ed.undo_redo is what the panel calls). Another preset
    # refills the fields; a field edited afterwards overrides the preset's value.
    wm = bpy.context.window_manager
    add = wm.operators[-1]
    assert add.bl_idname == "MESH_OT_qjulia_add", [op.bl_idname for op in wm.operators]
    assert (add.properties.source, add.properties.formula, add.properties.iterations) == \
        ("newton-cubic", "(2*h^3+1)/(3*h^2)", 12)
    nine = {"iterations": 9}
    bounds = {"iterations": 9, "bounds": {"min": [-2, -2, -2], "max": [1.75, 2, 2]}}
    for change, preset, overrides, flags in (
            ({"preset": "classic-julia", "resolution": 64}, "classic-julia", {}, ()),
            ({"preset": "newton-cubic"}, "newton-cubic", {}, ()),
            ({"iterations": 9}, "newton-cubic", nine, ("--iterations", 9)),
            ({"bounds_max": (1.75, 2, 2)}, "newton-cubic", bounds,
             ("--iterations", 9, "--bounds=-2,-2,-2,1.75,2,2"))):
        props = wm.operators[-1].properties
        for name, value in change.items():
            setattr(props, name, value)
        with bpy.context.temp_override(**ui):
            assert bpy.ops.ed.undo_redo('EXEC_DEFAULT', True) == {'FINISHED'}  # with undo
        assert len(bpy.data.objects) == 1, [o.name for o in bpy.data.objects]
        obj = bpy.data.objects[0]
        assert obj.name == preset and obj.qjulia.preset == preset, obj.name
        stats = cli_stats("--preset", preset, "--resolution", 64, *flags, "--color", "iterations")
        assert (len(obj.data.vertices), len(obj.data.polygons)) == \
            (stats["vertices"], stats["faces"]), (change, len(obj.data.polygons), stats["faces"])
        assert json.loads(obj.qjulia.params_json) == qjulia.params(
            preset, resolution=64, mesh={"color": "iterations"}, **overrides), change
        print(f"options panel: {change}: {obj.qjulia.summary}")
    yield 0.1

    # Esc cancels a long Regenerate; the object keeps its mesh.
    faces = len(obj.data.polygons)
    obj.qjulia.resolution = 512
    bpy.context.view_layer.objects.active = obj
    shown.clear()
    with bpy.context.temp_override(**ui, active_object=obj, object=obj):
        assert bpy.ops.object.qjulia_regenerate('INVOKE_DEFAULT') == {'RUNNING_MODAL'}
    while not shown or not shown[-1][1]:
        yield 0.05
    yield 0.5
    job = shown[-1][0]
    assert not job.done, "the regeneration ended before Esc"
    ui["window"].event_simulate(type='ESC', value='PRESS')
    ui["window"].event_simulate(type='ESC', value='RELEASE')
    pressed = time.monotonic()
    while not job.done:
        yield 0.02
    seen = cancelled_at[0] - pressed
    stopped = ended_at[job] - cancelled_at[0]
    print(f"esc: the operator saw Esc {seen:.2f} s after it was sent; the job stopped "
          f"{stopped:.2f} s later")
    # (Software OpenGL on a shared machine makes the window's event loop slow to deliver it.)
    assert stopped < 1.0, "Esc did not stop the job within a second"
    assert isinstance(job.error, qjulia.Cancelled), job.error
    assert any(requested for _, _, _, requested in shown), "no '(cancelling)' in the status bar"
    yield 0.3  # the operator's next timer event ends it
    assert len(obj.data.polygons) == faces


def run(test=steps()):
    try:
        return next(test)
    except StopIteration:
        print("qjulia Blender add-on, modal: all checks passed")
        code = 0
    except BaseException:
        traceback.print_exc()
        code = 1
    shutil.rmtree(TMP, True)
    # os._exit skips Blender's own cleanup, which removes its session's temporary folder.
    shutil.rmtree(bpy.app.tempdir, True)
    os._exit(code)  # ends Blender at once, with the code


bpy.app.timers.register(run, first_interval=0.5)
