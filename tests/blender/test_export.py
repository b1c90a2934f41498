"""The export operator: what the .glb says (checked with an independent glTF evaluator against
Blender's own data) and the Lua wrapper next to it."""

import json
import math
import os
import subprocess
import tempfile

import bpy
import pytest
from mathutils import Vector

import scenes
from conftest import submodule
from gltf_eval import Gltf

# Matrices go through float32 in the file: 1e-5 relative, a few 1e-6 m absolute at these sizes.
MATRIX_TOLERANCE = 1e-4


def export(saved_blend):
    saved_blend()
    assert bpy.ops.refrakt.export() == {"FINISHED"}
    paths = submodule("scene_export").paths(bpy.context.scene)
    return paths, Gltf(paths.glb)


def assert_matrix_close(a, b, what):
    worst = max(abs(a[r][c] - b[r][c]) for r in range(4) for c in range(4))
    assert worst < MATRIX_TOLERANCE, f"{what}: matrices differ by {worst:.2e}\n{a}\n{b}"


def test_world_matrices_at_several_frames_match_blender(addon, saved_blend):
    scene = scenes.round_trip_scene()
    paths, gltf = export(saved_blend)
    fps = scene.render.fps / scene.render.fps_base
    for frame in scenes.FRAMES:
        scene.frame_set(frame)
        t = frame / fps
        for name in ("Ball", "Rig", "Cube"):
            obj = bpy.data.objects[name]
            expected = scenes.Z_UP_TO_Y_UP @ obj.matrix_world @ scenes.Z_UP_TO_Y_UP.inverted()
            assert_matrix_close(gltf.world(name, t), expected, f"{name} at frame {frame}")
        # Cameras and lights look down their local −Z in both conventions: compare where they
        # are and where they look, in glTF's world.
        for name in ("Camera", "Spot"):
            obj = bpy.data.objects[name]
            got, want = gltf.world(name, t), scenes.gltf_world(obj)
            for axis in (Vector((0, 0, -1, 0)), Vector((0, 1, 0, 0)), Vector((0, 0, 0, 1))):
                assert (got @ axis - want @ axis).length < MATRIX_TOLERANCE, f"{name} axis {axis} at frame {frame}"
    # The cube really moves, so the comparison above covers animation, not a still.
    assert (gltf.world("Cube", 1 / fps).translation - gltf.world("Cube", 6 / fps).translation).length > 0.5


def test_lights_camera_and_glass(addon, saved_blend):
    scene = scenes.round_trip_scene()
    _, gltf = export(saved_blend)
    # Blender's glTF exporter in its standard lighting mode: point/spot W → cd = W / 4π · 683,
    # sun W/m² → lux = · 683; refrakt divides by 683 again (as Blender's importer does).
    spot = gltf.light("Spot")
    assert spot["type"] == "spot"
    assert spot["intensity"] == pytest.approx(scenes.SPOT_WATTS / (4 * math.pi) * 683, rel=1e-5)
    assert spot["spot"]["outerConeAngle"] == pytest.approx(math.radians(20.0), rel=1e-5)
    assert spot["spot"]["innerConeAngle"] == pytest.approx(math.radians(20.0) * (1 - 0.15), rel=1e-5)
    assert gltf.light("Sun")["intensity"] == pytest.approx(scenes.SUN_STRENGTH * 683, rel=1e-5)

    camera = gltf.camera("Camera")["perspective"]
    assert camera["yfov"] == pytest.approx(scenes.camera_fov_y(bpy.data.objects["Camera"], scene), rel=1e-5)
    assert camera["aspectRatio"] == pytest.approx(64 / 36, rel=1e-5)

    glass = gltf.material("Glass")
    ext = glass["extensions"]
    assert ext["KHR_materials_ior"]["ior"] == pytest.approx(scenes.GLASS_IOR, rel=1e-6)
    assert ext["KHR_materials_transmission"]["transmissionFactor"] == pytest.approx(1.0)
    # Cycles' Volume Absorption: σa = density · (1 − color) per metre.
    sigma = [scenes.ABSORPTION_DENSITY * (1 - c) for c in scenes.ABSORPTION_COLOR]
    assert glass["extras"]["refrakt"]["absorption"] == pytest.approx(sigma, rel=1e-6)
    volume = ext["KHR_materials_volume"]
    transmitted = [c ** (1 / volume["attenuationDistance"]) for c in volume["attenuationColor"]]
    assert transmitted == pytest.approx([math.exp(-s) for s in sigma], rel=1e-6)
    for name in ("KHR_materials_ior", "KHR_materials_transmission", "KHR_materials_volume", "KHR_lights_punctual"):
        assert name in gltf.json["extensionsUsed"]


def pointer_channel(gltf, pointer):
    """The sampler of the channel aimed at `pointer` (KHR_animation_pointer)."""
    for anim in gltf.json.get("animations", []):
        for channel in anim["channels"]:
            if channel["target"].get("extensions", {}).get("KHR_animation_pointer", {}).get("pointer") == pointer:
                return anim["samplers"][channel["sampler"]]
    raise AssertionError(f"no channel aims at {pointer}")


def dumped_frames(real_refrakt, glb, scene, size):
    """`refrakt dump` of frames 1–5 of `glb` at the scene's frame rate, each document yielded
    with Blender's scene set to its frame."""
    fps = scene.render.fps / scene.render.fps_base
    done = subprocess.run([real_refrakt, "dump", glb, "--frames", "1..5", "--fps", str(fps), "--size", size],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    for doc in map(json.loads, done.stdout.splitlines()):
        scene.frame_set(doc["frame"])
        yield doc


def ball_glass_frames(real_refrakt, glb, scene):
    """(frame, the Ball's material) in `refrakt dump` of frames 1–5, Blender's scene at each."""
    for doc in dumped_frames(real_refrakt, glb, scene, "32x18"):
        ball = next(n for n in doc["nodes"] if n["name"] == "Ball")
        yield doc["frame"], doc["materials"][ball["material"]]


def test_animated_light_power_and_colour_reach_the_gltf_in_its_units(addon, saved_blend, real_refrakt):
    """A point light's power, a sun's strength, a light's colour and a camera's focal length keyed
    over the frames go out
    as KHR_animation_pointer channels that say, at every frame, what a still export of that
    frame says (W / 4π · 683 cd, W/m² · 683 lux); Blender 4.5's own channels were 4π (point)
    and 1/683 (sun) off. (The still `intensity` is the first frame's: the exporter gathers it
    while sampling the range.) A light by colour temperature with Normalize off is tinted and
    scaled by its area at every frame as its still value is. refrakt reads them back as the
    power Blender has at each frame."""
    scene = scenes.round_trip_scene()
    scene.frame_start, scene.frame_end = 1, 5
    point = bpy.data.lights.new("Bulb", "POINT")
    bpy.context.collection.objects.link(bpy.data.objects.new("Bulb", point))
    # A warm bulb by colour temperature, with Normalize off: its still value is tinted by the
    # temperature's colour and multiplied by its area; its channels must be too.
    warm = bpy.data.lights.new("Warm", "POINT")
    warm.use_temperature, warm.temperature, warm.normalize, warm.shadow_soft_size = True, 3000.0, False, 0.2
    warm_object = bpy.data.objects.new("Warm", warm)
    bpy.context.collection.objects.link(warm_object)
    sun = bpy.data.objects["Sun"].data
    for frame, watts, strength, green in ((1, 100.0, 2.0, 1.0), (5, 400.0, 6.0, 0.25)):
        point.energy, sun.energy, point.color = watts, strength, (1.0, green, 0.5)
        warm.energy, warm.color = watts / 2, (1.0, 1.0, green)
        for prop in ("energy", "color"):
            point.keyframe_insert(prop, frame=frame)
            warm.keyframe_insert(prop, frame=frame)
        sun.keyframe_insert("energy", frame=frame)
        camera = bpy.data.objects["Camera"]
        camera.data.lens = 50.0 if frame == 1 else 25.0
        camera.data.keyframe_insert("lens", frame=frame)
    scene.frame_set(3)
    paths, gltf = export(saved_blend)
    assert scene.frame_current == 3, "exporting leaves the current frame as it was"
    fps = scene.render.fps / scene.render.fps_base
    lights = gltf.json["extensions"]["KHR_lights_punctual"]["lights"]
    index = {name: gltf.node(name)["extensions"]["KHR_lights_punctual"]["light"] for name in ("Bulb", "Sun", "Warm")}
    channel = {name: pointer_channel(gltf, f"/extensions/KHR_lights_punctual/lights/{i}/intensity") for name, i in index.items()}
    warm_colour = pointer_channel(gltf, f"/extensions/KHR_lights_punctual/lights/{index['Warm']}/color")
    warm_area = warm.area(matrix_world=warm_object.matrix_world)
    colour = pointer_channel(gltf, f"/extensions/KHR_lights_punctual/lights/{index['Bulb']}/color")
    yfov = pointer_channel(gltf, f"/cameras/{gltf.node('Camera')['camera']}/perspective/yfov")
    powers = []
    for frame in range(1, 6):
        scene.frame_set(frame)
        t = frame / fps
        powers.append(point.energy)
        assert gltf._sample(channel["Bulb"], t)[0] == pytest.approx(point.energy / (4 * math.pi) * 683, rel=1e-4), frame
        assert gltf._sample(channel["Sun"], t)[0] == pytest.approx(sun.energy * 683, rel=1e-4), frame
        assert gltf._sample(colour, t) == pytest.approx(list(point.color), abs=1e-5), frame
        assert gltf._sample(channel["Warm"], t)[0] == pytest.approx(warm.energy * warm_area / (4 * math.pi) * 683, rel=1e-4), frame
        tinted = [c * k for c, k in zip(warm.color, warm.temperature_color)]
        assert gltf._sample(warm_colour, t) == pytest.approx(tinted, abs=1e-5), frame
        assert gltf._sample(yfov, t)[0] == pytest.approx(scenes.camera_fov_y(camera, scene), rel=1e-4), frame
    assert powers[0] == pytest.approx(100.0) and powers[-1] == pytest.approx(400.0), "the power really changes"
    assert lights[index["Bulb"]]["intensity"] == pytest.approx(min(powers) / (4 * math.pi) * 683, rel=1e-5)
    for doc in dumped_frames(real_refrakt, paths.glb, scene, "32x18"):
        bulb = next(light for light in doc["lights"] if light["node"] == "Bulb")
        # radiant intensity, W/sr, times the colour: P / 4π for a point light.
        want = [c * point.energy / (4 * math.pi) for c in point.color]
        assert bulb["radiant"] == pytest.approx(want, rel=1e-4), doc["frame"]
        lit = next(light for light in doc["lights"] if light["node"] == "Warm")
        want = [c * k * warm.energy * warm_area / (4 * math.pi) for c, k in zip(warm.color, warm.temperature_color)]
        assert lit["radiant"] == pytest.approx(want, rel=1e-4), doc["frame"]


def test_a_keyed_glass_index_and_glow_reach_refrakt_frame_by_frame(addon, saved_blend, real_refrakt):
    """A glass's IOR, Emission Strength and Base Color keyed in Blender (the Principled BSDF's:
    1.45 at frame 1 to 1.33 at frame 5, a glow of 2 to 6, white to blue) go out as Blender's
    KHR_animation_pointer channels into KHR_materials_ior, KHR_materials_emissive_strength and
    baseColorFactor, and refrakt's glass has Blender's index, glow and tint (√ of the Base
    Color, as the still export writes it) at every frame (`refrakt dump`)."""
    scene = scenes.round_trip_scene()
    scene.frame_start, scene.frame_end = 1, 5
    bsdf = bpy.data.materials["Glass"].node_tree.nodes["Principled BSDF"]
    ior, strength, base = bsdf.inputs["IOR"], bsdf.inputs["Emission Strength"], bsdf.inputs["Base Color"]
    bsdf.inputs["Emission Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    for frame, value, glow, colour in ((1, scenes.GLASS_IOR, 2.0, (1.0, 1.0, 1.0, 1.0)), (5, 1.33, 6.0, (0.25, 0.5, 1.0, 1.0))):
        ior.default_value, strength.default_value, base.default_value = value, glow, colour
        for socket in (ior, strength, base):
            socket.keyframe_insert("default_value", frame=frame)
    paths, gltf = export(saved_blend)
    glass_index = next(i for i, m in enumerate(gltf.json["materials"]) if m["name"] == "Glass")
    for leaf in ("KHR_materials_ior/ior", "KHR_materials_emissive_strength/emissiveStrength"):
        pointer_channel(gltf, f"/materials/{glass_index}/extensions/{leaf}")
    seen = []
    for frame, glass in ball_glass_frames(real_refrakt, paths.glb, scene):
        assert glass["kind"] == "glass" and glass["ior"] == pytest.approx(ior.default_value, abs=1e-4), frame
        glow = [c * glass["emission_strength"] for c in glass["emission"]]
        assert glow == pytest.approx([strength.default_value * c for c in (1.0, 0.5, 0.25)], rel=1e-4), frame
        # Principled glass tints by √(Base Color) at each surface, as the still export does.
        assert glass["tint"] == pytest.approx([math.sqrt(c) for c in base.default_value[:3]], abs=1e-4), frame
        seen.append(glass["ior"])
    assert seen[0] == pytest.approx(scenes.GLASS_IOR, abs=1e-4) and seen[-1] == pytest.approx(1.33, abs=1e-4), seen


def test_a_keyed_glass_bsdf_reaches_refrakt_frame_by_frame(addon, saved_blend, real_refrakt):
    """A Glass BSDF's IOR, Color and Roughness keyed in Blender (1.45 → 1.33, white → blue,
    polished → 0.4 over frames 1–5), which Blender's exporter does not understand, go out as
    KHR_animation_pointer channels the add-on samples every frame, and refrakt's glass has the
    Glass BSDF's values at every frame (its Color in full, as Cycles tints each surface)."""
    scene = scenes.round_trip_scene()
    scene.frame_start, scene.frame_end = 1, 5
    m = bpy.data.materials.new("Keyed glass")
    m.use_nodes = True
    nodes = m.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    bsdf = nodes.new("ShaderNodeBsdfGlass")
    m.node_tree.links.new(bsdf.outputs[0], nodes["Material Output"].inputs["Surface"])
    bpy.data.objects["Ball"].data.materials[0] = m
    ior, colour, roughness = bsdf.inputs["IOR"], bsdf.inputs["Color"], bsdf.inputs["Roughness"]
    for frame, values in ((1, (scenes.GLASS_IOR, (1.0, 1.0, 1.0, 1.0), 0.0)), (5, (1.33, (0.25, 0.5, 1.0, 1.0), 0.4))):
        ior.default_value, colour.default_value, roughness.default_value = values
        for socket in (ior, colour, roughness):
            socket.keyframe_insert("default_value", frame=frame)
    paths, gltf = export(saved_blend)
    index = next(i for i, mat in enumerate(gltf.json["materials"]) if mat["name"] == "Keyed glass")
    for pointer in ("extensions/KHR_materials_ior/ior", "pbrMetallicRoughness/baseColorFactor", "pbrMetallicRoughness/roughnessFactor"):
        pointer_channel(gltf, f"/materials/{index}/{pointer}")
    seen = []
    for frame, glass in ball_glass_frames(real_refrakt, paths.glb, scene):
        assert glass["kind"] == "glass" and glass["ior"] == pytest.approx(ior.default_value, abs=1e-4), frame
        assert glass["tint"] == pytest.approx(list(colour.default_value)[:3], abs=1e-4), frame
        assert glass["roughness"] == pytest.approx(roughness.default_value, abs=1e-4), frame
        seen.append((glass["ior"], glass["roughness"]))
    assert seen[0] == pytest.approx((scenes.GLASS_IOR, 0.0), abs=1e-4) and seen[-1] == pytest.approx((1.33, 0.4), abs=1e-4), seen


def test_depth_of_field_reaches_refrakts_thin_lens(addon, saved_blend, real_refrakt):
    """A camera's Depth of Field as Cycles sets up its lens: aperture = focal length / f-stop,
    blades and their rotation, the focus distance or a focus object's distance along the view;
    refrakt reads it back (`refrakt dump`)."""
    scene = scenes.round_trip_scene()
    camera = bpy.data.objects["Camera"]
    dof = camera.data.dof
    dof.use_dof, dof.aperture_fstop, dof.focus_distance = True, 2.8, 3.5
    dof.aperture_blades, dof.aperture_rotation = 6, math.radians(15.0)
    camera.data.lens = 50.0
    paths, gltf = export(saved_blend)
    lens = gltf.camera("Camera")["extras"]["refrakt"]
    assert lens["aperture"] == pytest.approx(0.050 / 2.8, rel=1e-6)
    assert lens["focus"] == pytest.approx(3.5, rel=1e-6)
    # Cycles turns the hexagon so a flat side faces Rotation; refrakt puts a corner there.
    assert lens["blades"] == 6 and lens["blade_rotation"] == pytest.approx(15.0 + 30.0, rel=1e-5)
    # Focused on the ball instead: its distance along the camera's view.
    ball = bpy.data.objects["Ball"]
    dof.focus_object = ball
    _, gltf = export(saved_blend)
    view = camera.matrix_world.to_3x3() @ Vector((0, 0, -1))
    along = (ball.matrix_world.translation - camera.matrix_world.translation).dot(view)
    assert gltf.camera("Camera")["extras"]["refrakt"]["focus"] == pytest.approx(along, rel=1e-4)
    done = subprocess.run([real_refrakt, "dump", paths.glb, "--camera", "Camera"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    got = json.loads(done.stdout.splitlines()[0])["camera"]["lens"]
    assert got["aperture"] == pytest.approx(0.050 / 2.8, rel=1e-5) and got["blades"] == 6
    assert got["focus"] == pytest.approx(along, rel=1e-4)
    # Without Depth of Field: no lens, a pinhole.
    dof.use_dof = False
    _, gltf = export(saved_blend)
    assert "refrakt" not in (gltf.camera("Camera").get("extras") or {})


def test_a_focus_pull_an_iris_a_shift_and_a_growing_bulb_reach_refrakt_frame_by_frame(addon, saved_blend, real_refrakt):
    """What glTF has no field for, keyed in Blender — the focus distance, the f-stop, Shift X and
    a spot's radius — goes out as pointer channels into refrakt's extras, which refrakt plays
    back (`refrakt dump`) at every frame as Blender has it; a focus object that moves pulls the
    focus with it. Nothing keyed: no channel (the still extras say it all)."""
    scene = scenes.round_trip_scene()
    scene.frame_start, scene.frame_end = 1, 5
    camera, spot = bpy.data.objects["Camera"].data, bpy.data.lights["Spot"]
    camera.dof.use_dof = True
    _, gltf = export(saved_blend)
    pointers = [c["target"].get("extensions", {}).get("KHR_animation_pointer", {}).get("pointer", "")
                for a in gltf.json.get("animations", []) for c in a["channels"]]
    assert not [p for p in pointers if "/extras/" in p], pointers
    for frame, focus, fstop, shift, radius in ((1, 2.0, 2.0, 0.0, 0.1), (5, 6.0, 8.0, 0.2, 0.4)):
        camera.dof.focus_distance, camera.dof.aperture_fstop, camera.shift_x = focus, fstop, shift
        spot.shadow_soft_size = radius
        for prop in ("dof.focus_distance", "dof.aperture_fstop", "shift_x"):
            camera.keyframe_insert(prop, frame=frame)
        spot.keyframe_insert("shadow_soft_size", frame=frame)
    paths, gltf = export(saved_blend)
    seen = []
    for doc in dumped_frames(real_refrakt, paths.glb, scene, "64x36"):
        lens = doc["camera"]["lens"]
        assert lens["focus"] == pytest.approx(camera.dof.focus_distance, rel=1e-5), doc["frame"]
        assert lens["aperture"] == pytest.approx(camera.lens * 1e-3 / camera.dof.aperture_fstop, rel=1e-5), doc["frame"]
        assert lens["shift"][0] == pytest.approx(camera.shift_x, abs=1e-6), doc["frame"]
        bulb = next(light for light in doc["lights"] if light["node"] == "Spot")
        assert bulb["radius"] == pytest.approx(spot.shadow_soft_size, rel=1e-5), doc["frame"]
        seen.append(lens["focus"])
    assert seen[0] == pytest.approx(2.0) and seen[-1] == pytest.approx(6.0) and len(set(seen)) == 5, seen
    # Focused on a ball that moves away along the view: the focus follows it.
    camera.animation_data_clear()
    ball, holder = bpy.data.objects["Ball"], bpy.data.objects["Camera"]
    camera.dof.focus_object = ball
    view = (holder.matrix_world.to_3x3() @ Vector((0, 0, -1))).normalized()
    for frame, away in ((1, 0.0), (5, 2.0)):
        ball.location = Vector((-1.0, 0.0, 0.5)) + away * view
        ball.keyframe_insert("location", frame=frame)
    _, gltf = export(saved_blend)
    focus = pointer_channel(gltf, f"/cameras/{gltf.node('Camera')['camera']}/extras/refrakt/focus")
    fps = scene.render.fps / scene.render.fps_base
    for frame in range(1, 6):
        scene.frame_set(frame)
        along = (ball.matrix_world.translation - holder.matrix_world.translation).dot(view)
        assert gltf._sample(focus, frame / fps)[0] == pytest.approx(along, rel=1e-4), frame


def test_motion_blur_reaches_refrakts_shutter(addon, saved_blend, real_refrakt):
    """Render ▸ Motion Blur's Shutter (frames) and the panel's Motion Steps go out as the scene's
    `shutter` and `motion_steps`, which refrakt reads (`refrakt dump`) for the glTF and for the
    Lua wrapper alike; off, there is no shutter."""
    scene = scenes.round_trip_scene()
    scene.render.use_motion_blur, scene.render.motion_blur_shutter = True, 0.75
    scene.refrakt.motion_steps = 12
    paths, gltf = export(saved_blend)
    extras = gltf.json["scenes"][gltf.json.get("scene", 0)]["extras"]["refrakt"]
    assert extras["shutter"] == pytest.approx(0.75) and extras["motion_steps"] == 12
    for file in (paths.glb, paths.lua):
        done = subprocess.run([real_refrakt, "dump", file, "--camera", "Camera"], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        assert json.loads(done.stdout.splitlines()[0])["motion_blur"] == {"shutter": pytest.approx(0.75), "steps": 12}, file
    scene.render.use_motion_blur = False
    _, gltf = export(saved_blend)
    assert "shutter" not in gltf.json["scenes"][gltf.json.get("scene", 0)]["extras"]["refrakt"]


def test_an_object_without_a_material_keeps_cycles_default_surface(addon, saved_blend):
    """Cycles shades a mesh without a material with a diffuse BSDF of colour 0.8; glTF's default
    material is a rough metal (no diffuse light, no caustics on it). The export writes Cycles'."""
    scenes.round_trip_scene()
    assert not any(slot.material for slot in bpy.data.objects["Cube"].material_slots)
    _, gltf = export(saved_blend)
    primitive = gltf.json["meshes"][gltf.node("Cube")["mesh"]]["primitives"][0]
    surface = gltf.json["materials"][primitive["material"]]
    assert surface["name"] == submodule("gltf_hooks").DEFAULT_SURFACE
    assert surface["pbrMetallicRoughness"]["baseColorFactor"] == pytest.approx([0.8, 0.8, 0.8, 1.0])
    assert surface["pbrMetallicRoughness"]["metallicFactor"] == 0
    assert surface["extensions"]["KHR_materials_specular"]["specularFactor"] == 0
    assert "KHR_materials_specular" in gltf.json["extensionsUsed"]
    # The ball keeps its own glass.
    ball = gltf.json["meshes"][gltf.node("Ball")["mesh"]]["primitives"][0]
    assert gltf.json["materials"][ball["material"]]["name"] == "Glass"


def test_light_radius_reaches_the_node_extras(addon, saved_blend):
    """Blender's light Radius (shadow_soft_size) of point and spot lights travels as
    nodes[i].extras.refrakt.light_radius (KHR_lights_punctual has no size), with whether the
    camera sees it (Ray Visibility ▸ Camera) as light_visible; suns have neither."""
    scenes.round_trip_scene()
    bpy.data.lights["Spot"].shadow_soft_size = 0.3
    next(o for o in bpy.data.objects if o.data == bpy.data.lights["Spot"]).visible_camera = True
    bulb = bpy.data.objects.new("Bulb", bpy.data.lights.new("Bulb", "POINT"))
    bulb.data.shadow_soft_size = 0.12
    bulb.visible_camera = False
    bpy.context.scene.collection.objects.link(bulb)
    _, gltf = export(saved_blend)
    assert gltf.node("Spot")["extras"]["refrakt"] == {"light_radius": pytest.approx(0.3), "light_visible": True}
    assert gltf.node("Bulb")["extras"]["refrakt"] == {"light_radius": pytest.approx(0.12), "light_visible": False}
    assert "refrakt" not in (gltf.node("Sun").get("extras") or {})


def test_principled_glass_reaches_khr_materials(addon, saved_blend):
    """What refrakt reads of a Principled BSDF arrives through Blender's own exporter:
    transmission, IOR, roughness and base colour — as its square root, refrakt's tint at each
    surface, since Cycles tints Principled glass by √(Base Color) at each (light through a solid
    comes out tinted by the Base Color once); where the Base Color also colours a diffuse base,
    the root goes to the extras' tint."""
    scenes.round_trip_scene()
    bsdf = bpy.data.materials["Glass"].node_tree.nodes["Principled BSDF"]
    bsdf.inputs["IOR"].default_value = 1.6
    bsdf.inputs["Roughness"].default_value = 0.25
    bsdf.inputs["Base Color"].default_value = (0.9, 0.8, 0.7, 1.0)
    _, gltf = export(saved_blend)
    glass = gltf.material("Glass")
    ext = glass["extensions"]
    assert ext["KHR_materials_transmission"]["transmissionFactor"] == pytest.approx(1.0)
    assert ext["KHR_materials_ior"]["ior"] == pytest.approx(1.6, rel=1e-6)
    pbr = glass["pbrMetallicRoughness"]
    assert pbr.get("roughnessFactor", 1.0) == pytest.approx(0.25, rel=1e-6)
    assert pbr["baseColorFactor"][:3] == pytest.approx([math.sqrt(c) for c in (0.9, 0.8, 0.7)], rel=1e-6)
    assert "KHR_materials_dispersion" not in ext, "no Abbe number set: no dispersion"
    assert "KHR_materials_specular" not in ext, "Specular IOR Level 0.5 and a white tint: the plain Fresnel"
    # Specular IOR Level and Tint reach the glass's KHR_materials_specular (level × 2 the factor).
    bsdf.inputs["Specular IOR Level"].default_value = 0.25
    bsdf.inputs["Specular Tint"].default_value = (1.0, 0.5, 0.25, 1.0)
    _, gltf = export(saved_blend)
    specular = gltf.material("Glass")["extensions"]["KHR_materials_specular"]
    assert specular["specularFactor"] == pytest.approx(0.5) and specular["specularColorFactor"] == pytest.approx([1.0, 0.5, 0.25])
    bsdf.inputs["Specular IOR Level"].default_value = 0.5
    bsdf.inputs["Specular Tint"].default_value = (1.0, 1.0, 1.0, 1.0)
    # Partly glass: the Base Color is also its diffuse base's, in full, so the factor stays and
    # the root goes to the extras as the tint alone.
    bsdf.inputs["Transmission Weight"].default_value = 0.5
    _, gltf = export(saved_blend)
    glass = gltf.material("Glass")
    assert glass["pbrMetallicRoughness"]["baseColorFactor"][:3] == pytest.approx((0.9, 0.8, 0.7), rel=1e-6)
    assert glass["extras"]["refrakt"]["tint"] == pytest.approx([math.sqrt(c) for c in (0.9, 0.8, 0.7)], rel=1e-6)


def test_the_abbe_number_goes_out_as_khr_materials_dispersion(addon, saved_blend):
    """Blender's glass BSDFs have no dispersion setting; the material's refrakt Abbe number
    travels as KHR_materials_dispersion's 20 / V_d, on glass only."""
    scenes.round_trip_scene()
    bpy.data.materials["Glass"].refrakt.abbe = 36.0
    _, gltf = export(saved_blend)
    assert gltf.material("Glass")["extensions"]["KHR_materials_dispersion"]["dispersion"] == pytest.approx(20 / 36, rel=1e-6)
    assert "KHR_materials_dispersion" in gltf.json["extensionsUsed"]


def test_scene_and_node_extras(addon, saved_blend):
    scene = scenes.round_trip_scene()
    s = scene.refrakt
    s.photons, s.samples, s.volume_resolution, s.volume_margin = 20000, 2, 48, 0.1
    s.fog, s.fog_density, s.fog_color, s.fog_absorption, s.fog_anisotropy = "CUSTOM", 0.2, (1.0, 0.5, 0.25), 0.05, 0.3
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(2, 0, 1))
    lens = bpy.context.object
    lens.name = "Lens"
    lens.refrakt.role, lens.refrakt.field = "FIELD", "LUNEBURG"
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 1))
    slab = bpy.context.object
    slab.name = "Slab"
    slab.scale = (1, 1, 1)
    slab.refrakt.role, slab.refrakt.field, slab.refrakt.use_bounds = "FIELD", "SLAB", False
    slab.refrakt.size, slab.refrakt.ior, slab.refrakt.gradient = (1.0, 2.0, 3.0), 1.4, 0.25
    bpy.ops.mesh.primitive_cube_add(size=4.0, location=(0, 0, 1))
    bounds = bpy.context.object
    bounds.name = "Bounds"
    s.volume_bounds = bounds

    _, gltf = export(saved_blend)
    extras = gltf.json["scenes"][gltf.json.get("scene", 0)]["extras"]["refrakt"]
    assert extras["photons"] == 20000 and extras["samples"] == 2
    assert extras["volume"]["resolution"] == 48
    assert extras["volume"]["min"] == pytest.approx([-2, -1, -2]) and extras["volume"]["max"] == pytest.approx([2, 3, 2])
    assert extras["fog"] == {"scattering": pytest.approx([0.2, 0.1, 0.05]), "absorption": pytest.approx([0.05] * 3), "g": pytest.approx(0.3)}
    env = extras["environment"]
    assert env["color"] == pytest.approx(list(scenes.WORLD_COLOR), rel=1e-6)
    assert env["intensity"] == pytest.approx(scenes.WORLD_STRENGTH) and env["visible"] is False

    assert gltf.node("Lens")["extras"]["refrakt"] == {"field": "luneburg", "radius": pytest.approx(0.7, rel=1e-3)}
    # Local Z (Blender's up) becomes the node's local Y in glTF: size (x, z, y).
    assert gltf.node("Slab")["extras"]["refrakt"] == {
        "field": "slab", "size": pytest.approx([1.0, 3.0, 2.0]), "ior": pytest.approx(1.4), "gradient": pytest.approx(0.25),
    }
    assert gltf.node("Bounds")["extras"]["refrakt"] == {"role": "ignore"}
    assert "extras" not in gltf.node("Ball")


def test_environment_image_and_rotation(addon, saved_blend, tmp_path):
    scenes.round_trip_scene()
    sky = bpy.data.images.new("sky", 8, 4, float_buffer=True)
    sky.filepath_raw = str(tmp_path / "sky.exr")
    sky.file_format = "OPEN_EXR"
    sky.save()
    world = bpy.context.scene.world
    nodes, links = world.node_tree.nodes, world.node_tree.links
    texture = nodes.new("ShaderNodeTexEnvironment")
    texture.image = sky
    mapping = nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value[2] = math.radians(90)
    links.new(mapping.outputs[0], texture.inputs["Vector"])
    links.new(texture.outputs["Color"], nodes["Background"].inputs["Color"])
    paths, gltf = export(saved_blend)
    env = gltf.json["scenes"][0]["extras"]["refrakt"]["environment"]
    assert env["image"] == os.path.relpath(tmp_path / "sky.exr", paths.directory)
    # Mapping turns the lookup direction, refrakt turns the environment: opposite signs.
    assert env["rotation"] == pytest.approx(-90.0) and env["intensity"] == pytest.approx(scenes.WORLD_STRENGTH)
    assert "color" not in env

    sky.pack()  # not on disk any more: refrakt cannot read it
    warnings = submodule("scene_export").export(bpy.context)
    assert any("Environment Texture of an image file on disk" in w for w in warnings), warnings


def test_glass_bsdf_becomes_khr_transmission(addon, saved_blend):
    scenes.round_trip_scene()
    m = bpy.data.materials.new("Water")
    m.use_nodes = True
    nodes = m.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    glass = nodes.new("ShaderNodeBsdfGlass")
    glass.inputs["IOR"].default_value = 1.33
    glass.inputs["Color"].default_value = (0.9, 0.95, 1.0, 1.0)
    m.node_tree.links.new(glass.outputs[0], nodes["Material Output"].inputs["Surface"])
    bpy.data.objects["Ball"].data.materials[0] = m
    _, gltf = export(saved_blend)
    water = gltf.material("Water")
    assert water["extensions"]["KHR_materials_transmission"]["transmissionFactor"] == 1.0
    assert water["extensions"]["KHR_materials_ior"]["ior"] == pytest.approx(1.33, rel=1e-6)
    assert water["pbrMetallicRoughness"]["baseColorFactor"] == pytest.approx([0.9, 0.95, 1.0, 1.0])
    assert water["pbrMetallicRoughness"]["roughnessFactor"] == pytest.approx(0.0)
    # Glass in Blender is a solid: the export says so, or glTF would make it thin-walled.
    assert water["extensions"]["KHR_materials_volume"]["thicknessFactor"] > 0


def test_roughness_and_thin_glass_reach_the_gltf(addon, saved_blend):
    scenes.round_trip_scene()
    frosted = bpy.data.materials["Glass"]
    frosted.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.35
    pane = bpy.data.materials.new("Pane")
    pane.use_nodes = True
    bsdf = pane.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Transmission Weight" if "Transmission Weight" in bsdf.inputs else "Transmission"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = 0.0
    bsdf.distribution = "GGX"  # single-scattering: refrakt's multiscatter = false
    pane.refrakt.surface = "THIN"
    frosted.refrakt.priority = 2
    bpy.context.scene.refrakt.volume_contact = 0.001
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.0, 0.0, 2.0))
    bpy.context.object.data.materials.append(pane)
    _, gltf = export(saved_blend)
    glass = gltf.material("Glass")
    assert glass["pbrMetallicRoughness"]["roughnessFactor"] == pytest.approx(0.35, rel=1e-6)
    assert glass["extras"]["refrakt"]["priority"] == 2
    assert "multiscatter" not in glass["extras"]["refrakt"], "Multiscatter GGX, the default, is refrakt's"
    assert gltf.json["scenes"][0]["extras"]["refrakt"]["volume"]["contact"] == pytest.approx(0.001)
    thin = gltf.material("Pane")
    assert thin["extras"]["refrakt"]["thin"] is True and thin["extras"]["refrakt"]["multiscatter"] is False
    assert "KHR_materials_volume" not in thin.get("extensions", {})
    assert "KHR_materials_transmission" in thin["extensions"]


def test_unreadable_volume_node_warns(addon, saved_blend):
    scenes.round_trip_scene()
    tree = bpy.data.materials["Glass"].node_tree
    texture = tree.nodes.new("ShaderNodeTexNoise")
    tree.links.new(texture.outputs["Fac"], tree.nodes["Volume Absorption"].inputs["Density"])
    saved_blend()
    warnings = submodule("scene_export").export(bpy.context)
    assert any("'Density' is driven by nodes" in w for w in warnings), warnings


def test_a_failing_hook_is_reported_not_hidden(addon, saved_blend, monkeypatch):
    scenes.round_trip_scene()
    saved_blend()

    def broken(*args):
        raise KeyError("Strength")

    monkeypatch.setattr(submodule("extras"), "scene_extras", broken)
    with pytest.raises(RuntimeError, match=r"refrakt's glTF export hook failed .*gather_scene_hook on 'Scene': KeyError: 'Strength'"):
        bpy.ops.refrakt.export()


def test_wrapper_is_written_kept_when_edited_and_refreshed_when_not(addon, saved_blend):
    scene = scenes.round_trip_scene()
    paths, _ = export(saved_blend)
    text = open(paths.lua).read()
    assert f'scene:add(r.gltf("{paths.name}.glb"))' in text
    assert "photons = 70000" in text and "resolution = 128" in text
    # Untouched: a re-export brings the new settings.
    scene.refrakt.photons = 12345
    export(saved_blend)
    assert "photons = 12345" in open(paths.lua).read()
    # Edited by hand: left alone.
    with open(paths.lua, "a") as f:
        f.write("-- my own node\n")
    scene.refrakt.photons = 999
    export(saved_blend)
    edited = open(paths.lua).read()
    assert edited.endswith("-- my own node\n") and "photons = 12345" in edited


def test_unsaved_file_exports_to_the_temporary_folder(addon):
    scenes.round_trip_scene()
    assert not bpy.data.filepath
    paths = submodule("scene_export").paths(bpy.context.scene)
    assert paths.directory.startswith(tempfile.gettempdir())
    assert bpy.ops.refrakt.export() == {"FINISHED"}
    assert os.path.isfile(paths.glb) and os.path.isfile(paths.lua)
