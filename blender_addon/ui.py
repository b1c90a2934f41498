"""Panels: Render Properties ▸ refrakt (settings, render, frames, live, viewport), View Layer
Properties ▸ refrakt Passes (with the refrakt engine), Object Properties ▸ refrakt (index
fields), Material Properties ▸ refrakt (its reading of the material, the medium inside)."""

import bpy

from . import extras, final_render, material_reading


class PropertiesPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"


class RefraktRenderPanel(PropertiesPanel):
    bl_context = "render"


class RefraktSubPanel(RefraktRenderPanel):
    """A subpanel of Render Properties ▸ refrakt, drawing the scene's refrakt settings."""

    bl_parent_id = "RENDER_PT_refrakt"

    def draw(self, context):
        self.layout.use_property_split = True
        self.draw_settings(context, self.layout, context.scene.refrakt)


class RENDER_PT_refrakt(RefraktRenderPanel, bpy.types.Panel):
    bl_label = "refrakt"

    def draw(self, context):
        layout = self.layout
        state = context.window_manager.refrakt
        if state.running:
            row = layout.row(align=True)
            row.progress(factor=state.progress / 100.0, text=state.status)
            row.operator("refrakt.cancel_render", text="", icon="CANCEL")
        else:
            row = layout.row(align=True)
            row.scale_y = 1.4
            row.operator("refrakt.render", icon="RENDER_ANIMATION")
            row.operator("refrakt.export", text="", icon="EXPORT")
            s = context.scene.refrakt
            row = layout.row(align=True)
            if _has_placeholder():
                row.prop(s, "cluster_address", text="", placeholder="ray://head:10001")
            else:
                row.prop(s, "cluster_address", text="")
            row.prop(s, "cluster_chunk")
            row.operator("refrakt.render_cluster", text="Render on Cluster", icon="NETWORK_DRIVE")
            if state.status:
                layout.label(text=state.status)
        if state.error:
            box = layout.box()
            for i, line in enumerate(_wrap(state.error, 70)):
                box.label(text=line, icon="ERROR" if i == 0 else "BLANK1")


def _has_placeholder():
    """UILayout.prop takes `placeholder` from Blender 4.1 on."""
    return bpy.app.version >= (4, 1, 0)


def _wrap(text, width):
    words, lines, line = text.split(), [], ""
    for w in words:
        if line and len(line) + 1 + len(w) > width:
            lines.append(line)
            line = w
        else:
            line = f"{line} {w}".strip()
    return lines + [line] if line else lines


class RENDER_PT_refrakt_light(RefraktSubPanel, bpy.types.Panel):
    bl_label = "Photons"

    def draw_settings(self, context, layout, s):
        layout.prop(s, "photons")
        layout.prop(s, "bounces")
        layout.prop(s, "samples")
        row = layout.row()
        row.enabled = context.scene.render.use_motion_blur
        row.prop(s, "motion_steps")


class RENDER_PT_refrakt_volume(RefraktSubPanel, bpy.types.Panel):
    bl_label = "Volume"

    def draw_settings(self, context, layout, s):
        layout.prop(s, "volume_resolution")
        layout.prop(s, "volume_bounds")
        col = layout.column()
        col.active = s.volume_bounds is None
        col.prop(s, "volume_margin")
        layout.prop(s, "volume_boundary")
        layout.prop(s, "volume_step")
        layout.prop(s, "volume_contact")


class RENDER_PT_refrakt_fog(RefraktSubPanel, bpy.types.Panel):
    bl_label = "Fog"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_settings(self, context, layout, s):
        layout.prop(s, "fog")
        if s.fog == "CUSTOM":
            layout.prop(s, "fog_density")
            layout.prop(s, "fog_color")
            layout.prop(s, "fog_absorption")
            layout.prop(s, "fog_anisotropy")
        elif s.fog == "WORLD" and context.scene.world is not None:
            _show_medium(layout, extras.node_medium(context.scene.world, extras.Warnings()))


class RENDER_PT_refrakt_output(RefraktSubPanel, bpy.types.Panel):
    bl_label = "Output"

    def draw_settings(self, context, layout, s):
        layout.prop(s, "directory")
        layout.prop(s, "basename")
        row = layout.row()
        row.prop(s, "show_environment")
        if context.scene.render.engine == "REFRAKT":
            # As the render engine, refrakt shows the World unless Film ▸ Transparent is on.
            row.active = False
            layout.label(text="F12 shows the World unless Film ▸ Transparent is on", icon="INFO")
        layout.prop(s, "source")
        layout.prop(s, "skip_existing")
        layout.prop(s, "apply_modifiers")
        layout.label(text="Frame range, rate, resolution and camera come from the scene", icon="INFO")


class RENDER_PT_refrakt_compositing(RefraktSubPanel, bpy.types.Panel):
    bl_label = "Frames in Blender"

    def draw_settings(self, context, layout, s):
        col = layout.column(heading="Over the Render", align=True)
        col.prop(s, "pass_beauty")
        col.prop(s, "pass_caustic")
        col.prop(s, "pass_volume")
        row = layout.row(align=True)
        row.operator("refrakt.load_frames", text="Image Editor", icon="IMAGE").compositor = False
        row.operator("refrakt.load_frames", text="Compositor", icon="NODE_COMPOSITING").compositor = True


class RENDER_PT_refrakt_live(RefraktSubPanel, bpy.types.Panel):
    bl_label = "Live Preview"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_settings(self, context, layout, s):
        state = context.window_manager.refrakt
        layout.prop(s, "live_debounce")
        layout.operator("refrakt.live", text="Stop Live" if state.live else "Start Live", icon="PAUSE" if state.live else "PLAY", depress=state.live)
        if state.live_status:
            layout.label(text=state.live_status)


class RENDER_PT_refrakt_viewport(RefraktSubPanel, bpy.types.Panel):
    bl_label = "Viewport"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_settings(self, context, layout, s):
        layout.prop(s, "viewport_scale")
        layout.prop(s, "live_debounce", text="Export Delay")
        layout.label(text="Rendered shading with the refrakt engine: one refrakt watch per viewport", icon="INFO")


class VIEWLAYER_PT_refrakt_passes(PropertiesPanel, bpy.types.Panel):
    bl_label = "refrakt Passes"
    bl_context = "view_layer"
    COMPAT_ENGINES = {"REFRAKT"}

    @classmethod
    def poll(cls, context):
        return context.scene.render.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        view_layer = context.view_layer
        col = layout.column(heading="Include", align=True)
        col.prop(view_layer, "use_pass_z")
        for name in final_render.PASSES:
            col.prop(view_layer.refrakt, f"use_pass_{name}")


class OBJECT_PT_refrakt(PropertiesPanel, bpy.types.Panel):
    bl_label = "refrakt"
    bl_context = "object"

    def draw(self, context):
        obj = context.object
        s = obj.refrakt
        layout = self.layout
        layout.use_property_split = True
        if obj.type == "LIGHT" and obj.data.type != "SUN":
            # The one setting of Cycles' Ray Visibility panel (Cycles' own, not shown for refrakt)
            # that refrakt reads: whether the camera sees the bulb or panel.
            layout.prop(obj, "visible_camera", text="Seen by Camera")
        layout.prop(s, "role")
        if context.object == context.scene.refrakt.volume_bounds:
            layout.label(text="Volume bounds of the scene: not rendered", icon="INFO")
        if s.role != "FIELD":
            return
        layout.prop(s, "field")
        layout.prop(s, "use_bounds")
        col = layout.column()
        col.active = not s.use_bounds
        col.prop(s, "radius" if s.field in ("LUNEBURG", "SPHERE") else "size")
        if s.field != "LUNEBURG":
            layout.prop(s, "ior")
        if s.field == "SLAB":
            layout.prop(s, "gradient")
        layout.prop(s, "boundary")


class MATERIAL_PT_refrakt(PropertiesPanel, bpy.types.Panel):
    bl_label = "refrakt"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return context.material is not None

    def draw(self, context):
        material = context.material
        s = material.refrakt
        layout = self.layout
        reading = material_reading.read(material)
        _show_reading(layout, reading)
        if reading.kind != "glass":
            # Medium, boundary, sheet and dispersion belong to glass: an opaque receiver has none.
            layout.label(text="Glass settings show for a transmissive material (Transmission > 0)", icon="INFO")
            return
        layout.use_property_split = True
        layout.prop(s, "medium")
        if s.medium == "CUSTOM":
            layout.prop(s, "absorption")
            layout.prop(s, "scattering")
            layout.prop(s, "anisotropy")
        else:
            warnings = extras.Warnings()
            _show_medium(layout, extras.node_medium(material, warnings))
            for w in warnings:
                layout.label(text=w, icon="ERROR")
        layout.prop(s, "boundary")
        layout.prop(s, "surface")
        layout.prop(s, "priority")
        layout.prop(s, "abbe")


READING_TITLES = {
    "glass": "refrakt reads: glass (a refractive medium)",
    "receiver": "refrakt reads: an opaque diffuse receiver",
    "unknown": "refrakt reads: the glTF exporter's default material",
}


def _show_reading(layout, reading):
    box = layout.box()
    box.label(text=READING_TITLES[reading.kind], icon="MATERIAL")
    col = box.column(align=True)
    for label, value, meaning in reading.rows:
        col.label(text=f"{label}: {value} → {meaning}")
    if reading.ignored:
        col = box.column(align=True)
        col.label(text="Ignored:", icon="INFO")
        for text in reading.ignored:
            col.label(text=text, icon="BLANK1")


def _show_medium(layout, medium):
    col = layout.column(align=True)
    col.label(text="Absorption /m: " + " ".join(f"{a:.3g}" for a in medium.absorption))
    col.label(text="Scattering /m: " + " ".join(f"{a:.3g}" for a in medium.scattering) + f"   g {medium.g:.2f}")


classes = (
    RENDER_PT_refrakt,
    RENDER_PT_refrakt_light,
    RENDER_PT_refrakt_volume,
    RENDER_PT_refrakt_fog,
    RENDER_PT_refrakt_output,
    RENDER_PT_refrakt_compositing,
    RENDER_PT_refrakt_live,
    RENDER_PT_refrakt_viewport,
    VIEWLAYER_PT_refrakt_passes,
    OBJECT_PT_refrakt,
    MATERIAL_PT_refrakt,
)


register, unregister = bpy.utils.register_classes_factory(classes)
