"""The panels' draw code, run against a recording layout (headless Blender draws no UI): every
property it shows exists on its data, every button is a registered operator, and what is shown
follows the settings (field options only for index fields, progress only while rendering)."""

from types import SimpleNamespace

import bpy
import pytest

import scenes
from conftest import submodule


class Layout:
    """Stands in for bpy.types.UILayout and records what would be drawn."""

    def __init__(self, log):
        self.log = log
        self.use_property_split = False
        self.active = True
        self.scale_y = 1.0

    def _child(self, *args, **kwargs):
        return Layout(self.log)

    row = column = box = _child

    def prop(self, data, name, **kwargs):
        assert name in data.bl_rna.properties, f"{data.bl_rna.identifier} has no property {name!r}"
        self.log.append(("prop", name))

    def operator(self, idname, **kwargs):
        category, name = idname.split(".")
        assert hasattr(bpy.types, f"{category.upper()}_OT_{name}"), f"no operator {idname}"
        self.log.append(("operator", idname))
        return _Props()

    def label(self, text="", **kwargs):
        self.log.append(("label", text))

    def progress(self, factor=0.0, text="", **kwargs):
        assert 0.0 <= factor <= 1.0
        self.log.append(("progress", text))


class _Props:
    """Operator properties set from a button (`…operator(…).compositor = True`)."""


def draw(panel_name, context=None):
    """What a registered panel draws, in order."""
    context = context or bpy.context
    log = []
    panel = getattr(bpy.types, panel_name)
    stub = SimpleNamespace(layout=Layout(log))
    if hasattr(panel, "draw_settings"):  # subpanels: the shared draw calls draw_settings
        stub.draw_settings = lambda *args: panel.draw_settings(stub, *args)
    panel.draw(stub, context)
    return log


RENDER_PANELS = [
    "RENDER_PT_refrakt", "RENDER_PT_refrakt_light", "RENDER_PT_refrakt_volume", "RENDER_PT_refrakt_fog",
    "RENDER_PT_refrakt_output", "RENDER_PT_refrakt_compositing", "RENDER_PT_refrakt_live",
    "RENDER_PT_refrakt_viewport",
]


@pytest.mark.parametrize("fog", ["NONE", "WORLD", "CUSTOM"])
def test_render_panels_draw(addon, fog):
    scenes.round_trip_scene()
    bpy.context.scene.refrakt.fog = fog
    logs = {name: draw(name) for name in RENDER_PANELS}
    assert ("operator", "refrakt.render") in logs["RENDER_PT_refrakt"]
    assert ("operator", "refrakt.render_cluster") in logs["RENDER_PT_refrakt"]
    assert ("prop", "cluster_address") in logs["RENDER_PT_refrakt"]
    assert ("operator", "refrakt.load_frames") in logs["RENDER_PT_refrakt_compositing"]
    shown = {name for _, name in logs["RENDER_PT_refrakt_fog"]}
    assert ("fog_density" in shown) == (fog == "CUSTOM")


def test_progress_shows_while_rendering(addon):
    state = bpy.context.window_manager.refrakt
    state.running, state.progress, state.status = True, 40.0, "refrakt: frame 2/5"
    try:
        log = draw("RENDER_PT_refrakt")
    finally:
        state.running = False
    assert ("progress", "refrakt: frame 2/5") in log and ("operator", "refrakt.cancel_render") in log


class Context:
    def __init__(self, **kw):
        self.__dict__.update(kw)
        self.scene = bpy.context.scene
        self.window_manager = bpy.context.window_manager


def test_object_panel_shows_field_settings_for_index_fields(addon):
    bpy.ops.mesh.primitive_uv_sphere_add()
    obj = bpy.context.object
    assert draw("OBJECT_PT_refrakt", Context(object=obj)) == [("prop", "role")]
    obj.refrakt.role, obj.refrakt.field = "FIELD", "SLAB"
    shown = [name for _, name in draw("OBJECT_PT_refrakt", Context(object=obj))]
    assert shown == ["role", "field", "use_bounds", "size", "ior", "gradient", "boundary"]


def test_object_panel_offers_camera_visibility_for_lights_with_a_size(addon):
    for kind in ("POINT", "SPOT", "AREA", "SUN"):
        obj = bpy.data.objects.new(kind, bpy.data.lights.new(kind, kind))
        shown = [name for _, name in draw("OBJECT_PT_refrakt", Context(object=obj))]
        assert shown == (["role"] if kind == "SUN" else ["visible_camera", "role"]), kind


def test_material_panel_shows_what_it_read_from_the_nodes(addon):
    scenes.round_trip_scene()
    log = draw("MATERIAL_PT_refrakt", Context(material=bpy.data.materials["Glass"]))
    assert ("label", "Absorption /m: 0.4 0.2 0") in log


def test_material_panel_shows_refrakts_reading_of_the_principled_bsdf(addon):
    scenes.round_trip_scene()
    glass = bpy.data.materials["Glass"]
    bsdf = glass.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = 0.2
    bsdf.inputs["Metallic"].default_value = 0.5
    bsdf.inputs["Coat Weight"].default_value = 0.3
    bsdf.inputs["Specular IOR Level"].default_value = 0.25
    bsdf.inputs["Base Color"].default_value = (0.9, 0.8, 0.7, 1.0)
    labels = [text for kind, text in draw("MATERIAL_PT_refrakt", Context(material=glass)) if kind == "label"]
    assert labels[0] == "refrakt reads: glass (a refractive medium)"
    assert "Transmission: 1 → clear glass" in labels
    assert f"IOR: {scenes.GLASS_IOR:.4g} → index of refraction" in labels
    assert "Base Color: 0.9 0.8 0.7 → tint, once through a solid (as Cycles)" in labels
    assert "Roughness: 0.2 → GGX roughness: frosted glass" in labels
    assert "Glass: Auto → closed meshes solid, flat ones thin sheets" in labels
    # Metal on glass is read (glTF's metallicFactor on a transmissive material); a coat is not.
    assert "Metallic: 0.5 → the metal part of its surface: reflects Base Color, passes nothing" in labels
    assert "Specular IOR Level: 0.25 → reflection strength, × Specular Tint (KHR_materials_specular)" in labels
    ignored = labels[labels.index("Ignored:") + 1:]
    assert not any(text.startswith(("Roughness", "Metallic")) for text in ignored)
    assert "Coat Weight 0.3" in ignored
    glass.refrakt.surface = "THIN"
    labels = [text for kind, text in draw("MATERIAL_PT_refrakt", Context(material=glass)) if kind == "label"]
    assert "Glass: Thin → a thin sheet" in labels

    bsdf.inputs["Transmission Weight"].default_value = 0.0
    glass.node_tree.links.remove(glass.node_tree.nodes["Material Output"].inputs["Volume"].links[0])
    reading = submodule("material_reading").read(glass)
    # A receiver is read with glTF's metallic-roughness model, its clear coat too.
    assert reading.kind == "receiver" and reading.rows == [
        ("Base Color", "0.9 0.8 0.7", "albedo"), ("Roughness", "0.2", "GGX roughness of its reflection"),
        ("Metallic", "0.5", "metallic: reflects Base Color"), ("Specular IOR Level", "0.25", "specular weight (KHR_materials_specular)"),
        ("Coat Weight", "0.3", "a clear coat (KHR_materials_clearcoat)"),
    ]
    assert reading.ignored == []
    shown = draw("MATERIAL_PT_refrakt", Context(material=glass))
    assert not [name for kind, name in shown if kind == "prop"], "glass settings on an opaque receiver"
    assert ("label", "Glass settings show for a transmissive material (Transmission > 0)") in shown
    bsdf.inputs["Emission Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 3.0
    reading = submodule("material_reading").read(glass)
    assert ("Emission", "1 0.5 0.25 × 3", "glows, and lights the scene from both sides") in reading.rows



def test_passes_panel_shows_with_the_engine(addon):
    scene = bpy.context.scene
    panel = bpy.types.VIEWLAYER_PT_refrakt_passes
    assert not panel.poll(bpy.context)
    scene.render.engine = "REFRAKT"
    assert panel.poll(bpy.context)
    context = Context(view_layer=scene.view_layers[0])
    shown = [name for _, name in draw("VIEWLAYER_PT_refrakt_passes", context)]
    assert shown == [
        "use_pass_z", "use_pass_caustic", "use_pass_direct", "use_pass_indirect", "use_pass_volume"
    ]
