"""Screenshots of refrakt as Blender's render engine, in Blender's user interface, for the guide (docs/blender.md).

Runs like scripts/blender_screenshots.py (whose helpers and scene it uses), in Blender with its
user interface under a virtual X display of 1600×1200:

    xvfb-run -s "-screen 0 1600x1200x24" blender --factory-startup \
        --python scripts/blender_engine_screenshots.py -- OUTDIR [--refrakt PATH] [--work DIR]

scripts/blender_screenshots.sh runs it with SCREENSHOTS=engine. As a user would: installs the
add-on, builds the same scene, picks *Render Engine ▸ refrakt*, presses F12 (render.render
INVOKE_DEFAULT: Blender's render job, refrakt in a subprocess), shows the Render Result with its
passes, opens the compositor on the Render Layers node (refrakt's passes as sockets), and turns
the 3D viewport to Rendered shading (refrakt watch behind it, drawn with the gpu module).
Writes to OUTDIR:

    blender_engine.png           the whole window: the Render Result of F12, the compositor's
                                 Render Layers node, the viewport in Rendered mode, Render ▸ engine
    blender_engine_viewport.png  the 3D viewport in Rendered mode
    blender_engine_passes.png    the compositor's Render Layers node with refrakt's passes
"""

import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_screenshots as shots  # noqa: E402  (the same command line: OUTDIR, --refrakt, --work)

VIEWPORT_TIMEOUT_S = 600.0


def lay_out():
    """Left: the 3D viewport above the compositor and an image editor side by side; right: the
    Render properties (Render Engine ▸ refrakt at their top)."""
    with shots.override(shots.areas("OUTLINER")[0]):
        bpy.ops.screen.area_close()
    yield 0.3
    props = shots.areas("PROPERTIES")[0]
    props.spaces.active.context = "RENDER"
    yield from shots.move_edge(props.x - 1, props.y + props.height // 2, props.width - shots.RIGHT_WIDTH)
    bottom, view3d = shots.split(shots.areas("VIEW_3D")[0], "HORIZONTAL", 0.5)
    bottom.type = "IMAGE_EDITOR"
    yield 0.3
    image_editor, nodes = shots.split(bottom, "VERTICAL", 0.5)
    nodes.type = "NODE_EDITOR"
    nodes.ui_type = "CompositorNodeTree"
    yield 0.3
    space = view3d.spaces.active
    r3d = space.region_3d
    r3d.view_perspective = "PERSP"
    target, eye = shots.Vector(shots.VIEW_TARGET), shots.Vector(shots.VIEW_EYE)
    r3d.view_location = target
    r3d.view_rotation = (eye - target).to_track_quat("Z", "Y")
    r3d.view_distance = (eye - target).length
    shots.redraw()


def compositor(scene):
    """The scene's compositor with a Render Layers node: refrakt's passes as its sockets."""
    api = sys.modules[shots.MODULE + ".compositor"]
    tree = api.tree(scene)
    layers = next((n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers"), None) or tree.nodes.new("CompositorNodeRLayers")
    layers.location = (0, 0)
    viewer = tree.nodes.new("CompositorNodeViewer")
    viewer.location = (300, 0)
    tree.links.new(layers.outputs["caustic"], viewer.inputs[0])
    return tree


def steps():
    shots.install_addon()
    yield 0.5
    scene = shots.build_scene()
    scene.render.engine = "REFRAKT"
    scene.view_layers[0].use_pass_z = True
    scene.refrakt.viewport_scale = 50
    bpy.context.preferences.view.render_display_type = "NONE"  # the Render Result goes to our image editor
    yield 0.5
    yield from lay_out()
    yield 1.0

    # F12, as the key runs it: Blender's render job, the engine's render() on its thread.
    view3d = shots.areas("VIEW_3D")[0]
    with shots.override(view3d):
        result = bpy.ops.render.render("INVOKE_DEFAULT")
    assert result == {"RUNNING_MODAL"}, f"F12: {result}"
    started = time.monotonic()
    while bpy.app.is_job_running("RENDER"):
        yield 0.5
        assert time.monotonic() - started < shots.RENDER_TIMEOUT_S, "F12 still rendering"
    print(f"blender_engine_screenshots: F12 took {time.monotonic() - started:.1f} s", flush=True)
    image_editor = shots.areas("IMAGE_EDITOR")[0]
    image_editor.spaces.active.image = bpy.data.images["Render Result"]
    image_editor.spaces.active.display_channels = "COLOR"
    with shots.override(image_editor):
        bpy.ops.image.view_all(fit_view=True)

    tree = compositor(scene)
    nodes = shots.areas("NODE_EDITOR")[0]
    nodes.spaces.active.node_tree = tree
    nodes.spaces.active.show_region_ui = False
    nodes.spaces.active.show_region_toolbar = False
    yield 0.5
    with shots.override(nodes):
        bpy.ops.node.view_all()

    # The viewport's Rendered shading: the engine starts refrakt watch and draws its frames.
    view3d.spaces.active.shading.type = "RENDERED"
    engine = sys.modules[shots.MODULE + ".engine"]
    started = time.monotonic()
    while not any(v.session.frames and v.session.quality == "final" for v in engine._viewports.values()):
        shots.redraw()
        yield 0.5
        errors = [v.session.error for v in engine._viewports.values() if v.session.error]
        assert not errors, f"viewport: {errors}"
        assert time.monotonic() - started < VIEWPORT_TIMEOUT_S, "no viewport frame"
    print(f"blender_engine_screenshots: first viewport frame after {time.monotonic() - started:.1f} s", flush=True)
    shots.redraw()
    yield 2.0
    shot = shots.xwd("engine")
    shots.save(shot, "blender_engine.png")
    shots.save(shot, "blender_engine_viewport.png", shots.rect(view3d))
    shots.save(shot, "blender_engine_passes.png", shots.rect(nodes))
    view3d.spaces.active.shading.type = "SOLID"  # ends the viewport's refrakt watch
    yield 1.0


shots.steps = steps
bpy.app.timers.register(shots.tick, first_interval=1.0)
