"""Screenshots of the refrakt add-on inside Blender's user interface, for the guide (docs/blender.md).

Runs in Blender with its user interface (not `-b`), under a virtual X display of 1600×1200:

    xvfb-run -s "-screen 0 1600x1200x24" blender --factory-startup \
        --python scripts/blender_screenshots.py -- OUTDIR [--refrakt PATH] [--work DIR]

scripts/blender_screenshots.sh does that in a Debian trixie chroot (Blender 4.3, Xvfb, Mesa's
llvmpipe OpenGL and lavapipe Vulkan) and writes to docs/images/. It needs `xwd` and ImageMagick's
`convert` on PATH.

What it does, as a user would: installs the add-on from the extension zip that
scripts/build_blender_addon.py builds (Install from Disk), builds the scene of
scripts/blender_figure.py (a floor, a glass ball, a ball marked as a Luneburg lens in
Object ▸ refrakt, a camera, a sky World) with a spot light instead of its sun, lays the window
out (3D viewport, image editor, Object properties, Render properties), presses *Render
Animation* (the modal operator: refrakt runs as a subprocess while Blender stays live), waits
for it, presses *Frames in Blender ▸ Image Editor*, and takes screenshots of the X display with
`xwd` (Blender's own screen.screenshot reads back black on llvmpipe under Xvfb). Writes to OUTDIR:

    blender_frame_in_blender.png  the whole window after the render, refrakt's frame in the image editor
    blender_panel.png             Render Properties, scrolled to the refrakt panels (all open)
    blender_object_panel.png      Object Properties of the lens, with Object ▸ refrakt
    blender_progress.png          the top of Render ▸ refrakt while refrakt renders (progress, cancel)

The scene, its export and refrakt's frames go to the work folder (default /tmp/refrakt-demo,
emptied first). Blender quits when done; the exit status is non-zero if a step failed (the
traceback is printed).
"""

import argparse
import math
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import traceback

import bpy
from mathutils import Vector

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "tests" / "blender"))
_resources = os.environ.get("BLENDER_USER_RESOURCES")
import blender_figure  # noqa: E402  (its scene, as the guide's Blender figure uses it)

# blender_figure points BLENDER_USER_RESOURCES at a temporary folder for the bpy module; in this
# running Blender that would send the extension install elsewhere than Blender looks for it.
if _resources is None:
    os.environ.pop("BLENDER_USER_RESOURCES", None)
else:
    os.environ["BLENDER_USER_RESOURCES"] = _resources
import build_blender_addon  # noqa: E402
import scenes  # noqa: E402  (look_at)

MODULE = blender_figure.MODULE  # bl_ext.user_default.refrakt
RENDER_TIMEOUT_S = 900.0

# The layout, in pixels of a 1600×1200 window.
RIGHT_WIDTH = 560  # Render properties
OBJECT_WIDTH = 430  # Object properties, right of the image editor
VIEW3D_HEIGHT = 480
# The render: tiny, so that lavapipe (Vulkan on the CPU) is quick.
VOLUME, PHOTONS, SAMPLES = 96, 20000, 4
SPOT_WATTS = 250.0
VIEW_TARGET, VIEW_EYE = (0.0, 0.3, 0.6), (3.6, -4.6, 3.8)
# blender_progress.png: this band of the Render properties (pixels below its top) while refrakt
# renders; it holds the refrakt panel's progress bar once the editor is scrolled to the bottom.
PROGRESS_TOP, PROGRESS_HEIGHT = 150, 330

# No splash screen over the screenshots (read before the splash would open, after this script).
bpy.context.preferences.view.show_splash = False


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser(prog="blender_screenshots.py", description=__doc__.splitlines()[0])
    parser.add_argument("out", help="folder for the screenshots")
    parser.add_argument("--refrakt", default="", help="the refrakt executable (default: refrakt on PATH)")
    parser.add_argument(
        "--work", default=os.path.join(tempfile.gettempdir(), "refrakt-demo"),
        help="folder for the scene, its export and the frames (emptied first; default %(default)s)",
    )
    return parser.parse_args(argv)


ARGS = parse_args()
OUT = pathlib.Path(ARGS.out).resolve()
WORK = pathlib.Path(ARGS.work).resolve()


# --- the window ------------------------------------------------------------------------------

def window():
    return bpy.context.window_manager.windows[0]


def areas(kind):
    return [a for a in window().screen.areas if a.type == kind]


def region(area, kind="WINDOW"):
    return next(r for r in area.regions if r.type == kind)


def override(area=None, region_kind="WINDOW"):
    """A context for operators run from a timer (which has no window of its own)."""
    win = window()
    kwargs = dict(window=win, screen=win.screen)
    if area is not None:
        kwargs.update(area=area, region=region(area, region_kind))
    return bpy.context.temp_override(**kwargs)


def redraw():
    for a in window().screen.areas:
        a.tag_redraw()


def xwd(name):
    """A screenshot of the whole X display (the Blender window fills it, at its top left);
    returns the path of the PNG in the work folder."""
    dump = WORK / (name + ".xwd")
    path = WORK / (name + ".png")
    subprocess.run(["xwd", "-root", "-silent", "-out", str(dump)], check=True)
    subprocess.run(["convert", str(dump), str(path)], check=True)
    dump.unlink()
    return path


def save(source, name, rect=None):
    """Crops a screenshot to rect (x, y, width, height; X11 pixels, origin top left) into OUTDIR."""
    target = OUT / name
    crop = ["-crop", "{2}x{3}+{0}+{1}".format(*rect), "+repage"] if rect else []
    subprocess.run(["convert", str(source), *crop, "-strip", "-define", "png:compression-level=9", str(target)], check=True)
    print(f"blender_screenshots: wrote {target} ({target.stat().st_size // 1024} KiB)", flush=True)


def rect(area, top=0, height=None):
    """An area's rectangle in X11 pixel coordinates (origin top left), optionally only `height`
    pixels from `top` pixels below its top edge."""
    y = window().height - (area.y + area.height) + top
    return (area.x, y, area.width, area.height - top if height is None else height)


# --- the steps -------------------------------------------------------------------------------

def install_addon():
    zip_path = build_blender_addon.build(tempfile.mkdtemp(prefix="refrakt-addon-"))
    with override():
        result = bpy.ops.extensions.package_install_files(
            filepath=str(zip_path), repo="user_default", enable_on_install=True
        )
    assert result == {"FINISHED"}, f"installing {zip_path}: {result}"
    assert MODULE in bpy.context.preferences.addons, f"{MODULE} is not enabled after installing {zip_path}"
    refrakt = ARGS.refrakt or shutil.which("refrakt") or ""
    bpy.context.preferences.addons[MODULE].preferences.binary = refrakt
    print(f"blender_screenshots: installed {zip_path}, refrakt = {refrakt or '(not found)'}", flush=True)


def build_scene():
    # The factory scene's cube, camera and light go; blender_figure builds on an empty scene.
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    folder = WORK  # shown in Output ▸ Folder and in the report after the render
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    view3d = areas("VIEW_3D")[0]
    with override(view3d):
        scene = blender_figure.build_scene(folder)  # floor, Lens, Ball, Sun, sky World; saved as figure.blend

    # Tiny and quick on a CPU (lavapipe): 320×180, two frames.
    scene.render.resolution_x, scene.render.resolution_y = 320, 180
    scene.frame_start, scene.frame_end = 1, 2
    s = scene.refrakt
    s.volume_resolution, s.photons, s.samples = VOLUME, PHOTONS, SAMPLES
    s.show_environment = True

    # The ball is glass from its material (Principled BSDF, transmission 1, IOR 1.5, absorption);
    # the lens stays an index field (Object ▸ refrakt ▸ Index Field ▸ Luneburg Lens).
    ball, lens = bpy.data.objects["Ball"], bpy.data.objects["Lens"]
    ball.refrakt.role = "AUTO"
    ball.data.materials[0].node_tree.nodes["Principled BSDF"].inputs["IOR"].default_value = 1.5
    # A little motion, so the two frames differ.
    for frame, z in ((1, 0.0), (2, 0.3)):
        ball.rotation_euler = (0.0, 0.0, z)
        ball.keyframe_insert("rotation_euler", frame=frame)

    # A spot instead of the figure's sun, behind the balls and above, so that their shadows and
    # caustics fall on the floor in front of them, where the camera sees them.
    bpy.data.objects.remove(bpy.data.objects["Sun"])
    spot = bpy.data.objects.new("Spot", bpy.data.lights.new("Spot", "SPOT"))
    spot.data.energy = SPOT_WATTS
    spot.data.spot_size = math.radians(50.0)
    spot.data.spot_blend = 0.2
    scene.collection.objects.link(spot)
    spot.location = (-0.8, 2.2, 2.6)
    scenes.look_at(spot, (0.1, -0.6, 0.0))

    for obj in scene.objects:
        obj.select_set(False)
    lens.select_set(True)
    bpy.context.view_layer.objects.active = lens
    scene.frame_set(1)
    with override(view3d):
        bpy.ops.wm.save_mainfile()
    print(f"blender_screenshots: scene in {bpy.data.filepath}", flush=True)
    return scene


def open_closed_panels():
    """Fog and Live Preview start closed (bl_options DEFAULT_CLOSED) and Blender has no Python
    call that opens a panel: register those subpanels again without the flag, in their own
    order, before the Properties editor first draws them. Only their open state changes."""
    ui = sys.modules[MODULE + ".ui"]
    order = list(ui.classes)
    first = order.index(ui.RENDER_PT_refrakt_fog)
    again = [c for c in order[first:] if getattr(c, "bl_parent_id", "") == "RENDER_PT_refrakt"]
    for cls in reversed(again):
        bpy.utils.unregister_class(cls)
    for cls in again:
        if "DEFAULT_CLOSED" in getattr(cls, "bl_options", ()):
            cls.bl_options = set(cls.bl_options) - {"DEFAULT_CLOSED"}
        bpy.utils.register_class(cls)


def split(area, direction, factor):
    """Splits an area; returns the two halves, bottom or left first."""
    win = window()
    before = set(a.as_pointer() for a in win.screen.areas)
    with override(area):
        result = bpy.ops.screen.area_split(direction=direction, factor=factor)
    assert result == {"FINISHED"}, f"splitting {area.type}: {result}"
    new = next(a for a in win.screen.areas if a.as_pointer() not in before)
    return sorted((area, new), key=lambda a: (a.y, a.x) if direction == "HORIZONTAL" else (a.x, a.y))


def lay_out():
    """The right column: Render properties, the whole height (the outliner goes). The left: the
    3D viewport above an image editor and the Object properties side by side, the timeline below."""
    with override(areas("OUTLINER")[0]):
        bpy.ops.screen.area_close()
    yield 0.3
    render_props = areas("PROPERTIES")[0]
    render_props.spaces.active.context = "RENDER"
    # Wider: drag the edge on its left. screen.area_move runs only while the pointer is over no
    # region, so the pointer goes onto the edge first.
    yield from move_edge(render_props.x - 1, render_props.y + render_props.height // 2, render_props.width - RIGHT_WIDTH)

    bottom, view3d = split(areas("VIEW_3D")[0], "HORIZONTAL", 0.5)
    bottom.type = "IMAGE_EDITOR"
    yield 0.3
    image_editor, object_props = split(bottom, "VERTICAL", 0.5)
    object_props.type = "PROPERTIES"
    yield 0.5  # a new Properties editor knows its tabs once it has drawn
    object_props.spaces.active.context = "OBJECT"
    yield from move_edge(object_props.x - 1, object_props.y + object_props.height // 2, object_props.width - OBJECT_WIDTH)
    yield from move_edge(view3d.x + view3d.width // 2, view3d.y - 1, view3d.height - VIEW3D_HEIGHT)

    # The timeline shows the two frames.
    for a in areas("DOPESHEET_EDITOR"):
        with override(a):
            bpy.ops.action.view_all()

    # The 3D viewport: solid shading in material colors, looking at the balls from above the camera.
    space = view3d.spaces.active
    space.shading.type = "SOLID"
    space.shading.color_type = "MATERIAL"
    r3d = space.region_3d
    r3d.view_perspective = "PERSP"
    target, eye = Vector(VIEW_TARGET), Vector(VIEW_EYE)
    r3d.view_location = target
    r3d.view_rotation = (eye - target).to_track_quat("Z", "Y")
    r3d.view_distance = (eye - target).length
    redraw()


def move_edge(x, y, delta):
    """Drags the area edge through window point (x, y) by delta pixels."""
    window().cursor_warp(x, y)
    yield 0.3
    with override():
        result = bpy.ops.screen.area_move(x=x, y=y, delta=delta)
    assert result == {"FINISHED"}, f"moving the edge at {x}, {y}: {result}"
    yield 0.3


def scroll_to_refrakt(area):
    """Scrolls a Properties editor to its bottom, which brings the refrakt panels (drawn after
    most of Blender's own) into view."""
    with override(area):
        for _ in range(40):
            bpy.ops.view2d.scroll_down(page=True)
    area.tag_redraw()


def steps():
    install_addon()
    yield 0.5
    open_closed_panels()
    scene = build_scene()
    yield 0.5
    yield from lay_out()
    yield 1.0
    for a in areas("PROPERTIES"):
        scroll_to_refrakt(a)
    yield 1.0

    # Render Animation, as the panel's button runs it (invoke: modal, refrakt in a subprocess).
    props = [a for a in areas("PROPERTIES") if a.spaces.active.context == "RENDER"][0]
    with override(props):
        result = bpy.ops.refrakt.render("INVOKE_DEFAULT")
    assert result == {"RUNNING_MODAL"}, f"Render Animation: {result}, {bpy.context.window_manager.refrakt.error}"
    state = bpy.context.window_manager.refrakt
    waited, shot_progress = 0.0, False
    while state.running:
        yield 0.25
        waited += 0.25
        # refrakt reports frames as they are written, and it writes them in bursts: catch the
        # panel once refrakt has started (the bar may still be empty).
        if not shot_progress and state.running and "frame" in state.status:
            redraw()
            yield 0.3
            # The refrakt panel's top: the progress bar and its cancel button (the window on
            # screen is the one drawn before this timer ran: still rendering if this still is).
            if state.running:
                save(xwd("rendering"), "blender_progress.png", rect(props, top=PROGRESS_TOP, height=PROGRESS_HEIGHT))
                shot_progress = True
        assert waited < RENDER_TIMEOUT_S, f"refrakt still rendering after {RENDER_TIMEOUT_S:.0f} s"
    print(f"blender_screenshots: {state.status!r} error={state.error!r}", flush=True)
    assert not state.error, f"refrakt failed: {state.error}"
    if not shot_progress:
        print("blender_screenshots: the render ended before a progress screenshot", flush=True)

    # Frames in Blender ▸ Image Editor.
    with override(props):
        result = bpy.ops.refrakt.load_frames(compositor=False)
    assert result == {"FINISHED"}, f"Load Frames: {result}"
    image_editor = areas("IMAGE_EDITOR")[0]
    yield 1.0
    # Color only: the frame's alpha is the coverage of refractive media (so that it lays over
    # Blender's render), and Color & Alpha would show the checkerboard through everything else.
    image_editor.spaces.active.display_channels = "COLOR"
    with override(image_editor):
        bpy.ops.image.view_all(fit_view=True)
    scene.frame_set(1)
    for a in areas("PROPERTIES"):
        scroll_to_refrakt(a)
    redraw()
    yield 2.0

    shot = xwd("window")
    save(shot, "blender_frame_in_blender.png")
    save(shot, "blender_panel.png", rect(props))
    object_props = [a for a in areas("PROPERTIES") if a.spaces.active.context == "OBJECT"][0]
    save(shot, "blender_object_panel.png", rect(object_props))
    yield 0.2


_steps = None


def tick():
    global _steps
    try:
        if _steps is None:
            OUT.mkdir(parents=True, exist_ok=True)
            WORK.mkdir(parents=True, exist_ok=True)
            _steps = steps()
        return next(_steps)
    except StopIteration:
        print("blender_screenshots: done", flush=True)
        with override():
            bpy.ops.wm.quit_blender()
        return None
    except Exception:
        traceback.print_exc()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(1)


if __name__ == "__main__":  # (scripts/blender_engine_screenshots.py imports the helpers above)
    bpy.app.timers.register(tick, first_interval=1.0)
