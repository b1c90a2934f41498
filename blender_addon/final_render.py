"""F12 and Ctrl+F12 through refrakt: the render engine's `render` (engine.py) hands each frame
Blender asks for to a `RangeRender`, one `refrakt render` process for the rest of the range
(not one per frame), and copies the frame's EXR into Blender's Render Result pass by pass.

Blender calls `render` once per frame of an animation, in order; refrakt runs ahead on the
frames after it meanwhile. `render_init` (a new render) and `render_cancel`/`render_complete`
end the process of the render before, so an edited scene is exported afresh.
"""

import contextlib
import os
import threading
import time

import bpy
import numpy as np

from . import binary, cli, exr, extras, job, preferences, scene_export

# refrakt's passes beside Combined and Depth, named as its EXR layers (properties.py describes them).
PASSES = ("caustic", "direct", "indirect", "volume")

# Render Result pass → refrakt's EXR channels.
CHANNELS = {
    "Combined": ("R", "G", "B", "A"),
    "Depth": ("depth.Z",),
    **{name: tuple(f"{name}.{c}" for c in "RGB") for name in PASSES},
}

POLL_SECONDS = 0.05


def interrupted(engine):
    """Whether the user pressed Esc (headless Blender has no events; tests stand in here)."""
    return engine.test_break()


class RenderError(Exception):
    """The frame cannot be rendered; the message is for the user."""


class RangeRender:
    """One `refrakt render` process for frames first..last of a scene, and the files it has
    finished so far."""

    def __init__(self, scene, refrakt, first, last):
        self.scene_name = scene.name
        self.first, self.last = first, last
        self.paths = scene_export.paths(scene)
        os.makedirs(self.paths.frames, exist_ok=True)
        argv = cli.render(refrakt, scene, self.paths, frames=(first, last), resume=False)
        self.job = job.Job(argv, output_dir=self.paths.frames)
        self.files = {}
        self.shown_stats = None  # the status line last handed to Blender

    def covers(self, scene, k):
        return scene.name == self.scene_name and self.first <= k <= self.last and not self.job.cancelled

    def poll(self):
        for event in self.job.poll():
            if event.get("event") == "frame" and event.get("files"):
                exrs = [f for f in event["files"] if f.endswith(".exr")]
                self.files[int(event["frame"])] = exrs[0] if exrs else event["files"][0]

    def wait_for(self, k, engine):
        """The EXR of frame k once refrakt has written it; None when the render was stopped
        first (Esc). Keeps Blender's progress and stats current while it waits."""
        while True:
            self.poll()
            if k in self.files:
                return self.files[k]
            if self.job.finished:
                if self.job.cancelled:
                    return None
                raise RenderError(self.job.error or f"refrakt stopped before frame {k}")
            if interrupted(engine):
                self.job.cancel()  # refrakt finishes the frame in hand and exits
            _show_progress(engine, self, k)
            time.sleep(POLL_SECONDS)

    def stop(self, timeout=30.0):
        """Ends the process (after the frame in hand) and waits for it."""
        self.job.stop(timeout)


def _show_progress(engine, run, k):
    """Blender's status line and progress bar, told only what changed: each update_stats call
    prints a `Fra:` line to the console of a headless or command-line Blender, and this runs
    every POLL_SECONDS."""
    j = run.job
    state = "stopping after the frame in hand" if j.cancelled else f"rendering frame {k}"
    stats = f"{state} ({j.done}/{j.total or run.last - run.first + 1} of frames {run.first}–{run.last})"
    if stats != run.shown_stats:
        engine.update_stats("refrakt", stats)
        run.shown_stats = stats
    total = run.last - run.first + 1
    engine.update_progress((k - run.first + 0.5) / total)  # half way through frame k of the range


# The process of the render under way (an animation's frames share it).
current = None


@bpy.app.handlers.persistent
def stop_current(*_args):
    """Handler for render_init/render_cancel/render_complete: no process outlives its render."""
    global current
    if current is not None:
        current.stop()
        current = None


def _range_for(engine, scene, k):
    """The running process if it renders frame k for this render, else a new one (after a fresh
    export) for k..end of an animation with step 1, or k alone."""
    global current
    if current is not None and current.covers(scene, k):
        return current
    stop_current()
    try:
        refrakt = binary.resolve(preferences.get(bpy.context).binary)
        for w in on_main_thread(lambda: _export(scene)):
            engine.report({"WARNING"}, w)
    except (binary.BinaryError, scene_export.ExportError, OSError) as e:
        raise RenderError(str(e)) from None
    last = scene.frame_end if engine.is_animation and scene.frame_step == 1 and k <= scene.frame_end else k
    try:
        current = RangeRender(scene, refrakt, k, last)
    except (binary.BinaryError, OSError) as e:
        raise RenderError(str(e)) from None
    return current


def _export(scene):
    """The scene's .glb and Lua wrapper; returns the export's warnings."""
    windows = bpy.context.window_manager.windows
    with bpy.context.temp_override(window=windows[0]) if windows else contextlib.nullcontext():
        warnings = scene_export.export(bpy.context)
    scene_export.write_wrapper(scene, scene_export.paths(scene))
    return warnings


EXPORT_TIMEOUT_S = 600.0


def on_main_thread(work):
    """Runs `work` on Blender's main thread and returns what it returns (or raises what it
    raises). F12 renders on a thread of Blender's render job, whose context lacks what the glTF
    exporter reads (the active object, the view layer); the main thread runs it from a timer.
    Headless renders (`-b`, the bpy module) run on the main thread: `work` runs at once."""
    if threading.current_thread() is threading.main_thread():
        return work()
    done, outcome = threading.Event(), {}

    def run():
        try:
            outcome["value"] = work()
        except Exception as e:  # noqa: BLE001 (raised again on the render thread)
            outcome["error"] = e
        done.set()
        return None

    bpy.app.timers.register(run, first_interval=0.0)
    if not done.wait(EXPORT_TIMEOUT_S):
        raise RenderError(f"Blender's main thread did not export the scene within {EXPORT_TIMEOUT_S:.0f} s")
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


def render(engine, depsgraph):
    """RenderEngine.render: frame `scene.frame_current` into the Render Result."""
    scene = depsgraph.scene
    k = scene.frame_current
    if interrupted(engine):
        stop_current()
        _empty_result(engine, scene)
        return
    try:
        run = _range_for(engine, scene, k)
        path = run.wait_for(k, engine)
        if path is None:
            engine.update_stats("refrakt", "stopped; the frames written are whole")
            _empty_result(engine, scene)
            return
        engine.update_stats("refrakt", f"frame {k}: reading {os.path.basename(path)}")
        write_result(engine, scene, exr.read(path))
    except (RenderError, exr.ExrError) as e:
        stop_current()
        engine.report({"ERROR"}, f"refrakt: {e}")
        return
    engine.update_progress(1.0)
    if k >= run.last:
        stop_current()


def _empty_result(engine, scene):
    """A frame left unrendered still hands Blender a (blank) result: Blender's writers expect
    one whenever `render` returns."""
    w, h = cli.image_size(scene)
    engine.end_result(engine.begin_result(0, 0, w, h))


def write_result(engine, scene, planes):
    """refrakt's channels into the Render Result's passes (rows flipped: EXR's first row is the
    top of the image, Blender's the bottom). With a render region both are the region's size:
    Blender places it in the frame."""
    w, h = cli.image_size(scene)
    got = next(iter(planes.values())).shape
    if got != (h, w):
        raise RenderError(f"refrakt's frame is {got[1]}×{got[0]}, Blender's render size {w}×{h}")
    # refrakt's alpha is the coverage of glass and receivers; where the camera sees the World
    # the film is opaque, as Cycles' without Film ▸ Transparent.
    opaque = extras.world_in_frames(scene)
    result = engine.begin_result(0, 0, w, h)
    try:
        for layer in result.layers:
            for render_pass in layer.passes:
                names = CHANNELS.get(render_pass.name)
                if names is None or not all(n in planes for n in names):
                    continue  # a pass refrakt does not make (Blender's own) stays empty
                pixels = np.stack([planes[n][::-1] for n in names], axis=-1)
                if render_pass.name == "Combined" and opaque:
                    pixels[..., 3] = 1.0
                pixels = pixels.reshape(-1)
                set_pass(render_pass, pixels)
    finally:
        engine.end_result(result)


def set_pass(render_pass, pixels):
    """Blender 4.2's pass rect takes a sequence of pixels; later ones also a flat buffer."""
    try:
        render_pass.rect.foreach_set(pixels)
    except (AttributeError, TypeError, RuntimeError):
        render_pass.rect = pixels.reshape(-1, render_pass.channels)


def update_render_passes(engine, scene, view_layer):
    """Registers the passes the view layer asks for, so the compositor's Render Layers node and
    Blender's multilayer output show them."""
    engine.register_pass(scene, view_layer, "Combined", 4, "RGBA", "COLOR")
    if view_layer.use_pass_z:
        engine.register_pass(scene, view_layer, "Depth", 1, "Z", "VALUE")
    settings = view_layer.refrakt
    for name in PASSES:
        if getattr(settings, f"use_pass_{name}"):
            engine.register_pass(scene, view_layer, name, 3, "RGB", "COLOR")
