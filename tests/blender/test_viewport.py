"""The viewport's Rendered mode (viewport.py): what each kind of change sends to `refrakt watch`,
against a recording stand-in and once against the real `refrakt watch`.

Headless Blender has no viewport, so the tests play its part: they give the session a view
(as `view_draw` does from the region) and forward depsgraph updates (as `view_update` does)."""

import json
import math
import os
import time

import bpy
import numpy as np
import pytest
from mathutils import Matrix

import scenes
from conftest import prefs, submodule
from gltf_eval import Gltf
from test_engine import refrakt_exr


def window_matrix(fov_y_deg, aspect):
    """A perspective projection as Blender's viewport makes it (only [0][0] and [1][1] matter)."""
    t = 1.0 / math.tan(math.radians(fov_y_deg) / 2.0)
    m = Matrix.Identity(4)
    m[0][0], m[1][1] = t / aspect, t
    return m


def orbit_view(angle_deg, distance=6.0, height=2.0):
    """The view matrix of a viewport orbiting the origin at `angle_deg` about Blender's Z."""
    a = math.radians(angle_deg)
    cam = bpy.data.objects.new("view", None)
    cam.location = (distance * math.sin(a), -distance * math.cos(a), height)
    scenes.look_at(cam, (0, 0, 0.5))
    world = cam.matrix_basis.copy()
    bpy.data.objects.remove(cam)
    return world.inverted()


def camera(angle_deg, scale=50, size=(96, 54)):
    return submodule("viewport").view_camera(orbit_view(angle_deg), window_matrix(40.0, size[0] / size[1]), size, scale)


def test_view_camera_in_refrakts_frame(addon):
    """A view from Blender's (0, −5, 0) looking along +Y with +Z up is refrakt's (0, 0, 5)
    looking along −Z with +Y up; the field of view comes from the projection."""
    view = Matrix.Translation((0, -5, 0)) @ Matrix.Rotation(math.radians(90), 4, "X")
    cam = submodule("viewport").view_camera(view.inverted(), window_matrix(40.0, 2.0), (200, 100), 50)
    assert cam["position"] == pytest.approx([0, 0, 5], abs=1e-6)
    assert cam["target"] == pytest.approx([0, 0, 4], abs=1e-6)
    assert cam["up"] == pytest.approx([0, 1, 0], abs=1e-6)
    assert cam["fov"] == pytest.approx(40.0, abs=1e-3) and cam["size"] == [100, 50]


def test_an_orthographic_view_is_an_orthographic_camera(addon):
    """Blender's orthographic viewport (projection [1][1] = 2 / the view's height) becomes
    refrakt's orthographic camera of that height; a perspective view stays a pinhole."""
    view = Matrix.Translation((0, -5, 0)) @ Matrix.Rotation(math.radians(90), 4, "X")
    ortho = Matrix.Diagonal((2.0 / 6.0, 2.0 / 3.0, -2.0 / 99.9, 1.0))
    cam = submodule("viewport").view_camera(view.inverted(), ortho, (200, 100), 50, False)
    assert cam["orthographic"] == pytest.approx(3.0, abs=1e-6)
    assert "orthographic" not in submodule("viewport").view_camera(view.inverted(), window_matrix(40.0, 2.0), (200, 100), 50)


def test_a_camera_views_lens_shift_reaches_refrakts_camera(addon):
    """Looking through a camera with Shift X/Y, the viewport's projection is Blender's camera
    projection (`calc_matrix_camera`), off-centre by the shift: refrakt's view camera gets that
    shift, perspective and orthographic, landscape and portrait."""
    scene = scenes.round_trip_scene()
    cam = scene.camera
    cam.data.shift_x, cam.data.shift_y = 0.2, -0.1
    for kind in ("PERSP", "ORTHO"):
        cam.data.type = kind
        for size in ((96, 54), (54, 96)):
            window = cam.calc_matrix_camera(bpy.context.evaluated_depsgraph_get(), x=size[0], y=size[1])
            got = submodule("viewport").view_camera(cam.matrix_world.inverted(), window, size, 100, kind == "PERSP")
            assert got["shift"] == pytest.approx([0.2, -0.1], abs=1e-5), (kind, size)


class Recorder:
    """A depsgraph handler that forwards Blender's updates to the session, as view_update."""

    def __init__(self, session):
        self.session = session

    def __call__(self, scene, depsgraph):
        self.session.view_update(depsgraph)

    def __enter__(self):
        bpy.app.handlers.depsgraph_update_post.append(self)
        return self

    def __exit__(self, *exc):
        bpy.app.handlers.depsgraph_update_post.remove(self)


def tick_until(session, condition, timeout=20.0):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"timed out; sent {[s[0] for s in session.sent]}, error {session.error!r}"
        session.tick()
        time.sleep(0.02)


@pytest.fixture
def viewport(fake_refrakt, saved_blend, tmp_path, monkeypatch):
    """A session on the round-trip scene against the recording stand-in; yields (session, the
    stand-in's reloads)."""
    log = tmp_path / "watch-reloads.jsonl"
    monkeypatch.setenv("FAKE_REFRAKT_WATCH_LOG", str(log))
    scene = scenes.round_trip_scene()
    scene.refrakt.live_debounce = 0.1
    saved_blend()
    bpy.context.view_layer.update()  # (the scene as built, before the viewport opens)
    session = submodule("viewport").ViewportSession(scene, prefs().binary)
    session.set_view(camera(0))
    tick_until(session, lambda: session.frames >= 1)

    def reloads():
        return [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []

    yield session, reloads
    session.stop()


def test_exports_wait_for_the_timer(fake_refrakt, saved_blend):
    """Blender calls view_update while it draws (a GPU context bound): the session only notes
    changes there; the glTF export runs from the UI timer's tick."""
    scene = scenes.round_trip_scene()
    saved_blend()
    bpy.context.view_layer.update()
    session = submodule("viewport").ViewportSession(scene, prefs().binary)
    try:
        session.set_view(camera(0))
        bpy.data.objects["Ball"].location.x = 0.3
        session.view_update(bpy.context.evaluated_depsgraph_get())
        assert not os.path.exists(session.paths.glb) and session.watch is None
        session.tick()
        assert os.path.exists(session.paths.glb) and session.watch is not None
        assert session.sent == [("view", camera(0)), ("scene", ["all"])]
    finally:
        session.stop()


def test_orbit_sends_only_the_view(viewport):
    session, reloads = viewport
    name = session.paths.name
    glb_before = open(session.paths.glb, "rb").read()
    moved = camera(30)
    assert session.set_view(moved)
    assert not session.set_view(moved), "an unchanged view sends nothing"
    tick_until(session, lambda: session.frames >= 2)
    last = reloads()[-1]
    assert last["changed"] == [f"{name}.view.lua"]
    assert f"position = {{{', '.join(f'{x:.6g}' for x in moved['position'])}}}" in last["script"]
    assert session.reused == {"volume": True, "photons": True}
    assert session.sent[-1] == ("view", moved)
    assert open(session.paths.glb, "rb").read() == glb_before, "a view change re-exported the scene"


def test_moved_object_and_changed_material_send_the_scene(viewport):
    session, reloads = viewport
    ball = bpy.data.objects["Ball"]
    with Recorder(session):
        ball.select_set(True)  # selecting is no change to the picture
        bpy.context.view_layer.update()
        assert not session.pending
        # Re-evaluated where it was (as after the exporter stepped through the animation).
        ball.location = ball.location.copy()
        bpy.data.objects["Cube"].location = bpy.data.objects["Cube"].location.copy()
        bpy.context.view_layer.update()
        assert not session.pending
        ball.location.x = -0.4
        bpy.context.view_layer.update()
        assert session.pending == {"transform"}
        tick_until(session, lambda: session.frames >= 2)
        assert session.sent[-1] == ("scene", ["transform"])
        assert reloads()[-1]["changed"] == [f"{session.paths.name}.glb"]
        assert Gltf(session.paths.glb).node("Ball")["translation"][0] == pytest.approx(-0.4, abs=1e-6)

        bsdf = ball.active_material.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["IOR"].default_value = 1.8
        bpy.context.view_layer.update()
        tick_until(session, lambda: session.frames >= 3)
    # (Blender re-evaluates the objects that use a material with it: they come as geometry.)
    what, kinds = session.sent[-1]
    assert what == "scene" and "material" in kinds and "transform" not in kinds, kinds
    # (The cube has no material: it goes out as Blender's default surface, which stays as it was.)
    materials = [m for m in Gltf(session.paths.glb).json["materials"] if m["name"] != submodule("gltf_hooks").DEFAULT_SURFACE]
    assert [m["extensions"]["KHR_materials_ior"]["ior"] for m in materials] == [pytest.approx(1.8)]
    assert session.reused == {"volume": False, "photons": False}


def test_scene_settings_rewrite_the_view_script(viewport):
    session, reloads = viewport
    session.scene.refrakt.photons = 12345  # (no depsgraph update: the timer's tick sees it)
    tick_until(session, lambda: session.frames >= 2)
    assert session.sent[-1][0] == "settings" and session.sent[-1][1]["photons"] == 12345
    assert reloads()[-1]["changed"] == [f"{session.paths.name}.view.lua"]
    assert "photons = 12345," in reloads()[-1]["script"]


def test_frame_change_restarts_the_watcher(viewport, fake_refrakt):
    session, _ = viewport
    first, frames = session.watch, session.frames
    bpy.context.scene.frame_set(4)
    session.view_update(bpy.context.evaluated_depsgraph_get())  # (frame_set runs no update handler)
    assert session.watch is not first and first.finished
    assert session.sent[-1] == ("frame", 4) and not session.pending, "the animation moved the Cube, no edit"
    tick_until(session, lambda: session.frames > frames)  # the new watcher's first frame
    watches = [json.loads(line) for line in fake_refrakt.read_text().splitlines() if '"watch"' in line]
    assert watches[-1][watches[-1].index("--frame") + 1] == "4"
    assert watches[-1][1] == session.paths.view_script and "--size" not in watches[-1]


def test_viewport_with_the_real_refrakt_watch(addon, real_refrakt, saved_blend):
    """The real `refrakt watch` behind the viewport: an orbit renders a new frame that reuses
    the volume and the photons, and the pixels change."""
    scene = scenes.round_trip_scene()
    scene.refrakt.volume_resolution, scene.refrakt.photons, scene.refrakt.samples = 24, 2000, 1
    saved_blend()
    session = submodule("viewport").ViewportSession(scene, real_refrakt)
    try:
        session.set_view(camera(0, scale=50, size=(96, 54)))
        tick_until(session, lambda: session.quality == "final", timeout=120)
        before, size = session.pixels()
        assert size == (48, 27) and before.shape == (48 * 27 * 4,)
        # The add-on's reader against OpenEXR's own (the preview is half floats, uncompressed).
        planes = refrakt_exr(session.latest)
        expected = np.stack([planes[c][::-1] for c in "RGBA"], axis=-1).reshape(-1)
        assert np.array_equal(before, expected)
        frames = session.frames
        session.set_view(camera(25, scale=50, size=(96, 54)))
        tick_until(session, lambda: session.frames > frames and session.quality == "final", timeout=120)
        assert session.reused["volume"] and session.reused["photons"], session.reused
        after, _ = session.pixels()
        assert np.max(np.abs(after - before)) > 0.01, "the orbit did not change the picture"
        assert session.error == ""
    finally:
        session.stop()
