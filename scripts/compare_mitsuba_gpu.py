#!/usr/bin/env python3
"""refrakt against Mitsuba 3 on the same GPU: the floor under a glass ball and under the glass
Stanford bunny in the sun (the scenes of tests/mitsuba_caustics.rs), error against GPU time.

The error is the relative L1, Σ|E − E_ref| / Σ E_ref, of the floor's irradiance E (the light
straight from the sun and the caustic) over the 128² grid of x, z in [−1, 1] m, against a
reference Mitsuba converges on the GPU first: 2²⁰ light paths per pixel of its particle tracer
(its own error, from its two halves, 0.003). What each renderer does to get the floor:

* Mitsuba 3.9.1 (`cuda_ad_rgb`, drjit 1.5.0): its particle tracer, with the stock dielectric,
  at 1 to 131072 light paths per pixel; the time is the render, median of three after a warm-up
  (kernels compiled). The script first checks that its particle tracer and its path tracer read
  the open floor (the grid's four 16² corners) as the sun's irradiance there, cos θ = 0.966 W/m²,
  within 2 %: Mitsuba 3.5.2's CUDA particle tracer reads 1.92.
* refrakt at 25k to 1.6M photons per frame: its caustic's error, against the same reference's
  caustic (its floor less the unrefracted light), from the ignored test
  `caustic_error_against_photons_for_the_mitsuba_gpu_comparison` — deterministic, so measured on
  any adapter — with its direct light taken as exact (shadow rays; tests/lights.rs checks it);
  its time, `refrakt bench`'s median GPU frame (voxelize, octree, photons, march, caustic filter
  and an 8×8 view) of the same scenes.

Then, for each refrakt point, the time Mitsuba needs for the same error (its curve interpolated
in log–log), and the ratio.

    # on the GPU machine, with Mitsuba 3.9.1 and drjit 1.5.0 for its Python, and bunny.obj:
    python3 scripts/compare_mitsuba_gpu.py mitsuba --bunny bunny.obj --out target/compare_mitsuba_gpu
    # here, with that folder (its <scene>_reference.exr):
    cargo test --release --test mitsuba_caustics -- --ignored --nocapture
    # on the GPU machine again, with refrakt and the scenes the test wrote:
    python3 scripts/compare_mitsuba_gpu.py refrakt --binary refrakt --bunny bunny.obj --out target/compare_mitsuba_gpu
    python3 scripts/compare_mitsuba_gpu.py report target/compare_mitsuba_gpu --plot docs/images/mitsuba_gpu.png
"""

import argparse
import glob
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ERRORS_DIR = os.path.join(ROOT, "target", "compare_mitsuba_gpu")
SCENES = ("ball", "bunny")
SPP = tuple(2**k for k in range(18))  # 1 … 131072 light paths per pixel
PASS_SPP, REFERENCE_SPP = 16384, 1 << 20
CORNER = 16  # pixels: the open floor in each corner of the 128² grid


def relative_l1(got, exact):
    return float(np.abs(got - exact).sum() / exact.sum())


def open_floor(img):
    c = CORNER
    return float(np.mean([img[:c, :c].mean(), img[:c, -c:].mean(), img[-c:, :c].mean(), img[-c:, -c:].mean()]))


def mitsuba(args):
    """On the GPU: each scene's converged floor (REFERENCE_SPP light paths per pixel, written
    as `<scene>_reference.exr`, the caustic as the references hold it), then Mitsuba's error
    against GPU time (`mitsuba.json`)."""
    os.environ.setdefault("REFRAKT_MITSUBA_VARIANT", "cuda_ad_rgb")
    if args.bunny:
        os.environ["REFRAKT_BUNNY"] = os.path.abspath(args.bunny)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import drjit as dr
    import mitsuba as mi
    import mitsuba_reference as ref

    lit = -float(ref.SUN[1])  # the open floor's irradiance, W/m²
    os.makedirs(args.out, exist_ok=True)
    out = {"mitsuba": mi.__version__, "variant": mi.variant(), "reference_spp": REFERENCE_SPP, "scenes": {}}
    for name in SCENES:
        scene_dict = {"ball": ref.ball_scene, "bunny": ref.bunny_scene}[name]()
        ptracer = mi.load_dict(dict(scene_dict, type="scene", integrator={"type": "ptracer", "max_depth": 64, "hide_emitters": True}))
        # The unrefracted light: a path tracer cannot reach the delta sun through glass.
        direct = ref.irradiance(scene_dict, {"type": "path", "max_depth": 64}, 16)

        def render(spp, seed):
            started = time.perf_counter()
            img = mi.render(ptracer, spp=spp, seed=seed)
            dr.eval(img)
            dr.sync_thread()
            elapsed = time.perf_counter() - started
            return ref.orient(np.array(img)[:, :, 1] * math.pi), elapsed

        passes = [render(PASS_SPP, 1000 + k)[0] for k in range(REFERENCE_SPP // PASS_SPP)]
        floor = np.mean(passes, axis=0)
        for what, img in (("particle tracer", floor), ("path tracer", direct)):
            if abs(open_floor(img) / lit - 1) > 0.02:
                sys.exit(f"{name}: Mitsuba {mi.__version__}'s {what} reads the open floor {open_floor(img):.3f} W/m², not {lit:.3f}")
        # The reference's own error: half the difference of its two halves.
        noise = float(np.abs(np.mean(passes[::2], axis=0) - np.mean(passes[1::2], axis=0)).sum() / 2 / floor.sum())
        caustic = floor - direct
        mi.Bitmap(np.repeat(caustic[:, :, None], 3, axis=2).astype(np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(
            os.path.join(args.out, f"{name}_reference.exr"))
        against_stored = relative_l1(caustic, read_reference(name))
        print(f"{name}: reference at {REFERENCE_SPP} paths/pixel, its own floor error {noise:.4f}; "
              f"its caustic against tests/data/mitsuba/{name}.exr: relative L1 {against_stored:.4f}", flush=True)
        rows = []
        for spp in SPP:
            render(spp, 0)  # warm-up: kernels compiled for this launch size
            times, errors = [], []
            for seed in (1, 2, 3):
                img, elapsed = render(spp, seed)
                times.append(elapsed)
                errors.append(relative_l1(img, floor))
            rows.append({"spp": spp, "ms": 1e3 * float(np.median(times)), "l1": float(np.median(errors))})
            print(f"{name}: {spp} spp, {rows[-1]['ms']:.2f} ms, floor relative L1 {rows[-1]['l1']:.4f}", flush=True)
        out["scenes"][name] = {"floor_sum": float(floor.sum()), "caustic_sum": float(caustic.sum()), "reference_noise": noise,
                               "caustic_against_stored_reference": against_stored, "points": rows}
        write_json(args.out, "mitsuba.json", out)


def read_reference(name):
    import mitsuba as mi

    img = np.array(mi.Bitmap(os.path.join(ROOT, "tests", "data", "mitsuba", name + ".exr")), dtype=np.float64)
    return img[:, :, 1]


def refrakt(args):
    """refrakt's GPU frame per scene and photon count (`refrakt_times.json`), benched on the
    scenes the error test wrote."""
    scenes = sorted(glob.glob(os.path.join(args.scenes, "*.lua")))
    if not scenes:
        sys.exit(f"no scenes in {args.scenes}: run the ignored test first (see --help)")
    work = tempfile.mkdtemp()
    if args.bunny:
        shutil.copy(args.bunny, os.path.join(work, "bunny.obj"))
    rows = []
    for path in scenes:
        name, photons = re.match(r"(\w+)_(\d+)\.lua$", os.path.basename(path)).groups()
        scene = os.path.join(work, os.path.basename(path))
        shutil.copy(path, scene)
        result = os.path.join(work, "bench.json")
        subprocess.run([args.binary, "bench", "-q", "--scenes", scene, "--frames", "30", "--out", result], check=True, stdout=subprocess.DEVNULL)
        with open(result) as f:
            bench = json.load(f)
        s = bench["scenes"][0]
        rows.append({"scene": name, "photons": int(photons), "gpu_ms": s["gpu_ms"]["median"],
                     "stages_ms": {k: v["median"] for k, v in s["stages_ms"].items()}, "adapter": bench["adapter"]})
        print(f"{name}: {photons} photons, GPU frame {rows[-1]['gpu_ms']:.3f} ms", flush=True)
    write_json(args.out, "refrakt_times.json", rows)


def write_json(folder, name, value):
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "w") as f:
        json.dump(value, f, indent=1)


def mitsuba_time_at(points, l1):
    """Mitsuba's time to reach error l1: its (time, error) curve interpolated in log–log; None
    beyond its ends (more error than at 1 spp, or less than at its most)."""
    t = np.log([p["ms"] for p in points])
    e = np.log([p["l1"] for p in points])
    if not e.min() <= math.log(l1) <= e.max():
        return None
    order = np.argsort(e)
    return float(math.exp(np.interp(math.log(l1), e[order], t[order])))


def report(args):
    with open(os.path.join(args.folder, "mitsuba.json")) as f:
        mits = json.load(f)
    with open(os.path.join(args.folder, "refrakt_times.json")) as f:
        times = {(r["scene"], r["photons"]): r for r in json.load(f)}
    with open(os.path.join(args.errors, "refrakt_errors.json")) as f:
        errors = json.load(f)
    print("| scene | refrakt photons | floor relative L1 | refrakt GPU ms | Mitsuba ms at that L1 | ratio |")
    print("| --- | --- | --- | --- | --- | --- |")
    curves = {}
    for e in errors:
        t = times[(e["scene"], e["photons"])]
        scene = mits["scenes"][e["scene"]]
        # refrakt's direct light is taken as exact: its floor's error is its caustic's.
        l1 = e["abs_error"] / scene["floor_sum"]
        m = mitsuba_time_at(scene["points"], l1)
        curves.setdefault(e["scene"], []).append((t["gpu_ms"], l1))
        at = f"{m:.1f}" if m is not None else "—"
        ratio = f"{m / t['gpu_ms']:.0f}×" if m is not None else "—"
        print(f"| {e['scene']} | {e['photons']:,} | {l1:.4f} | {t['gpu_ms']:.2f} | {at} | {ratio} |")
    print()
    print("| light paths / pixel | " + " | ".join(f"{n}: floor relative L1, GPU ms" for n in SCENES) + " |")
    print("| --- | " + " | ".join("---" for _ in SCENES) + " |")
    for k, spp in enumerate(SPP):
        cells = [mits["scenes"][n]["points"][k] for n in SCENES]
        print(f"| {spp} | " + " | ".join(f"{p['l1']:.4f}, {p['ms']:.2f}" for p in cells) + " |")
    print(f"\nMitsuba {mits['mitsuba']} {mits['variant']}; references at {mits['reference_spp']} paths/pixel, their own floor error "
          + ", ".join(f"{n} {mits['scenes'][n]['reference_noise']:.4f}" for n in SCENES)
          + f"; refrakt on {next(iter(times.values()))['adapter']}")
    if args.plot:
        plot(args.plot, mits, curves)


def plot(path, mits, curves):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2), dpi=110)
    for name, colour in zip(SCENES, ("tab:blue", "tab:orange")):
        p = mits["scenes"][name]["points"]
        ax.plot([q["ms"] for q in p], [q["l1"] for q in p], "o--", color=colour, label=f"Mitsuba 3, {name} (1–131072 paths/pixel)")
        r = sorted(curves[name])
        ax.plot([q[0] for q in r], [q[1] for q in r], "s-", color=colour, label=f"refrakt, {name} (25k–1.6M photons)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("GPU time per frame (ms)")
    ax.set_ylabel("relative L1 of the floor's irradiance")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    print(f"wrote {path}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    m = sub.add_parser("mitsuba", help="Mitsuba's error and GPU time (on the GPU machine)")
    m.add_argument("--bunny", help="bunny.obj (default ../shared/assets/bunny.obj)")
    m.add_argument("--out", required=True)
    r = sub.add_parser("refrakt", help="refrakt's GPU frame for the scenes the error test wrote (on the GPU machine)")
    r.add_argument("--binary", default="refrakt")
    r.add_argument("--scenes", default=ERRORS_DIR)
    r.add_argument("--bunny", help="bunny.obj, copied beside the scenes")
    r.add_argument("--out", required=True)
    p = sub.add_parser("report", help="the table (markdown) and the plot")
    p.add_argument("folder", help="where mitsuba.json and refrakt_times.json are")
    p.add_argument("--errors", default=ERRORS_DIR)
    p.add_argument("--plot")
    args = parser.parse_args()
    {"mitsuba": mitsuba, "refrakt": refrakt, "report": report}[args.command](args)


if __name__ == "__main__":
    main()
