#!/usr/bin/env python3
"""refrakt against Cycles, side by side: caustic error against wall time on one scene.

The scene (built here in bpy): a glass ball and the glass Stanford bunny (read from
../shared/assets/bunny.obj) on a white floor, lit by a sun of 3° angular diameter and a spot
light of 0.1 m radius, in a black world, so the only light is the sun and the spot: direct light
and caustics, which is what refrakt computes. It is exported through the add-on as a user would
(the *Export for refrakt* operator writes a .glb and a Lua wrapper), and rendered

- by refrakt at rising photon counts (the command line the add-on's *Render Animation* runs, plus
  `--photons N`), timed from process start to the image on disk;
- by Cycles (CPU here) at rising sample counts, timed around the render call;
- once by Cycles at very many samples (8192, ~18 min on 2 shared cores): the reference, cached
  in docs/images/cycles_reference.npz (half floats, with the direct light alone, the floor and
  the caustic region) so re-runs skip it. It is not noise-free: its own RMSE, estimated from
  Cycles' curve, is reported with the results.

Cycles' light paths are set to the light transport refrakt computes: 1 diffuse bounce (the floor
sees the lights through the glass: caustics), 16 glossy and transmission bounces, 16 in all,
reflective and refractive caustics on, Filter Glossy 0, no clamping, no denoising, no adaptive
sampling, a 1-pixel box filter, no world light. What still differs:

- refrakt's glass is the mesh with smooth normals as a sharp interface (Fresnel reflection and
  refraction) for photons and view rays alike; so is Cycles' Principled BSDF (transmission 1,
  roughness 0, IOR 1.5). Cycles follows a path's reflection *or* refraction at random, as
  refrakt's photons do; refrakt's view rays trace both parts, to 8 interface events, dropping
  parts under 0.2 % of the pixel (Cycles: 16 bounces). Only the floor seen directly is scored.
- refrakt does not export Blender's sun angle (glTF has none; refrakt's glTF reader uses 0.53°):
  the wrapper is extended by hand, as its header invites, with `angular_diameter = 3`.
- Cycles' spot with a radius is a sphere light with a soft cone edge (smoothstep of
  `spot_blend`); refrakt's is a sphere of that radius with glTF's inner/outer cone.
- refrakt's caustics are photon density estimates on the floor (biased: blurred by the kernel,
  less so with more photons); Cycles is unbiased but noisy. The mean-level ratio shows a bias.
- No light reaches the floor after two diffuse bounces in either (Cycles: max 1 diffuse bounce).

Error (the caustic error): over the floor where the caustics fall, the RMSE of the RGB values
(absolute, no rescaling) of each image against the reference, also relative to the reference's
mean there, and the mean-level ratio (image mean / reference mean there). The region: pixels
that see the floor directly (Cycles' object index pass, eroded by one pixel so no edge is half
glass) whose caustic light (reference minus a Cycles render of direct light only, smoothed over
5×5 pixels) exceeds 10 % of its 99th percentile over the floor.

Outputs (under --out: docs/images, or WORK with --quick): compare_cycles.json (every point),
compare_cycles.md (the table and the headline: the time each renderer needs to reach the same
caustic error, interpolated log-log), compare_cycles.png (error against wall time, log-log;
drawn by compare_plot.py with numpy, as this venv has no matplotlib), compare_cycles_images.png
(the reference with the region outlined, each renderer's largest run); the reference in
--reference-dir (docs/images): cycles_reference.npz and a preview, cycles_reference.png.

Run with the bpy module's Python (scripts/test_blender.sh sets one up):

    ~/.cache/refrakt/venv-bpy-4.5.15/bin/python scripts/compare_cycles.py \\
        --refrakt target/release/refrakt [--quick] [--work DIR]

refrakt's timings from another machine (one without bpy, e.g. a GPU box): the run above writes
the exported scene to DIR/scene (`--export-only` writes just that, in seconds). Copy DIR/scene
there; then, with any Python 3 (no bpy, no numpy needed):

    python3 scripts/compare_cycles.py --refrakt-only --work DIR --refrakt PATH [--label H200]

writes refrakt's images and times to DIR/refrakt-<label>/ (each run's wall and CPU seconds in
times.json); back here, score them against the reference next to the Cycles and refrakt runs
DIR already holds, rendering nothing again:

    ~/.cache/refrakt/venv-bpy-4.5.15/bin/python scripts/compare_cycles.py --work DIR --score-only \\
        --refrakt-results DIR/refrakt-H200

Timings: wall seconds, and CPU seconds (refrakt: the child process's user + system time;
Cycles: this process's CPU time over the render call, all threads), since a shared machine's
load stretches wall time. Every run is one process or render call, cold: refrakt's times include
its start (device, shaders, scene, BVH), Cycles' its scene sync and BVH build.
"""

import argparse
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile
import time

from compare_plot import amount, image_strip, plot, png_of_image, short

ROOT = pathlib.Path(__file__).resolve().parent.parent
BUNNY = ROOT.parent / "shared" / "assets" / "bunny.obj"
MODULE = "bl_ext.user_default.refrakt"

SIZE = (200, 112)
SUN_ANGLE_DEG = 3.0
SCENE_NAME = "compare"
REFERENCE_SAMPLES = 8192
REFERENCE_SEED = 7919  # not the runs' seed 0, so the reference's samples are not theirs
# (refrakt photons, Cycles samples) per mode.
PLANS = {
    "full": ([10_000, 30_000, 100_000, 300_000, 1_000_000, 2_000_000], [1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024]),
    "quick": ([10_000, 100_000, 1_000_000], [1, 4, 16, 64]),
}


# --- refrakt runs: no bpy here, so they also run on a machine without Blender ----------------

def refrakt_run(binary, scene_dir, command, photons, out_dir):
    """Runs refrakt as the add-on would (the stored command line) with --photons; returns the
    EXR's path and the wall time from process start to the image on disk (refrakt writes it
    atomically and exits)."""
    name = f"refrakt-{photons}"
    argv = [binary] + command + ["--photons", str(photons), "--out", str(out_dir), "--name", name,
                                 "--format", "exr", "--frames", "1..1"]
    t0, c0 = time.perf_counter(), _children_cpu()
    try:
        proc = subprocess.run(argv, cwd=scene_dir, capture_output=True, text=True)
    except OSError as e:
        raise SystemExit(f"{binary} cannot be started: {e.strerror}")
    seconds, cpu = time.perf_counter() - t0, _children_cpu() - c0
    if proc.returncode != 0:
        raise SystemExit(f"refrakt failed ({' '.join(argv)}):\n{proc.stderr[-2000:]}")
    exr = pathlib.Path(out_dir) / f"{name}.0001.exr"
    if not exr.is_file():
        raise SystemExit(f"refrakt exited without writing {exr}")
    return exr, seconds, cpu


def _children_cpu():
    import resource

    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def refrakt_series(binary, work, photon_counts, label):
    """Renders every photon count; writes DIR/refrakt-<label>/times.json. Returns its rows."""
    scene_dir = work / "scene"
    setup = json.loads((scene_dir / "compare.json").read_text())
    out = work / f"refrakt-{label}"
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for n in photon_counts:
        exr, seconds, cpu = refrakt_run(binary, scene_dir, setup["command"], n, out)
        print(f"refrakt {label}: {n} photons, {seconds:.2f} s ({cpu:.2f} s CPU)", flush=True)
        rows.append({"photons": n, "seconds": seconds, "cpu_seconds": cpu, "image": exr.name})
    version = subprocess.run([binary, "--version"], capture_output=True, text=True).stdout.strip()
    meta = {"label": label, "binary": str(binary), "version": version, "runs": rows}
    (out / "times.json").write_text(json.dumps(meta, indent=1))
    return out


# --- measuring -------------------------------------------------------------------------------

def read_exr_rgb(path):
    """Linear RGB (H×W×3 float32, top row first) of an EXR: refrakt's beauty or Cycles' Combined."""
    import numpy as np
    import OpenEXR

    with OpenEXR.File(str(path), separate_channels=True) as f:
        channels = f.channels()
        for prefix in ("", "ViewLayer.Combined.", "beauty."):
            names = [prefix + c for c in "RGB"]
            if all(n in channels for n in names):
                return np.stack([channels[n].pixels.astype(np.float32) for n in names], axis=-1)
        raise SystemExit(f"{path}: no RGB channels (has {sorted(channels)})")


def read_exr_channel(path, name):
    import OpenEXR

    with OpenEXR.File(str(path), separate_channels=True) as f:
        return f.channels()[name].pixels


def eroded(mask):
    """The mask less every pixel with a 4-neighbour outside it (or outside the image)."""
    import numpy as np

    m = np.pad(mask, 1, constant_values=False)
    return mask & m[:-2, 1:-1] & m[2:, 1:-1] & m[1:-1, :-2] & m[1:-1, 2:]


def caustic_region(reference, direct, floor):
    """Where the caustics fall on the floor (see the module's docstring)."""
    import numpy as np

    caustic = np.clip(reference - direct, 0, None).mean(axis=-1)
    padded = np.pad(caustic, 2, mode="edge")
    smooth = sum(padded[i:i + caustic.shape[0], j:j + caustic.shape[1]] for i in range(5) for j in range(5)) / 25
    inner = eroded(floor)
    level = np.percentile(smooth[inner], 99)
    return inner & (smooth > 0.1 * level)


def score(image, reference, region, floor):
    """The caustic error in the region, and the mean-level ratios there and on the rest of the
    directly seen floor (direct light mostly: where a unit or light mismatch would show)."""
    import numpy as np

    diff = image[region] - reference[region]
    mean_ref = float(reference[region].mean())
    rmse = float(np.sqrt(np.mean(diff ** 2)))
    rest = floor & ~region
    return {"rmse": rmse, "relative": rmse / mean_ref, "level": float(image[region].mean()) / mean_ref,
            "floor_level": float(image[rest].mean() / reference[rest].mean())}


def time_to_reach(points, target):
    """Seconds a renderer needs to reach `target` relative error: log-log interpolation along its
    best-so-far curve (points sorted by time); None when it never does."""
    points = sorted(points, key=lambda p: p["seconds"])
    best, prev = math.inf, None
    for p in points:
        err = min(best, p["relative"])
        if err <= target:
            if prev is None or prev[1] <= target:
                return p["seconds"]
            (t0, e0), (t1, e1) = prev, (p["seconds"], err)
            if e1 == e0:
                return t1
            k = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + k * (math.log(t1) - math.log(t0)))
        best, prev = err, (p["seconds"], err)
    return None


def headline(series, no_caustics, law, reference_mean):
    """The time each renderer needs to reach a few relative errors: each renderer's best, and
    round levels between; only levels below the error of an image without caustics (a higher
    one is reached by leaving them out). Interpolated; Cycles' extrapolated by `law` past its
    last run (marked)."""
    bests = {min(p["relative"] for p in pts) for pts in series.values()}
    targets = sorted({t for t in bests | {0.2, 0.15, 0.125} if t < no_caustics and t >= min(bests)}, reverse=True)
    first = {k: min(pts, key=lambda p: p["seconds"]) for k, pts in series.items()}
    rows = []
    for t in targets:
        row = {"relative": t, "seconds": {}, "at_most": {}, "extrapolated": {}}
        for k, pts in series.items():
            seconds, extrapolated = time_to_reach(pts, t), False
            if seconds is None and k == "Cycles CPU":
                seconds, extrapolated = law.seconds_to(t * reference_mean), True
            row["seconds"][k], row["extrapolated"][k] = seconds, extrapolated and seconds is not None
            # reached by the first (fastest) run already: its time is an upper bound
            row["at_most"][k] = first[k]["relative"] <= t
        rows.append(row)
    return rows


# --- Blender: the scene, the export, Cycles ------------------------------------------------------

def blender():
    os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="refrakt-compare-"))
    import bpy

    return bpy


def install_addon(bpy, refrakt):
    sys.path.insert(0, str(ROOT / "scripts"))
    import build_blender_addon

    zip_path = build_blender_addon.build(tempfile.mkdtemp())
    bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default", enable_on_install=True)
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.preferences.addons[MODULE].preferences.binary = refrakt


def principled(bpy, name, color, glass):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.0 if glass else 1.0
    if glass:
        bsdf.inputs["Transmission Weight"].default_value = 1.0
        bsdf.inputs["IOR"].default_value = 1.5
    else:
        bsdf.inputs["Specular IOR Level"].default_value = 0.0  # a Lambertian floor, as refrakt's
    return m


def build_scene(bpy, folder, photons):
    from mathutils import Vector

    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    scene.frame_start = scene.frame_end = scene.frame_current = 1

    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location = (0.0, -2.4, 1.4)
    cam.rotation_euler = (Vector((-0.05, 0.05, 0.17)) - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 36
    scene.camera = cam

    bpy.ops.mesh.primitive_plane_add(size=8)
    floor = bpy.context.object
    floor.name = "Floor"
    floor.pass_index = 1
    floor.data.materials.append(principled(bpy, "Floor", (0.8, 0.8, 0.8), glass=False))

    glass = principled(bpy, "Glass", (1.0, 1.0, 1.0), glass=True)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.3, location=(-0.55, 0.0, 0.3), segments=64, ring_count=32)
    ball = bpy.context.object
    ball.name = "Ball"
    bpy.ops.object.shade_smooth()
    ball.data.materials.append(glass)

    bpy.ops.wm.obj_import(filepath=str(BUNNY))
    bunny = bpy.context.selected_objects[0]
    bunny.name = "Bunny"
    bunny.scale = (3.5, 3.5, 3.5)
    bpy.context.view_layer.update()
    low = min((bunny.matrix_world @ Vector(c)).z for c in bunny.bound_box)
    mid = sum((bunny.matrix_world @ Vector(c) for c in bunny.bound_box), Vector()) / 8
    bunny.location += Vector((0.45 - mid.x, 0.1 - mid.y, -low))
    bunny.data.materials.clear()
    bunny.data.materials.append(glass)
    for poly in bunny.data.polygons:
        poly.use_smooth = True

    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.data.angle = math.radians(SUN_ANGLE_DEG)
    sun.rotation_euler = (math.radians(40), 0, math.radians(-35))
    scene.collection.objects.link(sun)

    spot = bpy.data.objects.new("Spot", bpy.data.lights.new("Spot", "SPOT"))
    spot.data.energy = 400.0
    spot.data.shadow_soft_size = 0.1
    spot.data.spot_size = math.radians(50)
    spot.data.spot_blend = 0.15
    spot.location = (1.6, -1.2, 2.2)
    spot.rotation_euler = (Vector((0.2, 0.1, 0.0)) - spot.location).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(spot)

    world = bpy.data.worlds.new("Black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world

    s = scene.refrakt
    s.photons = photons
    s.directory = str(folder) + os.sep
    s.basename = SCENE_NAME
    s.source = "LUA"
    return scene


def export_for_refrakt(bpy, scene, folder, binary):
    """The add-on's Export operator, the wrapper extended by hand with the sun's angle, and the
    Render Animation operator's command line (cli.render) stored for --refrakt-only runs."""
    folder.mkdir(parents=True, exist_ok=True)
    scene_export = sys.modules[MODULE + ".scene_export"]
    paths = scene_export.paths(scene)
    if os.path.exists(paths.lua):
        os.remove(paths.lua)  # a fresh wrapper each run, extended below
    assert bpy.ops.refrakt.export() == {"FINISHED"}, "the add-on's export failed"
    cli = sys.modules[MODULE + ".cli"]
    lua = pathlib.Path(paths.lua)
    text = lua.read_text()
    extension = f'scene:find("Sun").light.angular_diameter = {SUN_ANGLE_DEG:g}  -- Blender\'s sun angle\n'
    lua.write_text(text.replace("\nreturn scene\n", "\n" + extension + "\nreturn scene\n"))
    argv = cli.render(binary, scene, paths)
    # Keep what chooses the scene, its camera and size; each run sets frames, output and photons.
    drop = {"--frames", "--out", "--name", "--format", "--progress"}
    command, k = [], 1
    while k < len(argv):
        if argv[k] in drop:
            k += 2
            continue
        command.append(argv[k])
        k += 1
    command[1] = os.path.basename(command[1])  # the scene, relative to the folder it runs in
    (folder / "compare.json").write_text(json.dumps({"command": command, "sun_angle_deg": SUN_ANGLE_DEG}, indent=1))
    dump = subprocess.run([binary, "dump", command[1]], cwd=folder, capture_output=True, text=True, check=True)
    lights = json.loads(dump.stdout.splitlines()[0])["lights"]
    suns = [l for l in lights if l["kind"] == "sun"]
    got = math.degrees(suns[0]["angular_diameter"]) if suns else None
    if got is None or abs(got - SUN_ANGLE_DEG) > 1e-3:
        raise SystemExit(f"the exported scene's sun has angular diameter {got}°, not {SUN_ANGLE_DEG}°")


def cycles_settings(scene, samples, diffuse_bounces=1, seed=0):
    import cycles_parity  # (numpy and bpy: only where Cycles runs)

    cycles_parity.cycles_settings(scene, samples, diffuse_bounces, seed)
    scene.render.image_settings.file_format = "OPEN_EXR_MULTILAYER"
    scene.render.image_settings.color_depth = "32"
    scene.render.image_settings.exr_codec = "ZIP"


def cycles_render(bpy, scene, samples, path, diffuse_bounces=1, seed=0):
    """Renders with Cycles; returns the wall and CPU seconds of the render call."""
    cycles_settings(scene, samples, diffuse_bounces, seed)
    scene.render.filepath = str(path)
    t0, c0 = time.perf_counter(), time.process_time()
    bpy.ops.render.render(write_still=False)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    bpy.data.images["Render Result"].save_render(filepath=str(path))
    return seconds, cpu


def load_reference(cache):
    """The reference, its direct light alone, the caustic region, the floor, the seconds it took."""
    import numpy as np

    data = np.load(cache)
    return (data["reference"].astype(np.float32), data["direct"].astype(np.float32), data["region"], data["floor"],
            float(data["seconds"]))


class CyclesLaw:
    """Cycles' error against samples: with independent seeds a run of N samples measures
    m² = σ²/N + σ²/R against a reference of R samples. σ² is fitted (least squares) to the runs of
    64 samples and more, where fireflies have averaged out, and so are the seconds per sample."""

    def __init__(self, cycles_points, reference_samples):
        runs = [p for p in cycles_points if p["samples"] >= 64]
        self.reference_samples = reference_samples
        self.sigma2 = None
        if runs:
            x = [1 / p["samples"] + 1 / reference_samples for p in runs]
            self.sigma2 = sum(xi * p["rmse"] ** 2 for xi, p in zip(x, runs)) / sum(xi * xi for xi in x)
            self.seconds_per_sample = sum(p["seconds"] for p in runs) / sum(p["samples"] for p in runs)

    def reference_noise(self):
        """The reference's own RMSE."""
        return math.sqrt(self.sigma2 / self.reference_samples) if self.sigma2 else None

    def seconds_to(self, rmse):
        """Extrapolated seconds to measure `rmse`; None below the reference's own noise."""
        if not self.sigma2 or rmse ** 2 <= self.sigma2 / self.reference_samples:
            return None
        return self.sigma2 / (rmse ** 2 - self.sigma2 / self.reference_samples) * self.seconds_per_sample


def make_reference(bpy, scene, work, cache, samples):
    """The converged reference, the direct light alone and the floor mask, cached in `cache`
    (skipped when the cache holds this many samples at this size)."""
    import numpy as np

    if cache.is_file():
        data = np.load(cache)
        if int(data["samples"]) == samples and tuple(data["reference"].shape[:2]) == (SIZE[1], SIZE[0]):
            print(f"reference: cached {cache} ({samples} samples)", flush=True)
            return
    bpy.context.view_layer.use_pass_object_index = True
    print(f"reference: Cycles at {samples} samples (cached afterwards)", flush=True)
    seconds, _ = cycles_render(bpy, scene, samples, work / "reference.exr", seed=REFERENCE_SEED)
    direct_seconds, _ = cycles_render(bpy, scene, 256, work / "direct.exr", diffuse_bounces=0, seed=REFERENCE_SEED)
    bpy.context.view_layer.use_pass_object_index = False
    ref = read_exr_rgb(work / "reference.exr")
    direct = read_exr_rgb(work / "direct.exr")
    floor = read_exr_channel(work / "reference.exr", "ViewLayer.IndexOB.X") == 1
    region = caustic_region(ref, direct, floor)
    np.savez_compressed(cache, reference=ref.astype(np.float16), direct=direct.astype(np.float16), region=region,
                        floor=eroded(floor), samples=samples,
                        seconds=seconds,
                        direct_seconds=direct_seconds)
    print(f"reference: {seconds:.0f} s; caustic region {int(region.sum())} pixels", flush=True)


# --- the whole comparison ------------------------------------------------------------------------

def table(series, heads, meta):
    lines = [f"Scene: {meta['scene']}. Reference: Cycles, {meta['reference_samples']} samples "
             f"({meta['reference_seconds']:.0f} s), {SIZE[0]}×{SIZE[1]}; caustic region {meta['region_pixels']} pixels, "
             f"reference mean {meta['reference_mean']:.4g} there. Without any caustics (Cycles' direct light alone) the "
             f"error is {100 * meta['no_caustics']['relative']:.1f} %" + (
                 f"; the reference's own noise, estimated from Cycles' curve, is an RMSE of "
                 f"{meta['reference_noise_rmse']:.3g} ({100 * meta['reference_noise_rmse'] / meta['reference_mean']:.1f} %)"
                 if meta["reference_noise_rmse"] else "") + ".", "",
             "| renderer | photons / samples | wall s | CPU s | caustic RMSE | RMSE / ref. mean | mean / ref. mean | rest of floor: mean / ref. |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name, pts in series.items():
        for p in sorted(pts, key=amount):
            what = f"{p['photons']:,} photons" if "photons" in p else f"{p['samples']} samples"
            cpu = f"{p['cpu_seconds']:.2f}" if p.get("cpu_seconds") is not None else "–"
            lines.append(f"| {name} | {what} | {p['seconds']:.2f} | {cpu} | {p['rmse']:.4g} | {100 * p['relative']:.1f} % | "
                         f"{p['level']:.3f} | {p['floor_level']:.3f} |")
    lines += ["", "Time to reach the same caustic error (log-log interpolation along each renderer's best-so-far curve; "
              "Cycles' past its last run extrapolated by its fitted m² = σ²/N + σ²/R; only errors below an image's without "
              "caustics; ≤: that renderer's fastest run is already there):", "",
              "| RMSE / ref. mean | " + " | ".join(f"{n} s" for n in series) + " |",
              "| --- | " + " | ".join("---" for _ in series) + " |"]
    for h in heads:
        cells = [("≤ " if h["at_most"][n] else "") + f"{h['seconds'][n]:.2f}"
                 + (" (extrapolated)" if h["extrapolated"][n] else "") if h["seconds"][n] is not None
                 else "not reached" for n in series]
        lines.append(f"| {100 * h['relative']:.1f} % | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def cycles_series(bpy, scene, work, sample_counts):
    """Renders every sample count; writes WORK/cycles/times.json."""
    folder = work / "cycles"
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    for n in sample_counts:
        path = folder / f"cycles-{n}.exr"
        seconds, cpu = cycles_render(bpy, scene, n, path)
        print(f"Cycles CPU: {n} samples, {seconds:.2f} s ({cpu:.2f} s CPU)", flush=True)
        rows.append({"samples": n, "seconds": seconds, "cpu_seconds": cpu, "image": path.name})
    meta = {"label": "Cycles CPU", "blender": bpy.app.version_string, "runs": rows}
    (folder / "times.json").write_text(json.dumps(meta, indent=1))


def scored(folder, ref, region, floor):
    """A series written by cycles_series or refrakt_series, each image scored."""
    meta = json.loads((folder / "times.json").read_text())
    keep = ("photons", "samples", "seconds", "cpu_seconds", "image")
    return meta["label"], meta.get("version") or f"Blender {meta.get('blender')}", [
        {**{k: r[k] for k in keep if k in r}, **score(read_exr_rgb(folder / r["image"]), ref, region, floor)}
        for r in meta["runs"]
    ]


def reference_cache(args):
    """The reference's cache file (in --reference-dir) and its samples."""
    folder = pathlib.Path(args.reference_dir).resolve()
    folder.mkdir(parents=True, exist_ok=True)
    samples = args.reference_samples or REFERENCE_SAMPLES
    if args.quick and not args.reference_samples and not (folder / "cycles_reference.npz").is_file():
        samples = 1024  # no cached reference: a rough one, so --quick stays quick
    name = "cycles_reference.npz" if samples == REFERENCE_SAMPLES else f"cycles_reference_{samples}.npz"
    return folder / name, samples


def plan(args):
    """The photon and sample counts to run: the mode's, or the lists given."""
    photons, samples = PLANS["quick" if args.quick else "full"]
    return args.photons or photons, args.samples or samples


def counts(text):
    try:
        values = [int(float(x)) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of counts (e.g. 10000,1e6)")
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: counts must be at least 1")
    return values


def render_all(args, work):
    """Builds and exports the scene, makes the reference if not cached, renders both series."""
    bpy = blender()
    binary = os.path.abspath(args.refrakt)
    photon_counts, sample_counts = plan(args)
    install_addon(bpy, binary)
    scene = build_scene(bpy, work / "scene", photon_counts[0])
    export_for_refrakt(bpy, scene, work / "scene", binary)
    if args.export_only:
        return
    cache, samples = reference_cache(args)
    make_reference(bpy, scene, work, cache, samples)
    cycles_series(bpy, scene, work, sample_counts)
    if not args.skip_refrakt:
        refrakt_series(binary, work, photon_counts, args.label)


def compare(args):
    work = pathlib.Path(args.work).resolve()
    out = pathlib.Path(args.out or (work if args.quick else ROOT / "docs" / "images")).resolve()
    out.mkdir(parents=True, exist_ok=True)
    if not args.score_only:
        render_all(args, work)
        if args.export_only:
            print(f"exported to {work / 'scene'}")
            return
    cache, samples = reference_cache(args)
    if not cache.is_file():
        raise SystemExit(f"{cache} is missing: run without --score-only first")
    ref, direct, region, floor, ref_seconds = load_reference(cache)
    png_of_image(cache.with_suffix(".png"), ref)

    folders = [work / "cycles"]
    if not args.skip_refrakt:
        folders.append(work / f"refrakt-{args.label}")
    folders += [pathlib.Path(f) for f in args.refrakt_results]
    series, versions = {}, {}
    for folder in folders:
        if not (folder / "times.json").is_file():
            raise SystemExit(f"{folder}/times.json is missing: nothing rendered there yet")
        label, version, pts = scored(folder, ref, region, floor)
        name = label if label == "Cycles CPU" else f"refrakt {label}"
        series[name], versions[name] = pts, version

    law = CyclesLaw(series["Cycles CPU"], samples)
    noise = law.reference_noise()
    no_caustics = score(direct, ref, region, floor)
    heads = headline(series, no_caustics["relative"], law, float(ref[region].mean()))
    meta = {"scene": "glass ball + glass bunny on a white floor, sun (3°) + spot (0.1 m), black world",
            "size": SIZE, "reference_samples": samples, "reference_seconds": ref_seconds,
            "region_pixels": int(region.sum()), "reference_mean": float(ref[region].mean()), "quick": args.quick,
            "no_caustics": no_caustics,
            "reference_noise_rmse": noise, "versions": versions}
    stem = "compare_cycles_quick" if args.quick else "compare_cycles"
    (out / f"{stem}.json").write_text(json.dumps({"meta": meta, "series": series, "headline": heads}, indent=1))
    (out / f"{stem}.md").write_text(table(series, heads, meta))
    plot(out / f"{stem}.png", series, baseline=meta["no_caustics"]["relative"])
    image_strip(out / f"{stem}_images.png", ref, region & ~eroded(region), [
        (f"{name.split()[0]} {short(amount(p))}", read_exr_rgb(folder / p["image"]))
        for (name, pts), folder in zip(series.items(), folders) for p in [max(pts, key=amount)]])
    print(table(series, heads, meta))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    parser.add_argument("--refrakt", help="the refrakt executable (not needed with --score-only)")
    parser.add_argument("--work", default=os.path.join(tempfile.gettempdir(), "refrakt-compare-cycles"),
                        help="folder for the exported scene (WORK/scene) and the renders")
    parser.add_argument("--out", help="folder for the table, plot and JSON (default: docs/images; with --quick, WORK)")
    parser.add_argument("--reference-dir", default=str(ROOT / "docs" / "images"),
                        help="folder of the cached reference, cycles_reference.npz (default: docs/images)")
    parser.add_argument("--quick", action="store_true", help="fewer, cheaper runs (about 3 minutes)")
    parser.add_argument("--reference-samples", type=int, help=f"Cycles samples of the reference (default {REFERENCE_SAMPLES})")
    parser.add_argument("--refrakt-only", action="store_true",
                        help="only render WORK/scene with refrakt and write images and times (no bpy needed)")
    parser.add_argument("--label", default="lavapipe", help="name of this machine's refrakt series")
    parser.add_argument("--refrakt-results", action="append", default=[],
                        help="a folder a --refrakt-only run wrote, to score as well (repeatable)")
    parser.add_argument("--skip-refrakt", action="store_true", help="do not run refrakt here (score only --refrakt-results)")
    parser.add_argument("--photons", type=counts, help="refrakt's photon counts, e.g. 10000,1e5,1e6 (default: the mode's)")
    parser.add_argument("--samples", type=counts, help="Cycles' sample counts, e.g. 1,16,256 (default: the mode's)")
    parser.add_argument("--export-only", action="store_true",
                        help="only build and export the scene to WORK/scene (for --refrakt-only elsewhere)")
    parser.add_argument("--score-only", action="store_true",
                        help="render nothing: score what WORK holds (and --refrakt-results) against the cached reference")
    args = parser.parse_args()
    if not args.refrakt and not args.score_only:
        parser.error("--refrakt PATH is needed to render")
    if args.refrakt_only:
        work = pathlib.Path(args.work).resolve()
        if not (work / "scene" / "compare.json").is_file():
            raise SystemExit(f"{work}/scene/compare.json is missing: run the comparison with --work {work} first")
        photon_counts = plan(args)[0]
        print(refrakt_series(os.path.abspath(args.refrakt), work, photon_counts, args.label))
        return
    if not BUNNY.is_file() and not args.score_only:
        raise SystemExit(f"{BUNNY} is missing (the bunny is read from ../shared/assets, not kept in this repository)")
    compare(args)


if __name__ == "__main__":
    main()
