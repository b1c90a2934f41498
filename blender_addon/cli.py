"""refrakt command lines for a Blender scene: the frame range, rate, size and camera are
Blender's own settings, so what refrakt renders matches what F12 would."""

import os
import struct

from . import extras, scene_export


def render_size(scene):
    """The frame's size in pixels as Blender's render pipeline takes it: the resolution times
    the percentage, rounded down (`(size · resolution) / 100` in whole numbers)."""
    r = scene.render
    return max(1, r.resolution_x * r.resolution_percentage // 100), max(1, r.resolution_y * r.resolution_percentage // 100)


def render_region(scene):
    """Blender's render region (Output ▸ Render Region, "border render") as refrakt's `--region`:
    (x, y, width, height) in pixels from the frame's top-left corner — the pixels Blender renders
    (the border's fractions of the frame, rounded down, y up from the bottom) — or None for the
    whole frame. Blender places the region in the frame itself (or crops to it)."""
    r = scene.render
    if not r.use_border:
        return None
    w, h = render_size(scene)
    x0, x1 = _pixel(r.border_min_x, w), _pixel(r.border_max_x, w)
    y0, y1 = _pixel(r.border_min_y, h), _pixel(r.border_max_y, h)
    if x1 <= x0 or y1 <= y0:
        return None  # (Blender refuses to render so small a region before the engine runs)
    return x0, h - y1, x1 - x0, y1 - y0


def _pixel(fraction, size):
    """A border's edge in pixels as Blender's C computes it: a float fraction times the size in
    single precision, rounded down (so 20/48 of 48 is 20, where doubles would give 19)."""
    return int(struct.unpack("f", struct.pack("f", fraction * size))[0])


def image_size(scene):
    """The size of the images refrakt writes for the scene: its render region's, or the frame's."""
    region = render_region(scene)
    return region[2:] if region else render_size(scene)


def _region(scene):
    region = render_region(scene)
    return ["--region", ",".join(str(v) for v in region)] if region else []


def scene_file(scene, paths):
    return paths.lua if scene.refrakt.source == "LUA" else paths.glb


def _common(scene, paths, blender_camera=True):
    args = ["--fps", f"{scene_export.fps(scene):.9g}"]
    if blender_camera:  # the scene camera at the render size (a view script brings its own)
        w, h = render_size(scene)
        args += ["--size", f"{w}x{h}", *(["--camera", scene.camera.name] if scene.camera is not None else [])]
    # refrakt reads files only below the scene's folder unless told otherwise: let it read the
    # World's image where it lies.
    image = extras.environment(scene, paths.directory, extras.Warnings()).get("image")
    if image is not None:
        folder = os.path.dirname(os.path.normpath(os.path.join(paths.directory, image)))
        if not _inside(folder, paths.directory):
            args += ["--allow-read", folder]
    return args


def _inside(path, folder):
    try:
        return os.path.commonpath([path, folder]) == folder
    except ValueError:  # another drive on Windows
        return False


def layers(scene):
    """The EXR layers (`render --layers`) the scene's view layers ask for: the beauty, and each
    pass on in a view layer that renders (Blender's Z pass is refrakt's depth; properties.py has
    refrakt's). refrakt reads back and encodes only those: a frame with its passes off is written
    sooner and smaller."""
    used = [v for v in scene.view_layers if v.use] or list(scene.view_layers)

    def asked(name):
        return any(v.use_pass_z if name == "depth" else getattr(v.refrakt, f"use_pass_{name}") for v in used)

    return ",".join(["beauty"] + [name for name in ("depth", "caustic", "direct", "volume", "indirect") if asked(name)])


def render(binary, scene, paths, frames=None, resume=None):
    """`refrakt render` of `frames` (first, last), by default the scene's range, with the layers
    the view layers ask for, of the render region where one is set; `resume` (default: the
    panel's Resume) skips frames whose files exist."""
    first, last = frames or (scene.frame_start, scene.frame_end)
    args = [
        binary, "render", scene_file(scene, paths),
        "--frames", f"{first}..{last}",
        "--out", paths.frames,
        "--name", paths.name,
        "--format", "exr",
        "--layers", layers(scene),
        "--progress", "json",
    ] + _common(scene, paths) + _region(scene)
    if scene.refrakt.skip_existing if resume is None else resume:
        args.append("--skip-existing")
    return args


def cluster(farm, binary, scene, paths):
    """`refrakt-farm render` of the scene's frame range on the Ray cluster at the scene's
    address: frames come back into the same folder, named as `render` names them. The options
    after `--` go to every refrakt (the farm passes those that choose files to `refrakt pack`),
    the layers the view layers ask for among them."""
    s = scene.refrakt
    args = [
        farm, "render", scene_file(scene, paths),
        "--frames", f"{scene.frame_start}..{scene.frame_end}",
        "--chunk", str(s.cluster_chunk),
        "--out", paths.frames,
        "--name", paths.name,
        "--format", "exr",
        "--progress", "json",
        "--refrakt", binary,
    ]
    if s.cluster_address.strip():
        args += ["--address", s.cluster_address.strip()]
    return args + ["--", "--layers", layers(scene)] + _common(scene, paths) + _region(scene)


def watch(binary, scene, paths):
    return [
        binary, "watch", scene_file(scene, paths),
        "--out", paths.preview,
        "--frame", str(scene.frame_current),
        "--progress", "json",
    ] + _common(scene, paths)


def watch_view(binary, scene, script, preview, frame):
    """`refrakt watch` of the viewport's script (scene_export.view_script): its camera carries
    the viewport's view and size, so neither --size nor --camera is given."""
    return [
        binary, "watch", script,
        "--out", preview,
        "--frame", str(frame),
        "--progress", "json",
    ] + _common(scene, scene_export.paths(scene), blender_camera=False)
