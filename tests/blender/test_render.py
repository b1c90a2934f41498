"""The render operator driving a refrakt subprocess: frames, progress, cancel, errors."""

import json
import os
import threading
import time
from types import SimpleNamespace

import bpy
import pytest

import exr_writer
import fake_refrakt
import scenes
from conftest import prefs, refrakt_supports, submodule


def frame_paths(scene):
    paths = submodule("scene_export").paths(scene)
    return paths, [paths.frame(k) for k in range(scene.frame_start, scene.frame_end + 1)]


def is_whole_fake_frame(path, k, size=(64, 36), layers="all"):
    """A frame the fake wrote completely, with `layers`: exactly the bytes of its EXR."""
    with open(path, "rb") as f:
        data = f.read()
    return data == exr_writer.encode(*size, fake_refrakt.frame_planes(k, *size, layers))


def record_progress(monkeypatch):
    """The job's percentage after every poll, as the operator sees it."""
    seen = []
    job = submodule("job")
    poll = job.Job.poll

    def recording(self):
        events = poll(self)
        seen.append(self.percent)
        return events

    monkeypatch.setattr(job.Job, "poll", recording)
    return seen


def test_render_writes_all_frames_with_progress_from_0_to_100(fake_refrakt, saved_blend, monkeypatch):
    scene = scenes.round_trip_scene()
    saved_blend()
    seen = record_progress(monkeypatch)
    assert bpy.ops.refrakt.render() == {"FINISHED"}

    paths, files = frame_paths(scene)
    for k, f in zip(range(1, 7), files):
        assert is_whole_fake_frame(f, k, layers=submodule("cli").layers(scene)), f
    assert seen[0] == 0.0 and seen[-1] == 100.0
    assert seen == sorted(seen) and len(set(seen)) >= 4, seen
    state = bpy.context.window_manager.refrakt
    assert not state.running and state.progress == 100.0 and state.status.startswith("Rendered 6 frame(s)")

    argv = json.loads(fake_refrakt.read_text().splitlines()[-1])
    assert argv[:2] == ["render", paths.glb]
    options = dict(zip(argv[2::2], argv[3::2]))
    assert options["--frames"] == "1..6" and options["--fps"] == "24" and options["--size"] == "64x36"
    assert options["--camera"] == "Camera" and options["--progress"] == "json" and options["--format"] == "exr"
    assert options["--out"] == paths.frames and options["--name"] == paths.name
    # The frames came back as an image sequence.
    image = bpy.data.images[f"refrakt {paths.name}"]
    assert image.source == "SEQUENCE" and bpy.path.abspath(image.filepath) == files[0]


def test_render_size_follows_resolution_percentage(fake_refrakt, saved_blend):
    """As Blender's render pipeline sizes the frame: 30 % of 64 × 36 is 19 × 10 (rounded down)."""
    scene = scenes.round_trip_scene()
    scene.render.resolution_percentage = 30
    scene.frame_end = 1
    saved_blend()
    assert bpy.ops.refrakt.render() == {"FINISHED"}
    argv = json.loads(fake_refrakt.read_text().splitlines()[-1])
    assert argv[argv.index("--size") + 1] == "19x10" and "--region" not in argv


def test_world_image_outside_the_folder_may_be_read(fake_refrakt, saved_blend, tmp_path):
    scene = scenes.round_trip_scene()
    scene.frame_end = 1
    textures = tmp_path / "textures"
    textures.mkdir()
    sky = bpy.data.images.new("sky", 4, 2, float_buffer=True)
    sky.filepath_raw, sky.file_format = str(textures / "sky.exr"), "OPEN_EXR"
    sky.save()
    nodes = scene.world.node_tree.nodes
    texture = nodes.new("ShaderNodeTexEnvironment")
    texture.image = sky
    scene.world.node_tree.links.new(texture.outputs["Color"], nodes["Background"].inputs["Color"])
    saved_blend()
    assert bpy.ops.refrakt.render() == {"FINISHED"}
    argv = json.loads(fake_refrakt.read_text().splitlines()[-1])
    assert argv[argv.index("--allow-read") + 1] == str(textures)


def test_cancel_midway_leaves_only_whole_frames(fake_refrakt, saved_blend, monkeypatch):
    scene = scenes.round_trip_scene()
    scene.frame_end = 30
    saved_blend()
    monkeypatch.setenv("FAKE_REFRAKT_DELAY", "0.25")
    paths, files = frame_paths(scene)

    def press_cancel():
        # What Esc (or the panel's Cancel button) does, once two frames are out.
        while sum(os.path.exists(f) for f in files) < 2:
            time.sleep(0.02)
        submodule("operators").current_render.cancel()

    canceller = threading.Thread(target=press_cancel)
    canceller.start()
    result = bpy.ops.refrakt.render()
    canceller.join()

    assert result == {"CANCELLED"}
    written = [f for f in files if os.path.exists(f)]
    assert 2 <= len(written) < len(files)
    assert written == files[: len(written)]  # in order, no gaps
    for k, f in enumerate(written, start=1):
        assert is_whole_fake_frame(f, k, layers=submodule("cli").layers(scene)), f
    assert not [n for n in os.listdir(paths.frames) if n.startswith(".")], "temporary files left"
    state = bpy.context.window_manager.refrakt
    assert state.status == f"Cancelled after {len(written)} frame(s); the frames written are whole"
    assert not state.error


def test_modal_operator_polls_on_timer_and_cancels_on_esc(fake_refrakt, saved_blend, monkeypatch):
    """Blender's interactive path (invoke → modal) with stand-in events, since headless Blender
    has no event loop: timer ticks take refrakt's progress, other events pass through to the
    UI, Esc stops refrakt after the frame in hand."""
    scene = scenes.round_trip_scene()
    scene.frame_end = 30
    saved_blend()
    monkeypatch.setenv("FAKE_REFRAKT_DELAY", "0.2")
    render = submodule("operators").REFRAKT_OT_render

    class Modal:  # the operator's own methods on a plain object (operators cannot be made by hand)
        _start, _command, _update, _finish, _load, modal = (
            render._start, render._command, render._update, render._finish, render._load, render.modal
        )
        load_frames = True

        def __init__(self):
            self.reports = []

        def report(self, kind, message):
            self.reports.append((kind, message))

    def event(kind, value="NOTHING"):
        return SimpleNamespace(type=kind, value=value)

    context, wm = bpy.context, bpy.context.window_manager
    op = Modal()
    assert op._start(context)
    op._timer = wm.event_timer_add(0.2, window=context.window)
    wm.progress_begin(0, 100)
    assert op.modal(context, event("MOUSEMOVE")) == {"PASS_THROUGH"}
    while op.job.done < 2:
        assert op.modal(context, event("TIMER")) == {"PASS_THROUGH"}
        time.sleep(0.02)
    assert 0 < wm.refrakt.progress < 100 and wm.refrakt.running
    assert op.modal(context, event("ESC", "PRESS")) == {"RUNNING_MODAL"}
    assert wm.refrakt.status.startswith("Cancelling after the frame in hand")
    while (result := op.modal(context, event("TIMER"))) == {"PASS_THROUGH"}:
        time.sleep(0.02)
    assert result == {"CANCELLED"} and not wm.refrakt.running
    assert op.reports[-1][0] == {"WARNING"} and "the frames written are whole" in op.reports[-1][1]
    assert 2 <= op.job.done < 30


def test_missing_binary_gives_a_message(addon, saved_blend, tmp_path, monkeypatch):
    scenes.round_trip_scene()
    saved_blend()
    prefs().binary = str(tmp_path / "nowhere" / "refrakt")
    with pytest.raises(RuntimeError) as raised:
        bpy.ops.refrakt.render()
    message = str(raised.value)
    assert f"refrakt was not found at {tmp_path / 'nowhere' / 'refrakt'}" in message
    assert "Preferences > Add-ons > refrakt" in message and "Traceback" not in message

    prefs().binary = ""
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(RuntimeError, match="refrakt was not found on PATH"):
        bpy.ops.refrakt.render()
    assert not bpy.context.window_manager.refrakt.running


def test_refrakt_error_is_reported_and_earlier_frames_stay(fake_refrakt, saved_blend, monkeypatch):
    scene = scenes.round_trip_scene()
    saved_blend()
    monkeypatch.setenv("FAKE_REFRAKT_FAIL_AT", "3")
    with pytest.raises(RuntimeError, match=r'refrakt: frame 3 \(t = 0.1250 s\): .*node "Cube": scale has a zero component'):
        bpy.ops.refrakt.render()
    _, files = frame_paths(scene)
    assert [os.path.exists(f) for f in files] == [True, True, False, False, False, False]
    state = bpy.context.window_manager.refrakt
    assert not state.running and "scale has a zero component" in state.error


def test_resume_skips_existing_frames(fake_refrakt, saved_blend, monkeypatch):
    scene = scenes.round_trip_scene()
    scene.refrakt.skip_existing = True
    saved_blend()
    assert bpy.ops.refrakt.render() == {"FINISHED"}
    seen = record_progress(monkeypatch)
    assert bpy.ops.refrakt.render() == {"FINISHED"}
    assert "--skip-existing" in json.loads(fake_refrakt.read_text().splitlines()[-1])
    assert seen[-1] == 100.0


def test_poll_never_waits_on_refrakt(fake_refrakt, tmp_path, monkeypatch):
    """The UI thread's poll returns at once even while refrakt is busy with a slow frame."""
    monkeypatch.setenv("FAKE_REFRAKT_DELAY", "2")
    scene_file = tmp_path / "x.glb"
    scene_file.write_bytes(b"glTF" + bytes(8))
    job = submodule("job").Job([str(prefs().binary), "render", str(scene_file), "--out", str(tmp_path), "--progress", "json"])
    try:
        slowest = 0.0
        for _ in range(20):
            t0 = time.perf_counter()
            job.poll()
            slowest = max(slowest, time.perf_counter() - t0)
            time.sleep(0.01)
        assert job.running and slowest < 0.05, slowest
    finally:
        job.cancel()
        job.wait(timeout=10)


def test_render_with_the_real_refrakt(addon, real_refrakt, saved_blend):
    scene = scenes.round_trip_scene()
    scene.render.resolution_x, scene.render.resolution_y = 32, 18
    scene.frame_end = 2
    scene.refrakt.volume_resolution, scene.refrakt.photons = 16, 2000
    saved_blend()
    paths = submodule("scene_export").paths(scene)
    prefs().binary = real_refrakt
    assert bpy.ops.refrakt.render() == {"FINISHED"}
    assert all(os.path.getsize(paths.frame(k)) > 0 for k in (1, 2))
