"""refrakt's EXR frames back in Blender: an image sequence in the image editor, and optionally
compositor nodes that lay refrakt's passes over Blender's own render.

refrakt writes one-part EXRs with the beauty as plain `R G B A` and the other layers as
`<pass>.<channel>` (`depth.Z`, `caustic.R`, `volume.R`, …). Blender reads such a file as a
multilayer image whose one (unnamed) layer has the passes Combined, depth, caustic, direct,
volume: the compositor's Image node shows each as its own socket.
"""

import os
import re

import bpy

FRAME_NAME = re.compile(r"^(?P<name>.+)\.(?P<k>\d{4,})\.exr$")

# Names of the compositor nodes this add-on owns, so wiring again updates instead of adding.
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
    path = os.path.join(directory, f"{name}.{first:04d}.exr")
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
    shown = 0
    for area in screen.areas if screen else ():
        if area.type == "IMAGE_EDITOR":
            space = area.spaces.active
            space.image = image
            set_image_user(space.image_user, first, count)
            area.tag_redraw()
            shown += 1
    return shown


def pass_names(image_node):
    return [s.name for s in image_node.outputs if s.enabled]


def _node(tree, kind, label, location):
    name = NODE_PREFIX + label
    node = tree.nodes.get(name)
    if node is None or node.bl_idname != kind:
        if node is not None:
            tree.nodes.remove(node)
        node = tree.nodes.new(kind)
        node.name = name
        node.label = "refrakt " + label
        node.location = location
    return node


def _add(tree, label, below, light, location):
    """`below` + `light`: refrakt's caustic and in-scattered light add to Blender's render."""
    mix = _node(tree, "CompositorNodeMixRGB", label, location)
    mix.blend_type = "ADD"
    mix.inputs[0].default_value = 1.0
    tree.links.new(below, mix.inputs[1])
    tree.links.new(light, mix.inputs[2])
    return mix.outputs[0]


def wire_compositor(scene, image, first, count):
    """Builds (or updates) refrakt's nodes in the scene's compositor (Blender 4.2–4.5):

        Render Layers ─(+ caustic)─(+ volume)─ Alpha Over (refrakt beauty on top) ─ Composite

    What fed the Composite node before becomes the background, so the user's own compositing
    stays. Which passes are used follows the refrakt panel's Compositing settings. Returns the
    Image node."""
    if not hasattr(scene, "node_tree"):
        raise FramesError("Wiring the compositor supports Blender 4.2 to 4.5; load the frames in the image editor instead.")
    s = scene.refrakt
    scene.use_nodes = True
    tree = scene.node_tree
    composite = next((n for n in tree.nodes if n.bl_idname == "CompositorNodeComposite"), None)
    if composite is None:
        composite = tree.nodes.new("CompositorNodeComposite")
        composite.location = (800, 300)
    background = _user_background(tree, composite)
    frames = _node(tree, "CompositorNodeImage", "frames", (-200, -200))
    frames.image = image
    set_image_user(frames, first, count)

    passes = pass_names(frames)
    result = background
    for label, enabled, y in (("caustic", s.pass_caustic, 150), ("volume", s.pass_volume, 0)):
        if enabled and label in passes:
            result = _add(tree, label, result, frames.outputs[label], (300, y))
        elif (node := tree.nodes.get(NODE_PREFIX + label)) is not None:
            tree.nodes.remove(node)
    if s.pass_beauty:
        over = _node(tree, "CompositorNodeAlphaOver", "over", (550, 300))
        # refrakt's beauty is premultiplied: radiance already weighted by coverage.
        over.use_premultiply = False
        tree.links.new(result, over.inputs[1])
        tree.links.new(frames.outputs["Combined"], over.inputs[2])
        result = over.outputs[0]
    elif (over := tree.nodes.get(NODE_PREFIX + "over")) is not None:
        tree.nodes.remove(over)
    tree.links.new(result, composite.inputs["Image"])
    return frames


def _user_background(tree, composite):
    """What refrakt's passes go over: what fed the Composite node before refrakt's nodes were
    put in front of it (found by walking back through them), or the Render Layers' image."""
    inp = composite.inputs["Image"]
    socket = inp.links[0].from_socket if inp.is_linked else None
    while socket is not None and socket.node.name.startswith(NODE_PREFIX):
        inp = socket.node.inputs[1]  # the background input of refrakt's Mix and Alpha Over
        socket = inp.links[0].from_socket if inp.is_linked else None
    if socket is not None:
        return socket
    layers = next((n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers"), None)
    if layers is None:
        layers = tree.nodes.new("CompositorNodeRLayers")
        layers.location = (-200, 300)
    return layers.outputs["Image"]
