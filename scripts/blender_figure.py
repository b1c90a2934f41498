#!/usr/bin/env python3
"""Makes the guide's Blender figure (docs/blender.md) headless, through the add-on as a user would use it: a
Blender scene (floor, a glass ball and a Luneburg lens marked as refrakt index fields, a sun,
a sky-colored World) is rendered by refrakt with *Render Animation*, loaded back with *Frames in
Blender ▸ Compositor*, and composited by Blender (Cycles) over its own render of the scene.

Run with the bpy module's Python (scripts/test_blender.sh sets one up):

    ~/.cache/refrakt/venv-bpy-4.5.15/bin/python scripts/blender_figure.py \
        --refrakt target/release/refrakt --out docs/images

Writes blender_cycles.png (Blender alone), blender_refrakt.png (refrakt's beauty pass as
Blender loaded it) and blender_composite.png (the composite).
"""

import argparse
import math
import os
import pathlib
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="refrakt-figure-"))

import bpy  # noqa: E402
from mathutils import Vector  # noqa: E402

sys.path.insert(0, str(ROOT / "scripts"))
import build_blender_addon  # noqa: E402

MODULE = "bl_ext.user_default.refrakt"


def install(refrakt):
    zip_path = build_blender_addon.build(tempfile.mkdtemp())
    bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default", enable_on_install=True)
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.preferences.addons[MODULE].preferences.binary = refrakt


def material(name, color, glass=False):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    if glass:
        bsdf.inputs["Transmission Weight"].default_value = 1.0
        bsdf.inputs["Roughness"].default_value = 0.0
        absorption = m.node_tree.nodes.new("ShaderNodeVolumeAbsorption")
        absorption.inputs["Color"].default_value = (0.55, 0.75, 1.0, 1.0)
        absorption.inputs["Density"].default_value = 1.5
        m.node_tree.links.new(absorption.outputs[0], m.node_tree.nodes["Material Output"].inputs["Volume"])
    return m


def sky_image(path, width=1024, height=512):
    """An equirectangular sky made here (no downloads): blue above, a pale horizon, and colored
    posts around it every 30 degrees, so refraction shows where light comes from."""
    import numpy as np

    v = (np.arange(height) + 0.5) / height  # 0 at the bottom row (Blender's pixel order)
    u = (np.arange(width) + 0.5) / width
    elevation = (v - 0.5) * np.pi
    sky = np.empty((height, width, 4), np.float32)
    zenith, horizon, ground = np.array([0.15, 0.3, 0.8]), np.array([0.9, 0.85, 0.75]), np.array([0.25, 0.22, 0.2])
    up = np.clip(elevation / (np.pi / 2), 0, 1)[:, None] ** 0.5
    sky[..., :3] = np.where(elevation[:, None, None] > 0, horizon + (zenith - horizon) * up[..., None], ground)
    posts = (np.floor(u * 12) % 2 == 0) & (np.abs((u * 12) % 1 - 0.5) < 0.15)
    band = (elevation > 0) & (elevation < np.radians(25))
    colors = np.array([[1.6, 0.3, 0.2], [0.2, 1.2, 0.3], [0.3, 0.4, 1.6]])
    which = (np.floor(u * 12) // 2 % 3).astype(int)
    mask = band[:, None] & posts[None, :]
    sky[..., :3][mask] = np.broadcast_to(colors[which][None, :, :], mask.shape + (3,))[mask]
    sky[..., 3] = 1.0
    image = bpy.data.images.new("sky", width, height, float_buffer=True)
    image.pixels.foreach_set(sky.ravel())
    image.filepath_raw = str(path)
    image.file_format = "OPEN_EXR"
    image.save()
    return image


def build_scene(folder):
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 480, 270, 100
    scene.frame_start = scene.frame_end = 1
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 32
    scene.cycles.device = "CPU"

    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location = (0.0, -3.0, 0.9)
    cam.rotation_euler = (Vector((0.0, 0.0, 0.3)) - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 40
    scene.camera = cam

    bpy.ops.mesh.primitive_plane_add(size=8)
    floor = bpy.context.object
    floor.name = "Floor"
    floor.data.materials.append(material("Floor", (0.6, 0.6, 0.6)))

    for name, x, field in (("Lens", -0.55, "LUNEBURG"), ("Ball", 0.55, "SPHERE")):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.4, location=(x, 0.0, 0.4), segments=48, ring_count=24)
        obj = bpy.context.object
        obj.name = name
        obj.data.materials.append(material(name, (1, 1, 1), glass=True))
        obj.refrakt.role, obj.refrakt.field, obj.refrakt.ior = "FIELD", field, 1.5

    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(35), 0, math.radians(25))
    scene.collection.objects.link(sun)

    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    texture = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    texture.image = sky_image(folder / "sky.exr")
    world.node_tree.links.new(texture.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
    scene.world = world

    s = scene.refrakt
    s.volume_resolution, s.samples, s.photons = 96, 4, 20000
    s.directory = str(folder) + os.sep
    s.basename = "figure"
    bpy.ops.wm.save_as_mainfile(filepath=str(folder / "figure.blend"))
    return scene


def render_png(scene, path):
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--refrakt", required=True, help="the refrakt executable")
    parser.add_argument("--out", default=str(ROOT / "docs" / "images"))
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    install(os.path.abspath(args.refrakt))
    scene = build_scene(pathlib.Path(tempfile.mkdtemp(prefix="refrakt-figure-scene-")))

    render_png(scene, out / "blender_cycles.png")
    assert bpy.ops.refrakt.render() == {"FINISHED"}

    # refrakt's beauty alone, as Blender reads it: the pass shown through the compositor.
    scene.refrakt.pass_caustic = scene.refrakt.pass_volume = False
    bpy.ops.refrakt.load_frames(compositor=True)
    compositor = sys.modules[MODULE + ".compositor"]
    tree = compositor.tree(scene)
    output = compositor.nodes_api().output(tree)
    tree.links.new(tree.nodes["refrakt frames"].outputs["Combined"], output)
    render_png(scene, out / "blender_refrakt.png")

    scene.refrakt.pass_caustic = scene.refrakt.pass_volume = True
    bpy.ops.refrakt.load_frames(compositor=True)
    render_png(scene, out / "blender_composite.png")


if __name__ == "__main__":
    main()
