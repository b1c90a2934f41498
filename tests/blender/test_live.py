"""Live mode against the fake `refrakt watch`: edits re-export (debounced), new previews reload
the image, a frame change restarts the watcher. Blender's timers do not run without its user
interface, so the tests call the session's tick the way the timer does."""

import json
import time

import bpy
import pytest

import scenes
from conftest import submodule
from gltf_eval import Gltf


def tick_until(session, condition, timeout=10.0):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        assert session.tick(bpy.context), session.error
        time.sleep(0.02)


@pytest.fixture
def session(fake_refrakt, saved_blend):
    scene = scenes.round_trip_scene()
    scene.refrakt.live_debounce = 0.3
    saved_blend()
    live = submodule("live")
    started = live.start(bpy.context, str(bpy.context.preferences.addons["bl_ext.user_default.refrakt"].preferences.binary))
    yield started
    live.stop(bpy.context)


def test_first_preview_appears(session):
    tick_until(session, lambda: session.previews >= 1)
    image = bpy.data.images["refrakt preview"]
    assert bpy.path.abspath(image.filepath) == session.paths.preview
    assert bpy.context.window_manager.refrakt.live


def test_edits_reexport_once_after_a_pause_and_refresh_the_preview(session):
    tick_until(session, lambda: session.previews >= 1)
    cube = bpy.data.objects["Ball"]
    for i in range(5):  # a burst of edits, as while dragging
        cube.location.x = -1.0 + 0.1 * (i + 1)
        bpy.context.view_layer.update()
        assert session.tick(bpy.context)
    assert session.exports == 1, "exported before the edits paused"
    time.sleep(session.scene.refrakt.live_debounce)
    tick_until(session, lambda: session.exports == 2)
    assert Gltf(session.paths.glb).node("Ball")["translation"][0] == pytest.approx(-0.5, abs=1e-6)
    tick_until(session, lambda: session.previews >= 2)
    assert session.exports == 2 and session.error == ""


def test_frame_change_restarts_the_watcher_on_the_new_frame(session, fake_refrakt):
    tick_until(session, lambda: session.previews >= 1)
    first = session.watch
    bpy.context.scene.frame_set(4)
    session.tick(bpy.context)
    assert session.watch is not first
    first.wait(timeout=10)
    previews = session.previews
    tick_until(session, lambda: session.previews > previews)  # the new watcher's first frame
    watches = [json.loads(line) for line in fake_refrakt.read_text().splitlines() if '"watch"' in line]
    assert watches[-1][watches[-1].index("--frame") + 1] == "4"


def test_stop_ends_the_watcher_and_the_handler(session):
    live = submodule("live")
    watch = session.watch
    live.stop(bpy.context)
    assert watch.finished and watch.proc.poll() is not None
    assert live._on_depsgraph_update not in bpy.app.handlers.depsgraph_update_post
    assert not bpy.app.timers.is_registered(live._on_timer)
    assert not bpy.context.window_manager.refrakt.live


def test_live_operator_needs_the_user_interface(fake_refrakt, saved_blend):
    scenes.round_trip_scene()
    saved_blend()
    with pytest.raises(RuntimeError, match="Live mode needs Blender's user interface"):
        bpy.ops.refrakt.live()


def test_live_with_the_real_refrakt_watch(addon, real_refrakt, saved_blend):
    """The real `refrakt watch` behind live mode: the first preview arrives (a fast frame, then
    the full one), and a moved object re-exports and brings a new full frame that differs."""
    scene = scenes.round_trip_scene()
    scene.render.resolution_x, scene.render.resolution_y = 48, 27
    scene.refrakt.volume_resolution, scene.refrakt.photons, scene.refrakt.samples = 24, 2000, 1
    scene.refrakt.live_debounce = 0.2
    saved_blend()
    live = submodule("live")
    session = live.start(bpy.context, real_refrakt)
    try:
        tick_until(session, lambda: session.quality == "final", timeout=120)
        image = bpy.data.images["refrakt preview"]
        assert bpy.path.abspath(image.filepath) == session.paths.preview
        with open(session.paths.preview, "rb") as f:
            before = f.read()
        assert before[:4] == b"\x76\x2f\x31\x01", "the preview is an OpenEXR file"
        previews = session.previews
        bpy.data.objects["Ball"].location.x += 0.4  # (the Cube is animated: its keys would win)
        bpy.context.view_layer.update()
        assert session.tick(bpy.context)
        time.sleep(scene.refrakt.live_debounce)
        tick_until(session, lambda: session.exports == 2, timeout=30)
        tick_until(session, lambda: session.previews > previews and session.quality == "final", timeout=120)
        with open(session.paths.preview, "rb") as f:
            assert f.read() != before, "the preview did not change after the ball moved"
        assert session.error == "" and "preview(s)" in live.status(session)
    finally:
        live.stop(bpy.context)
