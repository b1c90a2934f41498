#!/usr/bin/env python3
"""The glass bunny's caustic power on the whole 6 × 6 m floor from Mitsuba 3's particle tracer,
cut at a number of path vertices — how the light that reaches the floor splits by how many times
it met the glass (max_depth d keeps paths of up to d − 2 interface events). Compare with
refrakt's photon statistics (`Renderer::photon_stats().caustic`) with march.wgsl's MAX_EVENTS set
to the same count + 1. Uses scripts/mitsuba_reference.py's scenes.

    python3 scripts/mitsuba_paths.py [--spp 1024] [--flat]

The particle tracer's estimate of the direct light is noisy over the whole floor; the power at
max_depth 2 (direct light only, so a caustic of zero) is that noise, and is subtracted.
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mitsuba_reference as R  # noqa: E402

DEPTHS = [2, 3, 4, 5, 6, 64]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--spp", type=int, default=1024)
    parser.add_argument("--flat", action="store_true", help="face normals instead of refrakt's shading normals")
    args = parser.parse_args()
    R.HALF, R.PIXELS = 3.0, 256  # the whole floor
    scene = R.bunny_scene()
    if args.flat:
        scene["bunny"] = dict(scene["bunny"], filename=R.BUNNY, face_normals=True)
    direct = R.irradiance(scene, {"type": "path", "max_depth": 64}, 16)
    texel = (2 * R.HALF / R.PIXELS) ** 2
    power = {d: (R.irradiance(scene, {"type": "ptracer", "max_depth": d, "rr_depth": 100, "hide_emitters": True}, args.spp) - direct).sum() * texel for d in DEPTHS}
    for d in DEPTHS[1:]:
        print(f"max_depth {d:2d} (≤ {d - 2} interface events): {power[d] - power[2]:.5f} W")


if __name__ == "__main__":
    main()
