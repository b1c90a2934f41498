"""Render on Cluster: the operator runs refrakt-farm (here a stand-in that keeps its command line
and its JSON events) with the scene's Ray address and chunk size, the same scene file and
refrakt options as Render Animation, and shows its progress and errors the same way."""

import json
import os

import bpy
import pytest

import scenes
from conftest import HERE, prefs, submodule
from test_render import frame_paths, is_whole_fake_frame, record_progress

FAKE_FARM = HERE / "fake_refrakt_farm.py"


@pytest.fixture
def fake_farm(fake_refrakt, tmp_path, monkeypatch):
    log = tmp_path / "fake-farm-argv.jsonl"
    monkeypatch.setenv("FAKE_FARM_LOG", str(log))
    prefs().farm = str(FAKE_FARM)
    yield log
    prefs().farm = ""


def test_render_on_cluster_runs_refrakt_farm_with_the_address(fake_farm, fake_refrakt, saved_blend, monkeypatch):
    scene = scenes.round_trip_scene()
    scene.refrakt.cluster_address = "ray://head:10001"
    scene.refrakt.cluster_chunk = 4
    saved_blend()
    seen = record_progress(monkeypatch)
    assert bpy.ops.refrakt.render_cluster() == {"FINISHED"}

    paths, files = frame_paths(scene)
    for k, f in zip(range(1, 7), files):
        assert is_whole_fake_frame(f, k, layers=submodule("cli").layers(scene)), f
    assert seen[-1] == 100.0 and len(set(seen)) >= 3, seen
    assert bpy.context.window_manager.refrakt.status.startswith("Rendered 6 frame(s)")

    argv = json.loads(fake_farm.read_text().splitlines()[-1])
    own, extra = argv[: argv.index("--")], argv[argv.index("--") + 1:]
    assert own[:2] == ["render", paths.glb]
    options = dict(zip(own[2::2], own[3::2]))
    assert options["--address"] == "ray://head:10001" and options["--chunk"] == "4" and options["--frames"] == "1..6"
    assert options["--out"] == paths.frames and options["--name"] == paths.name and options["--progress"] == "json"
    assert options["--refrakt"] == str(prefs().binary)
    extra_options = dict(zip(extra[::2], extra[1::2]))
    assert extra_options["--size"] == "64x36" and extra_options["--camera"] == "Camera" and extra_options["--fps"] == "24"
    assert extra_options["--layers"] == submodule("cli").layers(scene)
    # Two chunks of the fake refrakt: 1..4 and 5..6.
    chunks = [json.loads(line) for line in fake_refrakt.read_text().splitlines()]
    assert [dict(zip(c[2::2], c[3::2]))["--frames"] for c in chunks] == ["1..4", "5..6"]


def test_without_an_address_a_local_ray_is_used(fake_farm, saved_blend):
    scene = scenes.round_trip_scene()
    scene.refrakt.cluster_address = "  "
    saved_blend()
    assert bpy.ops.refrakt.render_cluster() == {"FINISHED"}
    assert "--address" not in json.loads(fake_farm.read_text().splitlines()[-1])


def test_a_missing_refrakt_farm_gives_a_message(fake_refrakt, saved_blend, tmp_path):
    scenes.round_trip_scene()
    saved_blend()
    prefs().farm = str(tmp_path / "nowhere" / "refrakt-farm")
    try:
        with pytest.raises(RuntimeError) as raised:
            bpy.ops.refrakt.render_cluster()
    finally:
        prefs().farm = ""
    assert "refrakt-farm was not found at" in str(raised.value) and "pip install ./farm" in str(raised.value)
    assert not bpy.context.window_manager.refrakt.running


def test_a_failed_chunk_is_reported(fake_farm, saved_blend, monkeypatch):
    scene = scenes.round_trip_scene()
    saved_blend()
    monkeypatch.setenv("FAKE_REFRAKT_FAIL_AT", "5")
    with pytest.raises(RuntimeError, match=r"chunk 1\.\.6: .*scale has a zero component"):
        bpy.ops.refrakt.render_cluster()
    _, files = frame_paths(scene)
    assert [os.path.exists(f) for f in files][:4] == [True, True, True, True]
