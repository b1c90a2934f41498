"""Panels: Render Properties ▸ refrakt (settings, render, frames, live), Object Properties ▸
refrakt (index fields), Material Properties ▸ refrakt (the medium inside)."""

import bpy

from . import extras


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
        layout.prop(s, "samples")


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
        layout.prop(s, "show_environment")
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


class OBJECT_PT_refrakt(PropertiesPanel, bpy.types.Panel):
    bl_label = "refrakt"
    bl_context = "object"

    def draw(self, context):
        s = context.object.refrakt
        layout = self.layout
        layout.use_property_split = True
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
    OBJECT_PT_refrakt,
    MATERIAL_PT_refrakt,
)


register, unregister = bpy.utils.register_classes_factory(classes)
