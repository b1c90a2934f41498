"""The viewport's Rendered mode: one long-lived `refrakt watch` per viewport, fed through files.

`refrakt watch` re-renders when a file it read changes, reusing every stage whose inputs did
not change (a camera move neither voxelizes nor traces photons again). So the protocol is two
files next to the exported scene, each replaced whole by a rename:

- `NAME.view.lua`, the viewport's scene: the .glb plus the scene settings and a camera with the
  viewport's view, field of view and size. A view change (orbit, pan, zoom, a resized viewport)
  rewrites this small file only, and refrakt renders the view pass again;
- `NAME.glb`, re-exported when objects, meshes, materials, lights or the World change (once the
  edits pause for the Live Preview delay, as while dragging an object).

A new scene frame restarts the watcher on it (the frame is a `watch` argument). The session is
plain Python driven by the engine's `view_update`/`view_draw` and a UI timer (engine.py), so
tests drive it directly.
"""

import math
import time

import bpy
import numpy as np

from . import cli, exr, extras, job, scene_export

# What the depsgraph reports, by kind of data, as the change refrakt is sent.
_KINDS = (
    (bpy.types.Material, "material"),
    (bpy.types.Light, "light"),
    (bpy.types.World, "world"),
    (bpy.types.Mesh, "geometry"),
    (bpy.types.NodeTree, "material"),
)

DEFAULT_FOV = 35.0


def view_camera(view_matrix, window_matrix, region_size, scale, perspective=True):
    """refrakt's camera (Y up) for a viewport: where it is, what it looks at, which way is up,
    its vertical field of view and the image size (`scale` percent of the region's pixels). An
    orthographic view is an orthographic camera of the view's height (2 / the projection's
    [1][1], which is 2 / (top − bottom)); an off-centre projection (a camera view with lens
    shift) gives the camera that shift."""
    world = view_matrix.inverted()
    position = world.translation
    forward = -world.col[2].xyz.normalized()
    up = world.col[1].xyz.normalized()
    fov = math.degrees(2.0 * math.atan(1.0 / window_matrix[1][1])) if perspective else DEFAULT_FOV
    w, h = (max(1, round(n * scale / 100.0)) for n in region_size)
    rounded = lambda v: [round(x, 6) for x in extras.to_yup(v)]  # noqa: E731 (stable text)
    camera = {
        "position": rounded(position),
        "target": rounded(position + forward),
        "up": rounded(up),
        "fov": round(fov, 4),
        "size": [w, h],
    }
    if not perspective:
        camera["orthographic"] = round(2.0 / window_matrix[1][1], 6)
    shift = view_shift(window_matrix, w / h, perspective)
    if shift != (0.0, 0.0):
        camera["shift"] = [round(x, 6) for x in shift]
    return camera


def view_shift(window_matrix, aspect, perspective=True):
    """The projection's off-centre part as refrakt's lens shift (fractions of the image's larger
    side): a camera view with Shift X/Y, or panned in its frame. The view's centre lies at
    (P[0][2] / P[0][0], P[1][2] / P[1][1]) on the plane at unit distance of a perspective
    projection, at (−P[0][3] / P[0][0], −P[1][3] / P[1][1]) of an orthographic one; in units of
    half the view's height that is (P[0][2]·aspect, P[1][2]) or (−P[0][3]·aspect, −P[1][3]),
    and refrakt's shift moves it by twice the shift times the larger side."""
    m = window_matrix
    cx, cy = (m[0][2], m[1][2]) if perspective else (-m[0][3], -m[1][3])
    side = 2.0 * max(aspect, 1.0)
    return cx * aspect / side, cy / side


def view_script_text(paths, settings, camera):
    fields = scene_export.scene_fields({**settings, "camera": camera})
    return f"""-- {paths.name}.view.lua: what Blender's viewport shows in Rendered mode, written by the refrakt
-- add-on on every view change (your edits here are lost; the Lua wrapper {paths.name}.lua is yours).
local r = require("refrakt")

local scene = r.scene{{
{fields}}}

scene:add(r.gltf("{paths.name}.glb"))

return scene
"""


def placement(obj):
    """Where an (evaluated) object is and how big: its world matrix and bounding box, to 1e-6."""
    values = [x for row in obj.matrix_world for x in row] + [x for corner in obj.bound_box for x in corner]
    return tuple(round(x, 6) for x in values)


def placements(depsgraph):
    """Every object's placement as exported: the glTF exporter steps through the animation's
    frames and back, and Blender reports every animated object as moved afterwards, though
    nothing is where it was not; comparing with this tells those echoes from real edits."""
    return {o.name: placement(o) for o in depsgraph.objects}


def depsgraph_changes(depsgraph, exported):
    """The kinds of change in a depsgraph update that refrakt renders differently: moved or
    reshaped objects, objects added or removed, materials, lights, the World. Selecting objects,
    moving the scene camera (the viewport has its own view) or the glTF export's own
    re-evaluation (`exported`: placements at the last export) is none."""
    kinds = set()
    for update in depsgraph.updates:
        data = update.id
        if isinstance(data, bpy.types.Collection):
            if {o.name for o in depsgraph.scene.objects} != set(exported):
                kinds.add("objects")
            continue
        if isinstance(data, bpy.types.Object):
            moved = update.is_updated_transform or update.is_updated_geometry
            if data.type != "CAMERA" and moved and exported.get(data.name) != placement(data):
                kinds.add("transform" if update.is_updated_transform else "geometry")
            continue
        for kind_type, kind in _KINDS:
            if isinstance(data, kind_type):
                kinds.add(kind)
    return kinds


class ViewportSession:
    """The files and the `refrakt watch` process behind one viewport in Rendered mode."""

    def __init__(self, scene, refrakt):
        self.scene = scene
        self.binary = refrakt
        self.paths = scene_export.paths(scene)
        self.frame = scene.frame_current
        self.camera = None
        self.settings = None  # the scene settings in the view script
        self.script = None  # the view script's text
        self.watch = None
        # Kinds of scene change not yet exported: at first, everything. Exports run from `tick`
        # (a UI timer), never inside view_update, which Blender calls while drawing.
        self.pending = {"all"}
        self.dirty_since = -math.inf
        self.exported = None  # placements at the last export
        self.sent = []  # (what, detail) in the order sent: ("scene", kinds), ("view", camera), …
        self.frames = 0
        self.latest = None  # the preview's path once refrakt has written a frame
        self.reused = None
        self.quality = None
        self.error = ""
        self.warnings = []
        self.exporting = False

    # --- what Blender tells the session ------------------------------------------------

    def view_update(self, depsgraph):
        """Takes a depsgraph update: scene changes are exported once edits pause (tick), scene
        settings rewrite the view script (tick checks them too), a new frame restarts the
        watcher."""
        if self.exporting:
            return  # the exporter stepping through the animation: nothing was edited
        if self.scene.frame_current != self.frame:
            self.frame = self.scene.frame_current
            self.sent.append(("frame", self.frame))
            self._start_watch()
            if self.exported is not None:  # the .glb holds the animation: what it moved is no edit
                self.exported = placements(depsgraph)
        kinds = depsgraph_changes(depsgraph, self.exported or {})
        if kinds:
            self.pending |= kinds
            self.dirty_since = time.monotonic()
        self._write_script()

    def set_view(self, camera):
        """The viewport's camera (view_camera); rewrites the view script when it moved."""
        if camera == self.camera:
            return False
        self.camera = camera
        self.sent.append(("view", camera))
        self._write_script()
        if self.watch is None and self.exported is not None:
            self._start_watch()
        return True

    def tick(self):
        """On the UI thread: takes refrakt's news and exports pending edits once they pause.
        Returns True when a new frame is ready to draw."""
        if self.pending and time.monotonic() - self.dirty_since >= self.scene.refrakt.live_debounce:
            self.export()
        # Add-on settings set from Python tag no depsgraph update: they are compared here.
        self._write_script()
        fresh = False
        for event in self.watch.poll() if self.watch else ():
            if event.get("event") == "frame":
                self.frames += 1
                self.latest = event["files"][0]
                self.reused = (event.get("stats") or {}).get("reused")
                self.quality = event.get("quality", "final")  # a fast frame comes first after some changes
                self.error = ""
                fresh = True
            elif event.get("event") == "error":
                self.error = str(event.get("message", ""))  # the last good frame stays
        if self.watch is not None and self.watch.finished and not self.watch.cancelled:
            self.error = self.watch.error or "refrakt watch stopped"
        return fresh

    def export(self):
        kinds, self.pending, self.dirty_since = sorted(self.pending), set(), None
        self.exporting = True
        try:
            self.warnings = scene_export.export(bpy.context)
        finally:
            self.exporting = False
        self.exported = placements(bpy.context.evaluated_depsgraph_get())
        self.sent.append(("scene", kinds))
        if self.watch is None:
            self._start_watch()  # the first export: refrakt has a scene to watch

    def pixels(self):
        """The latest frame as float RGBA rows from the bottom (what a GPU texture takes), and
        its size; None before the first frame."""
        if self.latest is None:
            return None
        planes = exr.read(self.latest)
        rgba = np.stack([planes[c][::-1] for c in "RGBA"], axis=-1)
        return rgba.reshape(-1), (rgba.shape[1], rgba.shape[0])

    def stop(self):
        if self.watch is not None:
            self.watch.stop(timeout=5.0)
            self.watch = None

    # --- files and process -------------------------------------------------------------

    def _write_script(self):
        """Rewrites the view script when the settings or the camera differ from what it holds."""
        if self.camera is None:
            return
        settings = extras.scene_extras(self.scene, self.paths.directory, extras.Warnings())
        if self.settings is not None and settings != self.settings:
            self.sent.append(("settings", settings))
        self.settings = settings
        text = view_script_text(self.paths, settings, self.camera)
        if text != self.script:
            self.script = text
            scene_export.write_atomically(self.paths.view_script, text)

    def _start_watch(self):
        if self.camera is None or self.exported is None:
            return  # started once there is a view and an exported scene
        self.stop()
        argv = cli.watch_view(self.binary, self.scene, self.paths.view_script, self.paths.view_preview, self.frame)
        self.watch = job.Job(argv, output_dir=self.paths.directory)

