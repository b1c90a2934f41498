"""refrakt as Blender's render engine: F12 and animation renders through `refrakt render` into the
Render Result (Combined, Depth, caustic, direct, volume) and Blender's own output files; Esc;
errors. Headless Blender renders on the calling thread, so `bpy.ops.render.render` returns once
the frame (or the animation) is done."""

import json
import os

import bpy
import numpy as np
import pytest

import scenes
from conftest import submodule
from gltf_eval import Gltf

PASSES = ("caustic", "direct", "indirect", "volume")


def engine_scene(tmp_path, frames=(1, 1), size=(32, 18)):
    """The round-trip scene rendered by refrakt, with Blender writing OpenEXR multilayer files
    (every pass, full float) under tmp_path/out/."""
    scene = scenes.round_trip_scene()
    scene.render.engine = "REFRAKT"
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.frame_start, scene.frame_end = frames
    scene.frame_set(frames[0])
    scene.refrakt.volume_resolution, scene.refrakt.photons, scene.refrakt.samples = 16, 2000, 1
    scene.view_layers[0].use_pass_z = True
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):  # Blender 5.0: multilayer images are a media type
        settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.color_depth = "32"
    settings.exr_codec = "ZIP"
    scene.render.filepath = str(tmp_path / "out" / "shot.")
    scene.render.use_file_extension = True
    return scene


def refrakt_exr(path):
    """An EXR's channels, of every part, read by OpenEXR's own Python bindings (not the add-on's
    reader). Blender 5.0 writes a multilayer file as one part per pass."""
    import OpenEXR

    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {name: np.asarray(c.pixels, dtype=np.float32) for part in f.parts for name, c in part.channels.items()}


def expected_passes(planes, opaque):
    """refrakt's channels grouped as Blender's passes, rows from the bottom as Blender keeps them;
    Combined's alpha 1 where the film is `opaque` (the World in the frame)."""
    def stack(names):
        return np.stack([planes[n][::-1] for n in names], axis=-1)

    out = {"Combined": stack("RGBA"), "Depth": stack(["depth.Z"])}
    if opaque:
        out["Combined"][..., 3] = 1.0
    out.update({p: stack([f"{p}.{c}" for c in "RGB"]) for p in PASSES})
    return out


def render_layers_outputs(scene):
    """The sockets the compositor's Render Layers node shows for the scene's view layer."""
    tree = submodule("compositor").tree(scene)
    node = tree.nodes.new("CompositorNodeRLayers")
    return {s.name for s in node.outputs if s.enabled}


def test_engine_is_listed_and_its_passes_reach_the_compositor(addon):
    scene = bpy.context.scene
    scene.render.engine = "REFRAKT"  # (a name Blender does not list is refused)
    assert scene.render.engine == "REFRAKT"
    layer = scene.view_layers[0]
    layer.use_pass_z = True
    assert {"Image", "Alpha", "Depth", *PASSES} <= render_layers_outputs(scene)
    layer.refrakt.use_pass_direct = False
    layer.use_pass_z = False
    shown = render_layers_outputs(scene)
    assert {"caustic", "volume"} <= shown and not {"direct", "Depth"} & shown


def test_refrakt_error_reaches_blenders_report(fake_refrakt, tmp_path, saved_blend, monkeypatch):
    engine_scene(tmp_path, frames=(1, 3))
    saved_blend()
    monkeypatch.setenv("FAKE_REFRAKT_FAIL_AT", "2")
    with pytest.raises(RuntimeError, match=r'refrakt: frame 2 .*node "Cube": scale has a zero component'):
        bpy.ops.render.render(animation=True)
    assert fake_frame_value(tmp_path / "out" / "shot.0001.exr") == 1
    assert submodule("final_render").current is None


@pytest.mark.parametrize("refrakt", ["fake", "real"])
def test_f12_writes_the_result_and_blenders_file(request, refrakt, tmp_path, saved_blend, addon):
    if refrakt == "fake":
        request.getfixturevalue("fake_refrakt")
    else:
        path = request.getfixturevalue("real_refrakt")
        submodule("preferences").get(bpy.context).binary = path
    scene = engine_scene(tmp_path)
    saved_blend()
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    written = tmp_path / "out" / "shot.exr"
    assert written.is_file()
    paths = submodule("scene_export").paths(scene)
    ours = refrakt_exr(paths.frame(1))
    blenders = blender_exr_passes(written)
    want = expected_passes(ours, opaque=not scene.render.film_transparent)
    assert set(want) <= set(blenders), (sorted(blenders), sorted(want))
    assert np.any(ours["A"] > 0) and np.any(want["caustic"] > 0), "an empty frame proves nothing"
    for name, pixels in want.items():
        got = blenders[name]
        assert got.shape == pixels.shape, name
        assert np.max(np.abs(got - pixels)) <= 1e-6, name


def test_film_transparent_decides_whether_f12_shows_the_world(fake_refrakt, tmp_path, saved_blend, monkeypatch):
    """As in Cycles: F12 shows the World, with alpha 1, unless Film ▸ Transparent is on; then the
    camera does not see the World and alpha is refrakt's coverage (here the fake's 0.25)."""
    monkeypatch.setenv("FAKE_REFRAKT_ALPHA", "0.25")
    for transparent in (False, True):
        scene = engine_scene(tmp_path)
        scene.render.film_transparent = transparent
        saved_blend()
        assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
        glb = Gltf(submodule("scene_export").paths(scene).glb)
        assert glb.json["scenes"][0]["extras"]["refrakt"]["environment"]["visible"] is (not transparent)
        alpha = blender_exr_passes(tmp_path / "out" / "shot.exr")["Combined"][..., 3]
        assert np.all(alpha == (0.25 if transparent else 1.0)), (transparent, np.unique(alpha))


def test_refrakt_writes_only_the_passes_the_view_layers_ask_for(fake_refrakt, tmp_path, saved_blend):
    """Passes turned off in View Layer Properties are not read back or encoded by refrakt
    (`--layers`); those on reach the Render Result as before. Every pass off: the beauty alone."""
    scene = engine_scene(tmp_path)
    layer = scene.view_layers[0]
    layer.use_pass_z = False
    layer.refrakt.use_pass_direct = layer.refrakt.use_pass_indirect = False
    saved_blend()
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    calls = [json.loads(line) for line in fake_refrakt.read_text().splitlines()]
    render = next(c for c in calls if c[0] == "render")
    assert render[render.index("--layers") + 1] == "beauty,caustic,volume", render
    paths = submodule("scene_export").paths(scene)
    assert set(refrakt_exr(paths.frame(1))) == {"R", "G", "B", "A", *(f"{p}.{c}" for p in ("caustic", "volume") for c in "RGB")}
    blenders = blender_exr_passes(tmp_path / "out" / "shot.exr")
    assert np.all(blenders["caustic"] == np.float32(0.1)) and np.all(blenders["volume"] == np.float32(0.3)), sorted(blenders)
    layer.refrakt.use_pass_caustic = layer.refrakt.use_pass_volume = False
    assert submodule("cli").layers(scene) == "beauty"
    layer.use = False  # a scene whose every view layer is off still renders its first
    assert submodule("cli").layers(scene) == "beauty"


def test_a_long_frame_prints_few_status_lines(fake_refrakt, tmp_path, saved_blend, monkeypatch, capfd):
    """Headless Blender prints a `Fra:` line for every status update; the engine polls refrakt
    every 50 ms but tells Blender only what changed (a 1 s frame gave ~20 lines before)."""
    monkeypatch.setenv("FAKE_REFRAKT_DELAY", "1.0")
    engine_scene(tmp_path)
    saved_blend()
    capfd.readouterr()
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    lines = [line for line in capfd.readouterr().out.splitlines() if "Fra:" in line]
    assert 0 < len(lines) <= 5, lines


def blender_exr_passes(path):
    """The passes of Blender's multilayer EXR as {pass: (h, w, channels)}, rows from the bottom."""
    planes = refrakt_exr(path)
    grouped = {}
    for name, values in planes.items():
        parts = name.split(".")
        grouped.setdefault(parts[-2], []).append((parts[-1], values))
    order = "RGBAXYZV"
    out = {}
    for p, chans in grouped.items():
        chans.sort(key=lambda c: order.index(c[0]) if c[0] in order else 99)
        out[p] = np.stack([v[::-1] for _, v in chans], axis=-1)
    return out


def fake_frame_value(path):
    """The fake refrakt's frame number, which it writes into R."""
    return float(np.unique(blender_exr_passes(path)["Combined"][..., 0])[0])


def test_animation_renders_through_one_refrakt_process(fake_refrakt, tmp_path, saved_blend):
    engine_scene(tmp_path, frames=(1, 3))
    saved_blend()
    assert bpy.ops.render.render(animation=True) == {"FINISHED"}
    calls = [json.loads(line) for line in fake_refrakt.read_text().splitlines()]
    renders = [c for c in calls if c[0] == "render"]
    assert len(renders) == 1 and renders[0][renders[0].index("--frames") + 1] == "1..3", renders
    for k in (1, 2, 3):
        assert fake_frame_value(tmp_path / "out" / f"shot.{k:04d}.exr") == k
    assert submodule("final_render").current is None, "the process outlived the render"


def test_esc_stops_refrakt_after_the_frame_in_hand(fake_refrakt, tmp_path, saved_blend, monkeypatch):
    """Esc during frame 2 of 3 (test_break stands in for it: headless Blender has no events):
    refrakt finishes the frame in hand and exits; every file left is whole."""
    scene = engine_scene(tmp_path, frames=(1, 3))
    saved_blend()
    monkeypatch.setenv("FAKE_REFRAKT_DELAY", "0.4")
    final_render = submodule("final_render")
    written = []
    write = final_render.write_result
    monkeypatch.setattr(final_render, "write_result", lambda e, s, p: (write(e, s, p), written.append(s.frame_current)))
    monkeypatch.setattr(final_render, "interrupted", lambda engine: bool(written))
    jobs = []
    start = final_render.RangeRender.__init__
    monkeypatch.setattr(final_render.RangeRender, "__init__", lambda self, *a: (start(self, *a), jobs.append(self.job))[0])

    bpy.ops.render.render(animation=True)

    assert written == [1] and len(jobs) == 1
    proc = jobs[0].proc
    assert proc.poll() is not None, "refrakt still runs"
    paths = submodule("scene_export").paths(scene)
    frames = sorted(os.listdir(paths.frames))  # no temporaries either
    whole = [f"{paths.name}.{k:04d}.exr" for k in (1, 2)]
    assert frames in (whole[:1], whole), frames
    for k, name in enumerate(frames, start=1):
        assert np.all(refrakt_exr(os.path.join(paths.frames, name))["R"] == k)
    assert fake_frame_value(tmp_path / "out" / "shot.0001.exr") == 1
    # (Headless Blender's own loop cannot see the stand-in Esc, so it asks for frames 2 and 3;
    # the engine starts no refrakt for them and hands back blank results.)
    assert len([line for line in fake_refrakt.read_text().splitlines() if '"render"' in line]) == 1


def test_blenders_overwrite_setting_applies(fake_refrakt, tmp_path, saved_blend):
    """Overwrite off: Blender skips frames whose files exist, as for Cycles; the engine renders
    the others (still through one refrakt process) and leaves the existing file alone."""
    scene = engine_scene(tmp_path, frames=(1, 3))
    scene.render.use_overwrite = False
    saved_blend()
    out = tmp_path / "out"
    out.mkdir()
    (out / "shot.0002.exr").write_bytes(b"kept")
    bpy.ops.render.render(animation=True)
    assert (out / "shot.0002.exr").read_bytes() == b"kept"
    assert fake_frame_value(out / "shot.0001.exr") == 1 and fake_frame_value(out / "shot.0003.exr") == 3
    assert len([line for line in fake_refrakt.read_text().splitlines() if '"render"' in line]) == 1


def region_of(alpha):
    """(x, y, w, h), from the top-left corner, of the pixels whose alpha is not 0 (rows from the
    bottom, as Blender keeps them)."""
    rows, cols = np.nonzero(alpha[::-1])
    return int(cols.min()), int(rows.min()), int(cols.max() - cols.min() + 1), int(rows.max() - rows.min() + 1)


def test_a_render_region_renders_only_that_region_and_blender_places_it(fake_refrakt, tmp_path, saved_blend):
    """Output ▸ Render Region: refrakt renders only the region (`--region`, from the frame's
    top-left corner, as many pixels as Blender's render pipeline takes: the border's fractions of
    the frame rounded down); Blender places it in the frame, or crops to it. The frame's size
    follows Blender's rounding down of the resolution percentage too."""
    scene = engine_scene(tmp_path, size=(64, 36))
    scene.render.resolution_percentage = 70  # 44 × 25 (44.8 × 25.2 rounded down)
    scene.render.use_border = True
    scene.render.border_min_x, scene.render.border_max_x = 0.26, 0.7   # columns 11 … 29
    scene.render.border_min_y, scene.render.border_max_y = 0.1, 0.55   # rows 2 … 12 from the bottom
    for crop in (False, True):
        scene.render.use_crop_to_border = crop
        saved_blend()
        assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
        argv = json.loads(fake_refrakt.read_text().splitlines()[-1])
        assert argv[argv.index("--size") + 1] == "44x25" and argv[argv.index("--region") + 1] == "11,12,19,11"
        alpha = blender_exr_passes(tmp_path / "out" / "shot.exr")["Combined"][..., 3]
        if crop:
            assert alpha.shape == (11, 19) and np.all(alpha == 1.0)
        else:
            assert alpha.shape == (25, 44) and region_of(alpha) == (11, 12, 19, 11)


def glowing_dot_scene(tmp_path):
    """A small glowing ball off the axis of a camera with lens shift, in a black world: where
    Blender projects the ball's centre, refrakt's image must show it."""
    scene = engine_scene(tmp_path, size=(48, 32))
    scene.refrakt.samples = 4
    for obj in list(scene.objects):
        if obj.type != "CAMERA":
            bpy.data.objects.remove(obj)
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.08, location=(0.6, 0.8, 0.9), segments=16, ring_count=8)
    dot = bpy.context.object
    material = bpy.data.materials.new("Glow")
    material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Emission Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 5.0
    dot.data.materials.append(material)
    return scene, dot


def test_lens_shift_and_a_render_region_frame_the_image_as_blender_does(addon, real_refrakt, tmp_path, saved_blend):
    """Camera ▸ Lens ▸ Shift X/Y moves refrakt's image as Blender's camera projects it
    (`world_to_camera_view`, which applies the shift), the sensor fitted on Auto and on Vertical;
    and a render region of that frame holds the frame's own pixels there."""
    from bpy_extras.object_utils import world_to_camera_view

    submodule("preferences").get(bpy.context).binary = real_refrakt
    scene, dot = glowing_dot_scene(tmp_path)
    camera = scene.camera.data
    camera.shift_x, camera.shift_y = 0.2, -0.12
    w, h = 48, 32
    frames = {}
    for fit in ("AUTO", "VERTICAL"):
        camera.sensor_fit = fit
        saved_blend()
        assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
        beauty = blender_exr_passes(tmp_path / "out" / "shot.exr")["Combined"][..., 0]  # rows from the bottom
        weight = beauty / beauty.sum()
        ys, xs = np.mgrid[0:h, 0:w] + 0.5
        u, v, _ = world_to_camera_view(scene, scene.camera, dot.location)
        got, want = (float((weight * xs).sum()), float((weight * ys).sum())), (u * w, v * h)
        assert max(abs(got[0] - want[0]), abs(got[1] - want[1])) < 0.35, (fit, got, want)
        frames[fit] = beauty
    # A region around the ball: the frame's pixels there, bottom row 8, left column 20 (20/48
    # is not a float: Blender's single-precision product rounds to 20).
    scene.render.use_border, scene.render.use_crop_to_border = True, True
    scene.render.border_min_x, scene.render.border_max_x = 20 / w, 40 / w
    scene.render.border_min_y, scene.render.border_max_y = 8 / h, 30 / h
    saved_blend()
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    part = blender_exr_passes(tmp_path / "out" / "shot.exr")["Combined"][..., 0]
    assert part.shape == (22, 20) and part.max() > 0
    assert np.max(np.abs(part - frames["VERTICAL"][8:30, 20:40])) <= 1e-5 * part.max()
