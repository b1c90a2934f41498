"""Loading refrakt's EXR frames back: the image sequence (frame count, mapping of scene frames to
files, size) and the compositor (one socket per pass; passes laid over Blender's render)."""

import os
import subprocess

import bpy
import pytest

import exr_writer
import fake_refrakt
from conftest import ROOT, submodule

SIZE = (16, 8)
FIRST, LAST = 3, 7


@pytest.fixture
def frames_on_disk(addon, saved_blend):
    """Frames 3–7 as refrakt names them, each with R = its frame number."""
    saved_blend()
    paths = submodule("scene_export").paths(bpy.context.scene)
    os.makedirs(paths.frames)
    for k in range(FIRST, LAST + 1):
        exr_writer.write(paths.frame(k), *SIZE, fake_refrakt.frame_planes(k, *SIZE))
    return paths


def composite_pixel(scene, frame, tmp_path):
    """Renders the compositor at `frame` (Cycles, 1 sample, nothing in the scene) and returns
    (first pixel RGBA, size) of the result."""
    if scene.camera is None:
        scene.camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        scene.collection.objects.link(scene.camera)
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = str(tmp_path / f"composite-{frame}.exr")
    scene.frame_set(frame)
    bpy.ops.render.render(write_still=True)
    out = bpy.data.images.load(scene.render.filepath, check_existing=False)
    try:
        return list(out.pixels[:4]), tuple(out.size)
    finally:
        bpy.data.images.remove(out)


def image_editor():
    area = bpy.context.screen.areas[0]
    area.type = "IMAGE_EDITOR"
    return area.spaces.active


def test_frames_load_as_a_sequence_in_the_image_editor(frames_on_disk):
    space = image_editor()
    assert bpy.ops.refrakt.load_frames() == {"FINISHED"}
    image = bpy.data.images[f"refrakt {frames_on_disk.name}"]
    assert image.source == "SEQUENCE"
    assert bpy.path.abspath(image.filepath) == frames_on_disk.frame(FIRST)
    assert space.image == image
    user = space.image_user
    assert (user.frame_start, user.frame_offset, user.frame_duration) == (FIRST, FIRST - 1, LAST - FIRST + 1)


def test_compositor_shows_every_pass_and_maps_frames(frames_on_disk, tmp_path):
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = *SIZE, 100
    assert bpy.ops.refrakt.load_frames(compositor=True) == {"FINISHED"}
    node = submodule("compositor").tree(scene).nodes["refrakt frames"]
    assert set(submodule("frames").pass_names(node)) >= {"Combined", "Alpha", "depth", "caustic", "direct", "volume"}
    # The beauty (alpha 1 in these frames) covers the render: the result is frame k's R = k.
    for k in (FIRST, 5, LAST):
        pixel, size = composite_pixel(scene, k, tmp_path)
        assert size == SIZE and pixel[0] == pytest.approx(k), (k, pixel)
    # Beyond the last file Blender holds the last frame.
    assert composite_pixel(scene, LAST + 2, tmp_path)[0][0] == pytest.approx(LAST)


def test_caustic_and_volume_passes_add_to_the_render(frames_on_disk, tmp_path):
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = *SIZE, 100
    scene.refrakt.pass_beauty = False
    assert bpy.ops.refrakt.load_frames(compositor=True) == {"FINISHED"}
    pixel, _ = composite_pixel(scene, 4, tmp_path)
    # An empty scene renders black; the fake frames hold caustic 0.1 and volume 0.3.
    assert pixel[:3] == pytest.approx([0.4, 0.4, 0.4], abs=1e-5)
    scene.refrakt.pass_volume = False
    bpy.ops.refrakt.load_frames(compositor=True)
    assert composite_pixel(scene, 4, tmp_path)[0][:3] == pytest.approx([0.1, 0.1, 0.1], abs=1e-5)


def test_wiring_again_keeps_the_users_compositing(frames_on_disk):
    compositor = submodule("compositor")
    api = compositor.nodes_api()
    tree = compositor.tree(bpy.context.scene)
    output = api.output(tree)
    layers = tree.nodes.new("CompositorNodeRLayers")
    blur = tree.nodes.new("CompositorNodeBlur")
    tree.links.new(layers.outputs["Image"], blur.inputs["Image"])
    tree.links.new(blur.outputs["Image"], output)

    bpy.ops.refrakt.load_frames(compositor=True)
    count = len(tree.nodes)
    bpy.ops.refrakt.load_frames(compositor=True)
    assert len(tree.nodes) == count
    # output ← over ← volume ← caustic ← the user's blur.
    socket = output.links[0].from_socket
    chain = []
    while socket.node.name.startswith("refrakt "):
        chain.append(socket.node.name)
        socket = api.background_input(socket.node).links[0].from_socket
    assert chain == ["refrakt over", "refrakt volume", "refrakt caustic"] and socket.node == blur


def test_no_frames_gives_a_message(addon, saved_blend):
    saved_blend()
    with pytest.raises(RuntimeError, match="render with refrakt first"):
        bpy.ops.refrakt.load_frames()


def test_frames_rendered_by_the_real_refrakt(addon, real_refrakt, tmp_path):
    out = tmp_path / "frames"
    done = subprocess.run(
        [real_refrakt, "render", str(ROOT / "examples" / "default.lua"), "--frames", "1..2", "--size", "32x18",
         "--volume", "16", "--samples", "1", "--format", "exr", "--out", str(out), "--name", "lens", "--progress", "json"],
        capture_output=True, text=True,
    )
    assert done.returncode == 0, done.stderr
    assert bpy.ops.refrakt.load_frames(directory=str(out), name="lens", compositor=True) == {"FINISHED"}
    scene = bpy.context.scene
    node = submodule("compositor").tree(scene).nodes["refrakt frames"]
    assert {"Combined", "Alpha", "depth"} <= set(submodule("frames").pass_names(node))
    assert node.frame_duration == 2
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 32, 18, 100
    pixel, size = composite_pixel(scene, 1, tmp_path)
    assert size == (32, 18) and all(v == v for v in pixel)  # read, and not NaN
