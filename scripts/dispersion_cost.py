#!/usr/bin/env python3
"""The cost of dispersion at equal caustic noise, from `refrakt bench --quality` JSON.

    refrakt bench --scenes seed,seed-dispersion --quality --mesh ../shared/assets/bunny.obj > q.json
    python3 scripts/dispersion_cost.py q.json

For each scene, `quality.points` holds the caustic RMSE (against the scene's own render with 64×
the photons) and the photon stages' time at 1/8 … 8× seed's 70k photons. This finds, by
log-log interpolation, how many photons `seed-dispersion` needs to reach `seed`'s RMSE at its
own 70k, and compares frame costs: the scene's median GPU ms with the photon stages' time
replaced by the time at that photon count.
"""
import json
import math
import sys


def interpolate(points, x_key, y_key, x):
    pts = sorted((p[x_key], p[y_key]) for p in points)
    for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
        if min(x0, x1) <= x <= max(x0, x1) and x0 != x1:
            t = (math.log(x) - math.log(x0)) / (math.log(x1) - math.log(x0))
            return math.exp(math.log(y0) + t * (math.log(y1) - math.log(y0)))
    raise SystemExit(f"{x_key} = {x} is outside the measured range {pts[0][0]}…{pts[-1][0]}")


def main(path):
    scenes = {s["name"]: s for s in json.load(open(path))["scenes"]}
    seed, disp = scenes["seed"], scenes["seed-dispersion"]
    base = seed["quality"]["points"]
    photons = next(p["photons"] for p in base if math.isclose(p["photons"], seed["quality"]["reference_photons"] / 64, rel_tol=1e-6))
    target = next(p["caustic_rmse"] for p in base if p["photons"] == photons)
    # RMSE falls with photons: interpolate photons as a function of RMSE.
    needed = interpolate(disp["quality"]["points"], "caustic_rmse", "photons", target)
    def frame_ms(scene, n):
        at = next(p for p in scene["quality"]["points"] if p["photons"] == photons)["photon_stages_ms"]
        return scene["gpu_ms"]["median"] - at + interpolate(scene["quality"]["points"], "photons", "photon_stages_ms", n)
    a, b = frame_ms(seed, photons), frame_ms(disp, needed)
    print(f"seed: {photons} photons, caustic RMSE {target:.4g}, {a:.2f} ms a frame")
    print(f"seed-dispersion: {needed:.0f} photons for the same RMSE, {b:.2f} ms a frame")
    print(f"cost of dispersion at equal caustic noise: {b / a:.2f}x (target: at most 1.5x)")


if __name__ == "__main__":
    main(sys.argv[1])
