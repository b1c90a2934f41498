"""Operators: check the binary, export, render (modal, cancellable), load frames, live mode.

Long work runs in a refrakt subprocess; the render operator is modal and polls it from a timer,
so Blender stays responsive. In background mode (`blender -b`, the `bpy` module) there are no
events, so the same operator runs to the end in `execute`, printing progress.
"""

import os
import time

import bpy
from bpy.props import BoolProperty, StringProperty

from . import binary, cli, compositor, frames, job, live, preferences, scene_export

# The running render, if any: the panel shows it and the Cancel button reaches it.
current_render = None


def _binary(context):
    return binary.resolve(preferences.get(context).binary)


def _report_warnings(op, warnings):
    for w in warnings:
        op.report({"WARNING"}, w)


class REFRAKT_OT_check_binary(bpy.types.Operator):
    bl_idname = "refrakt.check_binary"
    bl_label = "Check refrakt"
    bl_description = (
        "Run `refrakt info` to check that the executable works and which GPU it uses "
        "(the one set here, else the one bundled with the add-on, else refrakt on PATH)"
    )

    def execute(self, context):
        prefs = preferences.get(context)
        try:
            checked = binary.check(prefs.binary)
        except binary.BinaryError as e:
            prefs.check_report = ""
            prefs.check_source = ""
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        prefs.check_report = checked.report
        prefs.check_source = checked.source
        first = checked.report.splitlines()[0] if checked.report else "works"
        self.report({"INFO"}, f"{binary.describe(checked.path, checked.source)}: {first}")
        return {"FINISHED"}


class REFRAKT_OT_export(bpy.types.Operator):
    bl_idname = "refrakt.export"
    bl_label = "Export for refrakt"
    bl_description = "Write the scene as .glb (with animation, cameras, lights, glass) and a Lua wrapper next to it"

    def execute(self, context):
        where = scene_export.paths(context.scene)
        try:
            warnings = scene_export.export(context)
        except scene_export.ExportError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        _report_warnings(self, warnings)
        kept = "" if scene_export.write_wrapper(context.scene, where) else f" (kept your edited {os.path.basename(where.lua)})"
        self.report({"INFO"}, f"Exported {where.glb}{kept}")
        return {"FINISHED"}


def _load_frames_property():
    return BoolProperty(name="Load Frames", description="Load the frames into the image editor when the render ends", default=True)


class _RenderJob:
    """A render in a subprocess that reports refrakt's JSON events: modal with a timer in the
    interface, to the end in `execute` in background mode. (A mixin: Blender does not let one
    registered operator subclass another.)"""

    _timer = None

    def _start(self, context):
        global current_render
        if current_render is not None and current_render.running:
            self.report({"ERROR"}, "A refrakt render is already running")
            return False
        scene = context.scene
        self.paths = scene_export.paths(scene)
        try:
            refrakt = _binary(context)
            _report_warnings(self, scene_export.export(context))
            scene_export.write_wrapper(scene, self.paths)
            os.makedirs(self.paths.frames, exist_ok=True)
            current_render = job.Job(self._command(context, refrakt), output_dir=self.paths.frames)
        except (binary.BinaryError, scene_export.ExportError, OSError) as e:
            self.report({"ERROR"}, str(e))
            return False
        self.job = current_render
        state = context.window_manager.refrakt
        state.running, state.progress, state.error = True, 0.0, ""
        state.status = "Starting refrakt…"
        return True

    def _command(self, context, refrakt):
        raise NotImplementedError

    def _update(self, context):
        """Takes refrakt's news; returns True once it has exited."""
        self.job.poll()
        state = context.window_manager.refrakt
        state.progress = self.job.percent
        if self.job.cancelled:
            state.status = f"Cancelling after the frame in hand… ({self.job.done}/{self.job.total})"
        elif self.job.total:
            state.status = f"refrakt: frame {self.job.done}/{self.job.total}"
        return self.job.finished

    def _finish(self, context):
        state = context.window_manager.refrakt
        state.running = False
        done = self.job.done
        if self.job.error:
            state.error = self.job.error
            state.status = "refrakt failed"
            self.report({"ERROR"}, f"refrakt: {self.job.error}")
        elif self.job.cancelled:
            state.status = f"Cancelled after {done} frame(s); the frames written are whole"
            self.report({"WARNING"}, state.status)
        else:
            state.status = f"Rendered {done} frame(s) to {self.paths.frames}"
            self.report({"INFO"}, state.status)
        if self.load_frames and done:
            self._load(context)
        return {"CANCELLED"} if self.job.error or self.job.cancelled else {"FINISHED"}

    def _load(self, context):
        try:
            image, first, count = frames.load_sequence(self.paths.frames, self.paths.name)
        except frames.FramesError as e:
            self.report({"WARNING"}, str(e))
            return
        frames.show_in_image_editors(context.screen, image, first, count)

    def execute(self, context):
        if not self._start(context):
            return {"CANCELLED"}
        reported = -1
        while not self._update(context):
            if self.job.done != reported:
                reported = self.job.done
                print(f"refrakt: {self.job.done}/{self.job.total} frame(s), {self.job.percent:.0f}%", flush=True)
            time.sleep(0.05)
        return self._finish(context)

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)  # no events arrive without the user interface
        if not self._start(context):
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.2, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, 100)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self.job.cancel()
            self._update(context)
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        finished = self._update(context)
        wm = context.window_manager
        wm.progress_update(self.job.percent)
        context.workspace.status_text_set(wm.refrakt.status)
        for area in context.screen.areas if context.screen else ():
            if area.type == "PROPERTIES":
                area.tag_redraw()
        if not finished:
            return {"PASS_THROUGH"}
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        return self._finish(context)


class REFRAKT_OT_render(_RenderJob, bpy.types.Operator):
    bl_idname = "refrakt.render"
    bl_label = "Render Animation"
    bl_description = "Export the scene and render its frame range with refrakt (Esc cancels; finished frames stay)"

    load_frames: _load_frames_property()

    def _command(self, context, refrakt):
        return cli.render(refrakt, context.scene, self.paths)


class REFRAKT_OT_render_cluster(_RenderJob, bpy.types.Operator):
    bl_idname = "refrakt.render_cluster"
    bl_label = "Render on Cluster"
    bl_description = (
        "Export the scene and render its frame range on the Ray cluster at Ray Address with refrakt-farm "
        "(chunks on the cluster's GPUs, frames back into the output folder; Esc cancels)"
    )

    load_frames: _load_frames_property()

    def _command(self, context, refrakt):
        farm = binary.resolve(preferences.get(context).farm, "refrakt-farm", binary.FARM_INSTALL_HINT)
        # Frames already in the folder are skipped by refrakt-farm itself (resume).
        return cli.cluster(farm, refrakt, context.scene, self.paths)


class REFRAKT_OT_cancel_render(bpy.types.Operator):
    bl_idname = "refrakt.cancel_render"
    bl_label = "Cancel"
    bl_description = "Stop the refrakt render after the frame in hand (the frames written are whole)"

    @classmethod
    def poll(cls, context):
        return current_render is not None and current_render.running

    def execute(self, context):
        current_render.cancel()
        return {"FINISHED"}


class REFRAKT_OT_load_frames(bpy.types.Operator):
    bl_idname = "refrakt.load_frames"
    bl_label = "Load Frames"
    bl_description = "Load refrakt's EXR frames as an image sequence (and, on request, into the compositor)"

    directory: StringProperty(name="Folder", subtype="DIR_PATH", description="Empty: the scene's refrakt frames folder")
    name: StringProperty(name="Name", description="Empty: the scene's refrakt name")
    compositor: BoolProperty(
        name="Compositor", description="Lay the frames over Blender's render in the compositor", default=False
    )

    def execute(self, context):
        where = scene_export.paths(context.scene)
        directory = bpy.path.abspath(self.directory) if self.directory else where.frames
        name = self.name or where.name
        try:
            image, first, count = frames.load_sequence(directory, name)
            if self.compositor:
                node = compositor.wire(context.scene, image, first, count)
                passes = ", ".join(frames.pass_names(node))
            frames.show_in_image_editors(context.screen, image, first, count)
        except frames.FramesError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        what = f" into the compositor (passes: {passes})" if self.compositor else ""
        self.report({"INFO"}, f"Loaded {count} frame(s) from {first} of {name}{what}")
        return {"FINISHED"}


class REFRAKT_OT_live(bpy.types.Operator):
    bl_idname = "refrakt.live"
    bl_label = "Live Preview"
    bl_description = "Re-export on every change and let `refrakt watch` re-render the current frame"

    def execute(self, context):
        if live.session is not None:
            live.stop(context)
            self.report({"INFO"}, "refrakt live mode off")
            return {"FINISHED"}
        if bpy.app.background:
            self.report({"ERROR"}, "Live mode needs Blender's user interface (it runs on a UI timer)")
            return {"CANCELLED"}
        try:
            session = live.start(context, _binary(context))
        except (binary.BinaryError, scene_export.ExportError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        _report_warnings(self, session.warnings)
        self.report({"INFO"}, f"refrakt live mode on: {session.paths.preview}")
        return {"FINISHED"}


classes = (
    REFRAKT_OT_check_binary,
    REFRAKT_OT_export,
    REFRAKT_OT_render,
    REFRAKT_OT_render_cluster,
    REFRAKT_OT_cancel_render,
    REFRAKT_OT_load_frames,
    REFRAKT_OT_live,
)


register, _unregister_classes = bpy.utils.register_classes_factory(classes)


def unregister():
    # Leave no refrakt process running behind a disabled add-on.
    if current_render is not None and current_render.running:
        current_render.cancel()
    live.stop(None)
    _unregister_classes()
