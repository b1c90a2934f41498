"""Live mode: while it is on, edits in Blender re-export the scene (once the edits pause for the
debounce delay) and `refrakt watch` re-renders it; every frame it reports reloads the preview
image in Blender's image editors.

Blender calls `on_depsgraph_update` after each edit and `tick` from a timer on the UI thread;
the watch process is read on background threads (see job.py), so nothing here waits on it.
"""

import os
import time

import bpy

from . import binary, cli, job, scene_export

# Kinds of data whose edits change what refrakt renders (an image reload, a UI change or a text
# edit do not; the preview image reloading itself must not trigger another export).
RENDERED_TYPES = (
    bpy.types.Object,
    bpy.types.Mesh,
    bpy.types.Material,
    bpy.types.Light,
    bpy.types.Camera,
    bpy.types.World,
    bpy.types.Scene,
    bpy.types.Collection,
    bpy.types.Action,
    bpy.types.NodeTree,
)

PREVIEW_IMAGE = "refrakt preview"


class LiveSession:
    def __init__(self, scene, refrakt_binary):
        self.scene = scene
        self.binary = refrakt_binary
        self.paths = scene_export.paths(scene)
        self.dirty_since = None
        self.frame = scene.frame_current
        self.watch = None
        self.exports = 0
        self.previews = 0
        self.quality = None
        self.error = ""
        self.warnings = []

    def start(self, context):
        self.export(context)
        scene_export.write_wrapper(self.scene, self.paths)
        self._start_watch()

    def _start_watch(self):
        if self.watch is not None:
            self.watch.cancel()
        self.frame = self.scene.frame_current
        self.watch = job.Job(cli.watch(self.binary, self.scene, self.paths), output_dir=self.paths.directory)

    def export(self, context):
        self.warnings = scene_export.export(context)
        self.exports += 1
        self.dirty_since = None

    def mark_dirty(self, depsgraph):
        if any(isinstance(u.id, RENDERED_TYPES) for u in depsgraph.updates):
            self.dirty_since = time.monotonic()

    def tick(self, context):
        """One step on the UI thread: take the watcher's events, restart it on a frame change,
        re-export once edits have paused. Returns False when the session has ended."""
        for event in self.watch.poll():
            if event.get("event") == "frame":
                self.error = ""
                self.previews += 1
                # refrakt shows a fast frame first after a change, then the full one.
                self.quality = event.get("quality", "final")
                self._show_preview(context)
            elif event.get("event") == "error":
                self.error = str(event.get("message", ""))  # refrakt keeps the last good frame
        if self.watch.finished:
            self.error = self.watch.error or "refrakt watch stopped"
            return False
        if self.scene.frame_current != self.frame:
            self._start_watch()
        delay = self.scene.refrakt.live_debounce
        if self.dirty_since is not None and time.monotonic() - self.dirty_since >= delay:
            self.export(context)
        return True

    def _show_preview(self, context):
        image = bpy.data.images.get(PREVIEW_IMAGE)
        if image is None and os.path.isfile(self.paths.preview):
            image = bpy.data.images.load(self.paths.preview, check_existing=False)
            image.name = PREVIEW_IMAGE
        if image is None:
            return
        image.reload()
        for window in context.window_manager.windows:
            for area in window.screen.areas:
                if area.type == "IMAGE_EDITOR":
                    if area.spaces.active.image is None:
                        area.spaces.active.image = image
                    area.tag_redraw()

    def stop(self):
        if self.watch is not None:
            self.watch.stop(timeout=5.0)


# The one live session (Blender has one UI thread and one scene being edited at a time).
session = None

TICK_SECONDS = 0.1


def _on_depsgraph_update(scene, depsgraph):
    if session is not None and scene == session.scene:
        session.mark_dirty(depsgraph)


def _on_timer():
    if session is None:
        return None
    context = bpy.context
    try:
        alive = session.tick(context)
    except scene_export.ExportError as e:
        session.error, alive = str(e), True  # keep watching the last good export
    except binary.BinaryError as e:  # refrakt vanished while restarting the watcher
        session.error, alive = str(e), False
    context.window_manager.refrakt.live_status = status(session)
    if not alive:
        stop(context)
        return None
    return TICK_SECONDS


def start(context, refrakt_binary):
    """Starts live mode for the context's scene (exports it first, so errors surface here)."""
    global session
    stop(context)
    live = LiveSession(context.scene, refrakt_binary)
    live.start(context)
    session = live
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph_update)
    bpy.app.timers.register(_on_timer, first_interval=TICK_SECONDS)
    context.window_manager.refrakt.live = True
    context.window_manager.refrakt.live_status = status(live)
    return live


def stop(context):
    global session
    if _on_depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph_update)
    if bpy.app.timers.is_registered(_on_timer):
        bpy.app.timers.unregister(_on_timer)
    if session is not None:
        session.stop()
        session = None
    if context is not None:
        context.window_manager.refrakt.live = False


def status(session_):
    if session_.error:
        return f"refrakt: {session_.error}"
    refining = " (refining…)" if session_.quality == "preview" else ""
    return f"Live: {session_.exports} export(s), {session_.previews} preview(s){refining}"
