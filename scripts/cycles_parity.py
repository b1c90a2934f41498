#!/usr/bin/env python3
"""The Cycles parity suite: Blender scenes built by script — a glass ball on a floor under a sun,
a spot, an area light, a uniform sky and an HDRI sky with a sun in it; tinted, frosted and fully
rough glass, the Stanford bunny (from ../shared/assets) and a glass of water under the sun —
each rendered by
Cycles (converged: many samples, caustics on, no clamp, box pixel filter) and by refrakt through
its render engine, and scored over the whole image and over the caustic region.

    python cycles_parity.py reference --out tests/data/cycles   # Cycles, 128×72 at 4096 spp,
                                                                 # kept as 64×36 (2×2 means)
    python cycles_parity.py table --refrakt target/release/refrakt --references target/parity
                                                                 # the full-size table and strip
    python cycles_parity.py noise --refrakt target/release/refrakt
                                      # frosted glass: refrakt's noise at 16 spp, Cycles' at 64

Run it with the bpy of scripts/test_blender.sh (`~/.cache/refrakt/venv-bpy-4.5.15/bin/python`),
which also has OpenEXR and flip-evaluator. `reference` writes the full-size renders beside the
small ones (`<scene>_full.exr`, not kept in the repository). tests/blender/test_parity.py renders
the small versions with refrakt in CI against the kept references, with bounds per scene.

Scores (refrakt against Cycles, linear RGB): `l1`, Σ|refrakt − Cycles| / Σ Cycles over the image;
`caustic_l1`, the same over the caustic region (where refrakt's caustic pass is above a tenth of
its 99th percentile, grown by a pixel); `light`, Σ refrakt / Σ Cycles (energy); `flip`, the mean
HDR-FLIP error (NVIDIA's `flip-evaluator`).
"""

import argparse
import math
import os
import pathlib
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
MODULE = "bl_ext.user_default.refrakt"

FULL_SIZE = (128, 72)
SMALL_SIZE = (64, 36)
REFERENCE_SAMPLES = 4096
# refrakt's settings: (photons, samples, volume resolution) for the small (CI) and full renders.
REFRAKT_SMALL = (200_000, 16, 64)
REFRAKT_FULL = (1_000_000, 64, 128)

BALL_RADIUS = 0.3
SUN_DIRECTION = (0.8, -0.5, 1.2)  # toward the sun, Blender's Z up
BUNNY = ROOT.parent / "shared" / "assets" / "bunny.obj"  # the Stanford bunny, beside the clone
BUNNY_HEIGHT = 0.5
# An equirectangular sky made by `write_hdri` (a gradient, a dark ground, a sun 10° across).
HDRI = ROOT / "tests" / "data" / "cycles" / "hdri_sky.exr"
# name: (light, glass base colour, glass roughness, glass shape)
SCENES = {
    "sun": ("SUN", (1.0, 1.0, 1.0), 0.0, "ball"),
    "spot": ("SPOT", (1.0, 1.0, 1.0), 0.0, "ball"),
    "area": ("AREA", (1.0, 1.0, 1.0), 0.0, "ball"),
    "sky": ("SKY", (1.0, 1.0, 1.0), 0.0, "ball"),
    "hdri": ("HDRI", (1.0, 1.0, 1.0), 0.0, "ball"),
    "tinted": ("SUN", (0.95, 0.6, 0.35), 0.0, "ball"),
    "frosted": ("SUN", (1.0, 1.0, 1.0), 0.15, "ball"),
    "bunny": ("SUN", (1.0, 1.0, 1.0), 0.0, "bunny"),
    "rough": ("SUN", (1.0, 1.0, 1.0), 1.0, "ball"),
    "water": ("SUN", (1.0, 1.0, 1.0), 0.0, "water"),
}
# The glass of water, as Blender users model one: a tumbler (outer radius, height, wall and
# bottom thickness, m; large, to fill the small frame as the ball does) resting on the floor, and
# the water in it a cylinder to WATER_LEVEL that reaches WATER_OVERLAP into the glass's wall and
# bottom (refrakt's priority rule gives the overlap to the water, the smaller box, and crosses
# glass to water as one interface; Cycles meets the two surfaces there one after the other).
TUMBLER = (0.2, 0.5, 0.015, 0.03)
WATER_LEVEL = 0.34
WATER_OVERLAP = 0.001


def look_at(obj, target):
    from mathutils import Vector

    obj.rotation_euler = (Vector(target) - obj.location).to_track_quat("-Z", "Y").to_euler()


def write_hdri(path, width=128, height=64):
    """An equirectangular sky as Blender maps one (u = atan2(y, −x)/2π + ½, v = elevation/π + ½):
    radiance 0.3 at the horizon rising to 0.6 overhead, a dark ground (0.05), and a sun 10°
    across toward SUN_DIRECTION whose disc gives 4 W/m² (the `sun` scene's), in linear RGB."""
    v, u = np.meshgrid((np.arange(height)[::-1] + 0.5) / height, (np.arange(width) + 0.5) / width, indexing="ij")
    phi, theta = (u - 0.5) * 2.0 * np.pi, (v - 0.5) * np.pi
    d = np.stack([-np.cos(phi) * np.cos(theta), np.sin(phi) * np.cos(theta), np.sin(theta)], axis=-1)
    sky = np.where(theta[..., None] > 0, (0.3 + 0.3 * np.sin(theta))[..., None] * np.array([0.8, 0.9, 1.0]), 0.05)
    sun = np.array(SUN_DIRECTION) / np.linalg.norm(SUN_DIRECTION)
    half_angle = math.radians(5.0)
    disc = (d @ sun) > math.cos(half_angle)
    sky[disc] = 4.0 / (2.0 * np.pi * (1.0 - math.cos(half_angle)))
    write_rgb(path, sky)


def add_light(bpy, scene, kind):
    """The scene's light: a sun 10° across (wide enough for Cycles' path tracer to find its
    caustic), a spot and a square area light with a size, a sky (a uniform World), or an HDRI
    World (`write_hdri`'s image on an Environment Texture)."""
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.6, 0.7, 0.9, 1.0) if kind == "SKY" else (0.0, 0.0, 0.0, 1.0)
    scene.world = world
    if kind == "HDRI":
        texture = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
        texture.image = bpy.data.images.load(str(HDRI))
        world.node_tree.links.new(texture.outputs["Color"], background.inputs["Color"])
    if kind in ("SKY", "HDRI"):
        return
    data = bpy.data.lights.new("Light", kind)
    light = bpy.data.objects.new("Light", data)
    scene.collection.objects.link(light)
    if kind == "SUN":
        data.energy, data.angle = 4.0, math.radians(10.0)
        light.location = SUN_DIRECTION
    elif kind == "SPOT":
        data.energy, data.spot_size, data.spot_blend, data.shadow_soft_size = 250.0, math.radians(60.0), 0.1, 0.1
        light.location = (0.9, -0.9, 2.2)
    else:
        data.energy, data.shape, data.size = 120.0, "SQUARE", 0.6
        light.location = (0.7, -0.7, 2.0)
    look_at(light, (0.0, 0.0, 0.0))


def glass_material(bpy, color, roughness, ior=1.5, name="Glass"):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Transmission Weight"].default_value = 1.0
    bsdf.inputs["IOR"].default_value = ior
    return m


def add_glass_of_water(bpy):
    """The tumbler (TUMBLER: a cylinder less a cylinder, its rims sharp, its sides smooth) resting
    on the floor, the active object, and the water in it (IOR 1.33)."""
    radius, height, wall, bottom = TUMBLER
    segments = 64
    bpy.ops.mesh.primitive_cylinder_add(vertices=segments, radius=radius - wall, depth=height, location=(0.0, 0.0, bottom + height / 2))
    hollow = bpy.context.object
    bpy.ops.mesh.primitive_cylinder_add(vertices=segments, radius=radius, depth=height, location=(0.0, 0.0, height / 2))
    tumbler = bpy.context.object
    cut = tumbler.modifiers.new("Hollow", "BOOLEAN")
    cut.operation, cut.object, cut.solver = "DIFFERENCE", hollow, "EXACT"
    bpy.ops.object.modifier_apply(modifier=cut.name)
    bpy.data.objects.remove(hollow)
    bpy.ops.object.shade_smooth_by_angle(angle=math.radians(30.0))
    depth = WATER_LEVEL - bottom + WATER_OVERLAP
    bpy.ops.mesh.primitive_cylinder_add(vertices=segments, radius=radius - wall + WATER_OVERLAP, depth=depth,
                                        location=(0.0, 0.0, bottom - WATER_OVERLAP + depth / 2))
    water = bpy.context.object
    water.name = "Water"
    bpy.ops.object.shade_smooth_by_angle(angle=math.radians(30.0))
    water.data.materials.append(glass_material(bpy, (1.0, 1.0, 1.0), 0.0, ior=1.33, name="Water"))
    bpy.context.view_layer.objects.active = tumbler
    tumbler.select_set(True)


def add_bunny(bpy):
    """The Stanford bunny (OBJ, Y up, as Blender's importer turns it), BUNNY_HEIGHT tall,
    centred, 1 cm above the floor: the active object."""
    from mathutils import Vector

    bpy.ops.wm.obj_import(filepath=str(BUNNY))
    bunny = bpy.context.selected_objects[0]
    bpy.context.view_layer.objects.active = bunny
    corners = [bunny.matrix_world @ Vector(c) for c in bunny.bound_box]
    lo = Vector([min(c[i] for c in corners) for i in range(3)])
    hi = Vector([max(c[i] for c in corners) for i in range(3)])
    k = BUNNY_HEIGHT / (hi.z - lo.z)
    bunny.scale = (k * bunny.scale.x, k * bunny.scale.y, k * bunny.scale.z)
    centre = (lo + hi) / 2
    bunny.location = (bunny.location - Vector((centre.x, centre.y, lo.z))) * k + Vector((0.0, 0.0, 0.01))
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)


def build(bpy, name, size, refrakt_settings):
    """Scene `name` of SCENES at `size`: a smooth glass ball (r = 0.3 m) just above a floor of
    Cycles' default surface (no material: diffuse 0.8, as refrakt exports it), seen from 2 m."""
    light, color, roughness, shape = SCENES[name]
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.frame_start = scene.frame_end = scene.frame_current = 1
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    camera.location = (0.0, -1.7, 1.0)
    look_at(camera, (0.0, 0.0, 0.2))
    camera.data.lens = 35.0
    scene.camera = camera
    bpy.ops.mesh.primitive_plane_add(size=6.0)
    bpy.context.object.name = "Floor"
    if shape == "ball":
        bpy.ops.mesh.primitive_uv_sphere_add(radius=BALL_RADIUS, location=(0.0, 0.0, BALL_RADIUS + 0.01), segments=48, ring_count=24)
        bpy.ops.object.shade_smooth()
    elif shape == "bunny":
        add_bunny(bpy)
        bpy.ops.object.shade_smooth()
    else:
        add_glass_of_water(bpy)
    ball = bpy.context.object
    ball.name = "Ball"
    ball.data.materials.append(glass_material(bpy, color, roughness))
    add_light(bpy, scene, light)
    if hasattr(scene, "refrakt"):  # the add-on is installed (not needed for Cycles alone)
        s = scene.refrakt
        s.photons, s.samples, s.volume_resolution = refrakt_settings
    scene.view_settings.view_transform = "Standard"
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):  # Blender 5.0: multilayer images are a media type
        settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format, settings.color_depth, settings.exr_codec = "OPEN_EXR_MULTILAYER", "32", "ZIP"
    scene.render.use_file_extension = True
    scene.render.film_transparent = False
    return scene


def cycles_settings(scene, samples, diffuse_bounces=1, seed=0):
    """Cycles as a reference: no adaptive sampling, denoising or clamping, caustics on, a box
    pixel filter one pixel wide (refrakt's pixels are boxes), glass bounces enough for a ball."""
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = seed
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.max_bounces = 16
    c.diffuse_bounces = diffuse_bounces
    c.glossy_bounces = c.transmission_bounces = 16
    c.transparent_max_bounces = 8
    c.volume_bounces = 0
    c.caustics_reflective = c.caustics_refractive = True
    c.blur_glossy = 0.0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.use_auto_tile = False
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"


def render(bpy, scene, path):
    scene.render.filepath = str(path)
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    return pathlib.Path(str(path) + ".exr") if not str(path).endswith(".exr") else pathlib.Path(path)


def passes(path):
    """A multilayer EXR's passes as {pass: (h, w, channels)}, rows from the top, read by OpenEXR's
    own bindings (Blender 5.0 writes a part per pass); a plain RGB file is one pass, Combined."""
    import OpenEXR

    grouped = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for part in f.parts:
            for name, c in part.channels.items():
                layer, channel = (["Combined"] + name.split("."))[-2:]
                grouped.setdefault(layer, {})[channel] = np.asarray(c.pixels, dtype=np.float64)
    return {p: np.stack([c[k] for k in "RGBAZ" if k in c], axis=-1) for p, c in grouped.items()}


def half_size(rgb):
    """2 × 2 means: a box-filtered image at half the size, as if rendered there."""
    h, w = rgb.shape[0] // 2, rgb.shape[1] // 2
    return rgb[: 2 * h, : 2 * w].reshape(h, 2, w, 2, -1).mean(axis=(1, 3))


def write_rgb(path, rgb):
    import OpenEXR

    channels = {c: rgb[..., i].astype(np.float32) for i, c in enumerate("RGB")}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(header, channels).write(str(path))


def read_rgb(path):
    return passes(path)["Combined"][..., :3]


def caustic_region(caustic):
    """Where refrakt's caustic pass is above a tenth of its 99th percentile, grown by a pixel."""
    level = caustic.mean(axis=-1)
    mask = level > 0.1 * np.percentile(level, 99)
    grown = mask.copy()
    for dy, dx in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        grown |= np.roll(mask, (dy, dx), axis=(0, 1))
    return grown


def score(got, reference, region):
    import flip_evaluator

    l1 = float(np.abs(got - reference).sum() / reference.sum())
    inside = region[..., None].repeat(3, axis=-1)
    caustic_l1 = float(np.abs(got - reference)[inside].sum() / max(reference[inside].sum(), 1e-12))
    _, flip, _ = flip_evaluator.evaluate(reference.astype(np.float32), got.astype(np.float32), "HDR", applyMagma=False)
    return {"l1": l1, "caustic_l1": caustic_l1, "light": float(got.sum() / reference.sum()), "flip": float(flip)}


def refrakt_render(bpy, name, size, settings, folder, binary):
    """refrakt (`binary`) through the render engine (F12): its Combined and caustic passes."""
    scene = build(bpy, name, size, settings)
    bpy.context.preferences.addons[MODULE].preferences.binary = binary
    scene.render.engine = "REFRAKT"
    scene.view_layers[0].refrakt.use_pass_caustic = True
    scene.refrakt.directory = str(folder / f"{name}_export")
    return refrakt_passes(render(bpy, scene, folder / f"{name}_refrakt"))


def refrakt_passes(path):
    p = passes(path)
    return p["Combined"][..., :3], p["caustic"][..., :3]


def ball_pixels(bpy, scene):
    """Which pixels' centres see the ball (rows from the top): the camera's rays cast into the
    scene by Blender itself."""
    from mathutils import Vector

    camera = scene.camera
    depsgraph = bpy.context.evaluated_depsgraph_get()
    corners = [camera.matrix_world @ v for v in camera.data.view_frame(scene=scene)]  # tr, br, bl, tl
    origin = camera.matrix_world.translation
    w, h = scene.render.resolution_x, scene.render.resolution_y
    mask = np.zeros((h, w), dtype=bool)
    for row in range(h):
        for col in range(w):
            u, v = (col + 0.5) / w, (row + 0.5) / h
            top = corners[3].lerp(corners[0], u)
            bottom = corners[2].lerp(corners[1], u)
            direction = (top.lerp(bottom, v) - origin).normalized()
            hit, _, _, _, obj, _ = scene.ray_cast(depsgraph, origin, Vector(direction))
            mask[row, col] = hit and obj.name == "Ball"
    return mask


def noise(bpy, size, refrakt_settings, work, binary, cycles_samples=64, samples=(16, 256)):
    """The frosted ball's noise — the RMS of a render's deviation from its own converged mean over
    the pixels that see the ball, over that mean — for Cycles at `cycles_samples` (two seeds: the
    RMS of their difference / √2) and for refrakt at samples[0] (against samples[1] of the same
    photons, whose camera samples include the first's: the difference's RMS / √(1 − s0/s1))."""
    photons, _, resolution = refrakt_settings
    scene = build(bpy, "frosted", size, refrakt_settings)
    ball = ball_pixels(bpy, scene)
    runs = []
    for seed in (1, 2):
        cycles_settings(scene, cycles_samples, seed=seed)
        runs.append(read_rgb(render(bpy, scene, work / f"frosted_cycles_{cycles_samples}_{seed}")))
    mean = 0.5 * (runs[0] + runs[1])
    cycles = float(np.sqrt(((runs[0] - runs[1])[ball] ** 2).mean() / 2.0) / mean[ball].mean())
    for n in samples:
        (work / f"spp{n}").mkdir(parents=True, exist_ok=True)
    few, many = (refrakt_render(bpy, "frosted", size, (photons, n, resolution), work / f"spp{n}", binary)[0] for n in samples)
    refrakt = float(np.sqrt(((few - many)[ball] ** 2).mean() / (1.0 - samples[0] / samples[1])) / many[ball].mean())
    return {"cycles": cycles, "refrakt": refrakt, "pixels": int(ball.sum())}


# --- the command line ---------------------------------------------------------------------------

def install_addon(bpy):
    sys.path.insert(0, str(ROOT / "scripts"))
    import build_blender_addon

    zip_path = build_blender_addon.build(tempfile.mkdtemp())
    bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default", enable_on_install=True)


def references(bpy, out, samples, only):
    import time

    out.mkdir(parents=True, exist_ok=True)
    if not HDRI.is_file():
        write_hdri(HDRI)
    for name in [n for n in SCENES if not only or n in only]:
        scene = build(bpy, name, FULL_SIZE, REFRAKT_FULL)
        cycles_settings(scene, samples, seed=7919)
        started = time.perf_counter()
        full = read_rgb(render(bpy, scene, out / f"{name}_full"))
        write_rgb(out / f"{name}.exr", half_size(full))
        print(f"{name}: Cycles {FULL_SIZE[0]}×{FULL_SIZE[1]} at {samples} spp in {time.perf_counter() - started:.0f} s, "
              f"kept at {SMALL_SIZE[0]}×{SMALL_SIZE[1]}", flush=True)


def table(bpy, refs, work, binary, only):
    """The table and the picture of every scene: those in `only` (all when empty) rendered anew,
    the others read from an earlier run's files in `work` where they are there."""
    from compare_plot import png_of_image

    rows = ["| scene | relative L1 | caustic region L1 | light (refrakt / Cycles) | mean HDR-FLIP |", "| --- | --- | --- | --- | --- |"]
    strips = []
    for name in SCENES:
        reference = read_rgb(refs / f"{name}_full.exr")
        earlier = work / f"{name}_refrakt.exr"
        if only and name not in only and earlier.is_file():
            got, caustic = refrakt_passes(earlier)
        else:
            got, caustic = refrakt_render(bpy, name, FULL_SIZE, REFRAKT_FULL, work, binary)
        s = score(got, reference, caustic_region(caustic))
        rows.append(f"| {name} | {s['l1']:.3f} | {s['caustic_l1']:.3f} | {s['light']:.3f} | {s['flip']:.3f} |")
        strips.append(np.concatenate([reference, got], axis=1))
        print(rows[-1], flush=True)
    png_of_image(work / "parity.png", np.concatenate(strips, axis=0))
    print("\n".join(rows))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("step", choices=["reference", "table", "noise"])
    parser.add_argument("--out", default=str(ROOT / "target" / "parity"), help="reference: where the renders go")
    parser.add_argument("--samples", type=int, default=REFERENCE_SAMPLES, help="reference: Cycles' samples per pixel")
    parser.add_argument("--refrakt", help="table: the refrakt binary")
    parser.add_argument("--references", default=str(ROOT / "target" / "parity"), help="table: reference's --out")
    parser.add_argument("--scenes", nargs="*", default=[], choices=list(SCENES), help="reference, table: only these scenes (table: the others from earlier files)")
    args = parser.parse_args()
    os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="refrakt-parity-"))
    import bpy

    if args.step == "reference":
        references(bpy, pathlib.Path(args.out), args.samples, set(args.scenes))
    elif args.step == "noise":
        if not args.refrakt:
            parser.error("noise needs --refrakt PATH")
        install_addon(bpy)
        work = pathlib.Path(args.out) / "noise"
        work.mkdir(parents=True, exist_ok=True)
        n = noise(bpy, FULL_SIZE, REFRAKT_FULL, work, os.path.abspath(args.refrakt))
        print(f"frosted glass, noise over the ball's {n['pixels']} pixels: Cycles at 64 spp {n['cycles']:.4f}, "
              f"refrakt at 16 spp {n['refrakt']:.4f}")
    else:
        if not args.refrakt:
            parser.error("table needs --refrakt PATH")
        install_addon(bpy)
        work = pathlib.Path(args.out)
        work.mkdir(parents=True, exist_ok=True)
        table(bpy, pathlib.Path(args.references), work, os.path.abspath(args.refrakt), set(args.scenes))


if __name__ == "__main__":
    main()
