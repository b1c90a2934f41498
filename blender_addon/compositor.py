"""refrakt's passes over Blender's own render in the scene's compositor:

    (what fed the output) ─ + caustic ─ + volume ─ Alpha Over (refrakt beauty on top) ─ output

The nodes carry fixed names, so wiring again updates them; whatever fed the compositor's output
before stays the background, so the user's own compositing is kept. Blender 5.0 made the
compositor a node group (a Group Output instead of the Composite node, the generic Mix node
instead of Mix RGB, Alpha Over's options as sockets); `_Nodes4` and `_Nodes5` hide that.
"""

import bpy

from . import frames

PREFIX = frames.NODE_PREFIX
# The nodes refrakt puts between the background and the output.
CHAIN = {PREFIX + label for label in ("caustic", "volume", "over")}


class _Nodes4:
    """Blender 4.2–4.5: `scene.node_tree`, the Composite node, Mix RGB."""

    @staticmethod
    def tree(scene):
        scene.use_nodes = True
        return scene.node_tree

    @staticmethod
    def output(tree):
        node = next((n for n in tree.nodes if n.bl_idname == "CompositorNodeComposite"), None)
        if node is None:
            node = tree.nodes.new("CompositorNodeComposite")
            node.location = (800, 300)
        return node.inputs["Image"]

    add_kind = "CompositorNodeMixRGB"

    @staticmethod
    def setup_add(node):
        node.blend_type = "ADD"
        node.inputs[0].default_value = 1.0
        return node.inputs[1], node.inputs[2], node.outputs[0]

    @staticmethod
    def setup_over(node):
        node.use_premultiply = False  # the foreground is premultiplied already
        return node.inputs[1], node.inputs[2], node.outputs[0]

    @staticmethod
    def background_input(node):
        return node.inputs[1]


class _Nodes5:
    """Blender 5.0 and later: `scene.compositing_node_group`, Group Output, the Mix node."""

    @staticmethod
    def tree(scene):
        tree = scene.compositing_node_group
        if tree is None:
            tree = bpy.data.node_groups.new("Compositor", "CompositorNodeTree")
            tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
            scene.compositing_node_group = tree
        return tree

    @staticmethod
    def output(tree):
        node = next((n for n in tree.nodes if n.bl_idname == "NodeGroupOutput" and n.is_active_output), None)
        if node is None:
            node = tree.nodes.new("NodeGroupOutput")
            node.location = (800, 300)
        return node.inputs[0]

    add_kind = "ShaderNodeMix"

    @staticmethod
    def setup_add(node):
        node.data_type = "RGBA"
        node.blend_type = "ADD"
        node.inputs["Factor"].default_value = 1.0
        a, b = (s for s in node.inputs if s.type == "RGBA")
        return a, b, next(s for s in node.outputs if s.type == "RGBA")

    @staticmethod
    def setup_over(node):
        node.inputs["Straight Alpha"].default_value = False  # premultiplied foreground
        return node.inputs["Background"], node.inputs["Foreground"], node.outputs[0]

    @staticmethod
    def background_input(node):
        if node.bl_idname == "ShaderNodeMix":
            return next(s for s in node.inputs if s.type == "RGBA")
        return node.inputs["Background"]


def nodes_api():
    return _Nodes5 if bpy.app.version >= (5, 0, 0) else _Nodes4


def tree(scene):
    return nodes_api().tree(scene)


def _node(tree_, kind, label, location):
    node = tree_.nodes.get(PREFIX + label)
    if node is None or node.bl_idname != kind:
        if node is not None:
            tree_.nodes.remove(node)
        node = tree_.nodes.new(kind)
        node.name = PREFIX + label
        node.label = PREFIX + label
        node.location = location
    return node


def _remove(tree_, label):
    node = tree_.nodes.get(PREFIX + label)
    if node is not None:
        tree_.nodes.remove(node)


def _user_background(api, tree_, output):
    """What fed the output before refrakt's nodes were put in front of it (found by walking back
    through them), or the Render Layers' image."""
    socket = output.links[0].from_socket if output.is_linked else None
    while socket is not None and socket.node.name in CHAIN:
        inp = api.background_input(socket.node)
        socket = inp.links[0].from_socket if inp.is_linked else None
    if socket is not None and not socket.node.name.startswith(PREFIX):
        return socket
    layers = next((n for n in tree_.nodes if n.bl_idname == "CompositorNodeRLayers"), None)
    if layers is None:
        layers = tree_.nodes.new("CompositorNodeRLayers")
        layers.location = (-200, 300)
    return layers.outputs["Image"]


def wire(scene, image, first, count):
    """Builds or updates refrakt's nodes following the panel's pass choices; returns the Image
    node that reads the frames."""
    api = nodes_api()
    s = scene.refrakt
    tree_ = api.tree(scene)
    output = api.output(tree_)
    result = _user_background(api, tree_, output)
    source = _node(tree_, "CompositorNodeImage", "frames", (-200, -200))
    source.image = image
    frames.set_image_user(source, first, count)

    passes = frames.pass_names(source)
    for label, enabled, y in (("caustic", s.pass_caustic, 150), ("volume", s.pass_volume, 0)):
        if enabled and label in passes:
            below, light, out = api.setup_add(_node(tree_, api.add_kind, label, (300, y)))
            tree_.links.new(result, below)
            tree_.links.new(source.outputs[label], light)
            result = out
        else:
            _remove(tree_, label)
    if s.pass_beauty:
        below, over, out = api.setup_over(_node(tree_, "CompositorNodeAlphaOver", "over", (550, 300)))
        tree_.links.new(result, below)
        tree_.links.new(source.outputs["Combined"], over)
        result = out
    else:
        _remove(tree_, "over")
    tree_.links.new(result, output)
    return source
