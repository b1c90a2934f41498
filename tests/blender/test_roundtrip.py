"""Round trip through refrakt itself: a scene built in Blender, exported by the add-on, and read
back by refrakt's glTF importer (`refrakt dump`, one JSON document per frame; schema in
docs/gltf.md), compared with Blender's own data at several frames.

Tolerances: transforms 1e-4 (float32 in the file and in refrakt, sizes of a few metres);
light intensities, IOR and FOV 1e-5 relative (float32); absorption 1e-4 relative (it goes
through exp and log when carried by KHR_materials_volume alone).
"""

import json
import math
import subprocess

import bpy
import pytest
from mathutils import Matrix, Vector

import scenes
from conftest import refrakt_supports, submodule

TRANSFORM_TOLERANCE = 1e-4


def dump(refrakt, scene_file):
    done = subprocess.run(
        [refrakt, "dump", scene_file, "--frames", "1..6", "--fps", "24", "--size", "64x36", "--camera", "Camera"],
        capture_output=True, text=True,
    )
    assert done.returncode == 0, done.stderr
    return {doc["frame"]: doc for doc in map(json.loads, done.stdout.splitlines())}


@pytest.fixture
def exported(addon, real_refrakt, saved_blend):
    if not refrakt_supports(real_refrakt, "dump"):
        pytest.skip("this refrakt build has no `refrakt dump` (it comes with the glTF importer, issue 7)")
    scene = scenes.round_trip_scene()
    saved_blend()
    assert bpy.ops.refrakt.export() == {"FINISHED"}
    return scene, submodule("scene_export").paths(scene)


@pytest.fixture
def dumped(exported, real_refrakt):
    scene, paths = exported
    return scene, dump(real_refrakt, paths.glb)


def column_major(values):
    return Matrix([[values[c * 4 + r] for c in range(4)] for r in range(4)])


def close(a, b, tolerance=TRANSFORM_TOLERANCE):
    return (Vector(a) - Vector(b)).length < tolerance


def node(doc, name):
    return next(n for n in doc["nodes"] if n["name"] == name)


def test_world_matrices_match_blender_at_several_frames(dumped):
    scene, frames = dumped
    for k in scenes.FRAMES:
        scene.frame_set(k)
        doc = frames[k]
        for name in ("Ball", "Rig", "Cube"):
            want = scenes.Z_UP_TO_Y_UP @ bpy.data.objects[name].matrix_world @ scenes.Z_UP_TO_Y_UP.inverted()
            got = column_major(node(doc, name)["world"])
            worst = max(abs(got[r][c] - want[r][c]) for r in range(4) for c in range(4))
            assert worst < TRANSFORM_TOLERANCE, f"{name} at frame {k}: off by {worst:.2e}\n{got}\n{want}"
    moved = column_major(node(frames[6], "Cube")["world"]).translation - column_major(node(frames[1], "Cube")["world"]).translation
    assert moved.length > 0.5


def test_camera_matches_blender(dumped):
    scene, frames = dumped
    cam = bpy.data.objects["Camera"]
    world = scenes.gltf_world(cam)
    for k in scenes.FRAMES:
        c = frames[k]["camera"]
        assert close(c["position"], world.translation)
        assert close(c["forward"], (world @ Vector((0, 0, -1, 0))).xyz)
        assert close(c["up"], (world @ Vector((0, 1, 0, 0))).xyz)
        assert c["yfov"] == pytest.approx(scenes.camera_fov_y(cam, scene), rel=1e-5)
        assert c["size"] == [64, 36]
        # Clip Start goes out as glTF's znear (Blender's exporter), where refrakt's rays start.
        assert c["clip_start"] == pytest.approx(cam.data.clip_start, rel=1e-5)


def test_lights_carry_blender_power(dumped):
    _, frames = dumped
    lights = {light["node"]: light for light in frames[1]["lights"]}
    spot, sun = lights["Spot"], lights["Sun"]
    color = list(bpy.data.lights["Spot"].color)
    # Blender: a spot of P watts has radiant intensity P / 4π W/sr (it is a masked point light).
    watts_per_sr = scenes.SPOT_WATTS / (4 * math.pi)
    assert spot["kind"] == "spot" and spot["unit"] == "cd"
    assert spot["intensity"] == pytest.approx(watts_per_sr * 683, rel=1e-5)
    assert spot["radiant"] == pytest.approx([c * watts_per_sr for c in color], rel=1e-5)
    assert spot["outer_cone_angle"] == pytest.approx(math.radians(20), rel=1e-4)
    assert spot["inner_cone_angle"] == pytest.approx(math.radians(20) * 0.85, rel=1e-4)
    world = scenes.gltf_world(bpy.data.objects["Spot"])
    assert close(spot["position"], world.translation)
    assert close(spot["direction"], (world @ Vector((0, 0, -1, 0))).xyz.normalized())
    assert sun["kind"] == "sun" and sun["radiant"] == pytest.approx([scenes.SUN_STRENGTH] * 3, rel=1e-5)
    assert spot["radius"] == pytest.approx(bpy.data.lights["Spot"].shadow_soft_size, rel=1e-6)


def test_glass_material(dumped):
    _, frames = dumped
    doc = frames[1]
    glass = doc["materials"][node(doc, "Ball")["material"]]
    assert glass["kind"] == "glass"
    assert glass["ior"] == pytest.approx(scenes.GLASS_IOR, rel=1e-5)
    sigma = [scenes.ABSORPTION_DENSITY * (1 - c) for c in scenes.ABSORPTION_COLOR]
    assert glass["absorption"] == pytest.approx(sigma, rel=1e-4, abs=1e-6)
    assert doc["photons"] == bpy.context.scene.refrakt.photons


def test_lua_wrapper_is_the_same_scene(exported, real_refrakt):
    """The generated wrapper (settings written out + r.gltf of the .glb) reads as the .glb does."""
    _, paths = exported
    from_glb, from_lua = dump(real_refrakt, paths.glb), dump(real_refrakt, paths.lua)
    for k in scenes.FRAMES:
        a, b = from_glb[k], from_lua[k]
        for key in ("position", "forward", "up", "yfov"):
            assert a["camera"][key] == pytest.approx(b["camera"][key], abs=1e-6)
        for name in ("Ball", "Rig", "Cube"):
            assert node(a, name)["world"] == pytest.approx(node(b, name)["world"], abs=1e-6)
        assert (a["photons"], a["samples"]) == (b["photons"], b["samples"])
        assert a["volume"]["dims"] == b["volume"]["dims"]
        for key in ("min", "max"):
            assert a["volume"][key] == pytest.approx(b["volume"][key], abs=1e-6)
