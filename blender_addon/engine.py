"""refrakt as a Blender render engine (Render Properties ▸ Render Engine ▸ refrakt).

- F12 / Ctrl+F12: `render` (final_render.py) exports the scene, runs one `refrakt render` for
  the frames asked and copies each frame into the Render Result: Combined, Depth and refrakt's
  caustic, direct, indirect and volume passes (registered in `update_render_passes`). Blender then writes
  its own output files with its own settings, and its compositor sees the passes.
- The viewport's Rendered mode: `view_update` and `view_draw` drive a ViewportSession
  (viewport.py), one `refrakt watch` per viewport, and draw its latest frame with `gpu`.
"""

import bpy

from . import binary, final_render, preferences, viewport

# Blender's own panels that show for refrakt too: materials, lights, World and cameras keep
# their usual settings (refrakt reads them through the glTF export).
COMPATIBLE_PANELS = (
    "EEVEE_MATERIAL_PT_context_material",
    "EEVEE_MATERIAL_PT_surface",
    "EEVEE_MATERIAL_PT_volume",
    "EEVEE_WORLD_PT_surface",
    "EEVEE_WORLD_PT_volume",
    "DATA_PT_light",
    "DATA_PT_EEVEE_light",
    "DATA_PT_camera",
    "DATA_PT_lens",
    "DATA_PT_camera_display",
    "VIEWLAYER_PT_layer_passes",
    "VIEWLAYER_PT_layer_passes_data",
)

class Viewport:
    """A viewport in Rendered mode: its engine, its session, and the texture last drawn."""

    def __init__(self, engine, session):
        self.engine = engine
        self.session = session
        self.texture = None
        self.drawn = 0  # the session's frame count when the texture was made


# The viewports in Rendered mode, by their engine's pointer, for the UI timer.
_viewports = {}
TICK_SECONDS = 0.1


class RefraktRenderEngine(bpy.types.RenderEngine):
    bl_idname = "REFRAKT"
    bl_label = "refrakt"
    bl_use_postprocess = True  # Blender's compositor and sequencer run on refrakt's frames
    bl_use_preview = False  # material thumbnails stay EEVEE's: a refrakt process per thumbnail is too slow
    bl_use_eevee_viewport = True  # Solid and Material Preview shading stay Blender's own

    def render(self, depsgraph):
        final_render.render(self, depsgraph)

    def update_render_passes(self, scene=None, renderlayer=None):
        final_render.update_render_passes(self, scene, renderlayer)

    def view_update(self, context, depsgraph):
        view = _viewports.get(self.as_pointer())
        if view is not None:
            view.session.view_update(depsgraph)
            return
        try:
            refrakt = binary.resolve(preferences.get(context).binary)
            session = viewport.ViewportSession(context.scene, refrakt)
        except Exception as e:  # noqa: BLE001 (a viewport cannot raise: the report says why)
            self.report({"ERROR"}, f"refrakt: {e}")
            return
        _viewports[self.as_pointer()] = Viewport(self, session)
        _ensure_timer()

    def view_draw(self, context, depsgraph):
        view = _viewports.get(self.as_pointer())
        if view is None:
            return
        region, r3d = context.region, context.region_data
        camera = viewport.view_camera(
            r3d.view_matrix, r3d.window_matrix, (region.width, region.height),
            context.scene.refrakt.viewport_scale, r3d.is_perspective,
        )
        view.session.set_view(camera)
        _draw(view, context.scene, region)

    def __del__(self):
        # Blender frees the engine when the viewport leaves Rendered mode.
        try:
            key = self.as_pointer()
        except ReferenceError:
            return
        view = _viewports.pop(key, None)
        if view is not None:
            view.session.stop()


def _draw(view, scene, region):
    """The session's latest frame over the whole region, through Blender's view transform."""
    import gpu
    from gpu_extras.presets import draw_texture_2d

    session = view.session
    if view.drawn != session.frames and session.latest is not None:
        pixels, size = session.pixels()
        buffer = gpu.types.Buffer("FLOAT", len(pixels), pixels)
        view.texture = gpu.types.GPUTexture(size, format="RGBA16F", data=buffer)
        view.drawn = session.frames
    if view.texture is None:
        return
    gpu.state.blend_set("ALPHA_PREMULT")
    view.engine.bind_display_space_shader(scene)
    draw_texture_2d(view.texture, (0, 0), region.width, region.height)
    view.engine.unbind_display_space_shader()
    gpu.state.blend_set("NONE")


def _tick():
    for key, view in list(_viewports.items()):
        try:
            if view.session.tick():
                view.engine.tag_redraw()
        except ReferenceError:  # the engine is gone (its viewport closed)
            view.session.stop()
            del _viewports[key]
        except Exception as e:  # noqa: BLE001 (an export error: the last good frame stays)
            view.session.error = str(e)
    return TICK_SECONDS if _viewports else None


def _ensure_timer():
    if not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=TICK_SECONDS)


def stop_viewports():
    for view in _viewports.values():
        view.session.stop()
    _viewports.clear()


def _panels():
    for name in COMPATIBLE_PANELS:
        panel = getattr(bpy.types, name, None)
        if panel is not None and hasattr(panel, "COMPAT_ENGINES"):
            yield panel


_HANDLERS = ("render_init", "render_cancel", "render_complete")


def register():
    bpy.utils.register_class(RefraktRenderEngine)
    for panel in _panels():
        panel.COMPAT_ENGINES.add(RefraktRenderEngine.bl_idname)
    for name in _HANDLERS:
        getattr(bpy.app.handlers, name).append(final_render.stop_current)


def unregister():
    for name in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if final_render.stop_current in handlers:
            handlers.remove(final_render.stop_current)
    final_render.stop_current()
    stop_viewports()
    for panel in _panels():
        panel.COMPAT_ENGINES.discard(RefraktRenderEngine.bl_idname)
    bpy.utils.unregister_class(RefraktRenderEngine)
