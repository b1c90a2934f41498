"""refrakt's EXR frames back in Blender as an image sequence (the image editor, the compositor's
Image node; compositor.py wires the passes over Blender's own render).

refrakt writes one-part EXRs with the beauty as plain `R G B A` and the other layers as
`<pass>.<channel>` (`depth.Z`, `caustic.R`, `volume.R`, …). Blender reads such a file as a
multilayer image whose one (unnamed) layer has the passes Combined, depth, caustic, direct,
indirect, volume: the compositor's Image node shows each as its own socket.
"""

import os
import re

import bpy

FRAME_NAME = re.compile(r"^(?P<name>.+)\.(?P<k>\d{4,})\.exr$")

# Names of the images and nodes this add-on owns, so loading again updates instead of adding.
NODE_PREFIX = "refrakt "


class FramesError(Exception):
    pass


def find_frames(directory, name):
    """Frame numbers of `name.<k:04>.exr` files in `directory`, sorted."""
    try:
        files = os.listdir(directory)
    except OSError:
        raise FramesError(f"The frames folder {directory} does not exist: render with refrakt first.") from None
    frames = sorted(int(m["k"]) for m in map(FRAME_NAME.match, files) if m and m["name"] == name)
    if not frames:
        raise FramesError(f"No frames named {name}.####.exr in {directory}: render with refrakt first.")
    return frames


def load_sequence(directory, name):
    """The frames as one image sequence; returns (image, first frame, frame count). Gaps in the
    numbering are allowed: Blender shows the nearest frame before a missing one."""
    frames = find_frames(directory, name)
    first, last = frames[0], frames[-1]
    # refrakt pads frame numbers to the digits of the range's last frame (at least 4).
    path = os.path.join(directory, f"{name}.{first:0{max(4, len(str(last)))}d}.exr")
    label = f"{NODE_PREFIX}{name}"
    image = bpy.data.images.get(label)
    if image is None or bpy.path.abspath(image.filepath) != path:
        if image is not None:
            bpy.data.images.remove(image)
        image = bpy.data.images.load(path, check_existing=False)
        image.name = label
    image.source = "SEQUENCE"
    image.colorspace_settings.name = "Linear Rec.709"
    image.reload()
    return image, first, last - first + 1


def set_image_user(user, first, count):
    """Scene frame k shows file k: Blender picks file (k − frame_start + 1) + frame_offset."""
    user.frame_start = first
    user.frame_offset = first - 1
    user.frame_duration = count
    user.use_auto_refresh = True


def show_in_image_editors(screen, image, first, count):
    for area in screen.areas if screen else ():
        if area.type == "IMAGE_EDITOR":
            space = area.spaces.active
            space.image = image
            set_image_user(space.image_user, first, count)
            area.tag_redraw()


def pass_names(image_node):
    return [s.name for s in image_node.outputs if s.enabled]
