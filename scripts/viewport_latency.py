#!/usr/bin/env python3
"""Measures the viewport's Rendered-mode latency through the add-on with the real refrakt: from a
view change (an orbit step) or an edit (a moved glass ball) to the new frame's pixels in hand,
i.e. what `view_draw` uploads next. Headless Blender draws nothing, so the GPU upload of the
texture (a few milliseconds) is not in these figures; everything before it is: the view script
written, refrakt watch noticing it, reloading the scene, rendering (reusing the volume and the
photons for a view change), writing the preview, the add-on reading it back.

Run with the bpy module's Python (scripts/test_blender.sh sets one up):

    ~/.cache/refrakt/venv-bpy-4.5.15/bin/python scripts/viewport_latency.py \
        --refrakt target/release/refrakt [--size 960x540] [--steps 10]

Prints one JSON object: the median and each sample per kind of change, and the frame sizes.
"""

import argparse
import json
import math
import os
import pathlib
import statistics
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="refrakt-latency-"))

import bpy  # noqa: E402
from mathutils import Matrix  # noqa: E402

sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "tests" / "blender"))
import blender_figure  # noqa: E402
import scenes  # noqa: E402


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--refrakt", required=True)
    p.add_argument("--size", default="480x270", help="the viewport region's pixels (the render is --scale %% of it)")
    p.add_argument("--scale", type=int, default=100, help="Viewport Resolution, percent")
    p.add_argument("--steps", type=int, default=8)
    p.add_argument("--volume", type=int, default=64)
    p.add_argument("--photons", type=int, default=20000)
    return p.parse_args()


def projection(fov_deg, aspect):
    m = Matrix.Identity(4)
    t = 1.0 / math.tan(math.radians(fov_deg) / 2)
    m[0][0], m[1][1] = t / aspect, t
    return m


def view(angle_deg):
    a = math.radians(angle_deg)
    probe = bpy.data.objects.new("probe", None)
    probe.location = (6 * math.sin(a), -6 * math.cos(a), 2.0)
    scenes.look_at(probe, (0, 0, 0.5))
    world = probe.matrix_basis.copy()
    bpy.data.objects.remove(probe)
    return world.inverted()


def wait_for_frame(session, before, timeout=600.0):
    """Ticks as the UI timer does until a final frame newer than `before` is read back."""
    deadline = time.monotonic() + timeout
    while True:
        session.tick()
        if session.frames > before and session.quality == "final":
            session.pixels()
            return
        if session.error:
            raise SystemExit(f"refrakt: {session.error}")
        if time.monotonic() > deadline:
            raise SystemExit("no frame within the timeout")
        time.sleep(0.002)


def main():
    args = parse_args()
    w, h = (int(x) for x in args.size.split("x"))
    blender_figure.install(os.path.abspath(args.refrakt))
    viewport = sys.modules[blender_figure.MODULE + ".viewport"]
    work = tempfile.mkdtemp(prefix="refrakt-latency-")
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(work, "latency.blend"))
    scene = scenes.round_trip_scene()
    scene.refrakt.volume_resolution, scene.refrakt.photons, scene.refrakt.samples = args.volume, args.photons, 1
    scene.refrakt.live_debounce = 0.05
    bpy.context.view_layer.update()

    def camera(angle):
        return viewport.view_camera(view(angle), projection(40.0, w / h), (w, h), args.scale)

    session = viewport.ViewportSession(scene, os.path.abspath(args.refrakt))
    started = time.monotonic()
    session.set_view(camera(0))
    wait_for_frame(session, 0)
    first = time.monotonic() - started
    orbit, moves, reused = [], [], []
    for i in range(1, args.steps + 1):
        before, t0 = session.frames, time.monotonic()
        session.set_view(camera(5 * i))
        wait_for_frame(session, before)
        orbit.append(time.monotonic() - t0)
        reused.append(session.reused)
    ball = bpy.data.objects["Ball"]
    for i in range(1, args.steps + 1):
        before, t0 = session.frames, time.monotonic()
        ball.location.x = -1.0 + 0.02 * i
        session.pending.add("transform")  # what view_update would note
        session.dirty_since = time.monotonic() - scene.refrakt.live_debounce  # no debounce wait
        wait_for_frame(session, before)
        moves.append(time.monotonic() - t0)
    session.stop()
    ms = lambda xs: [round(1e3 * x, 1) for x in xs]  # noqa: E731
    print(json.dumps({
        "blender": bpy.app.version_string,
        "render_size": camera(0)["size"],
        "volume": args.volume,
        "photons": args.photons,
        "first_frame_ms": round(1e3 * first, 1),
        "orbit_ms": {"median": round(1e3 * statistics.median(orbit), 1), "samples": ms(orbit)},
        "orbit_reused_volume_and_photons": all(r and r["volume"] and r["photons"] for r in reused),
        "object_move_ms": {"median": round(1e3 * statistics.median(moves), 1), "samples": ms(moves)},
    }, indent=2))


if __name__ == "__main__":
    main()
