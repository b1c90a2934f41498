#!/usr/bin/env python3
"""Writes examples/textures/ripples.png, the tangent-space normal map of examples/pool.lua's
water: a tileable height field of a few dozen sine waves (integer wave vectors, so the tile
repeats seamlessly), its normal n = normalize(−∂h/∂x, −∂h/∂y, 1) in glTF's convention (x along
+u, the image's columns; y toward −v, up the image), stored as (n + 1)/2 in 8-bit RGB.

    python3 scripts/make_ripples.py            # deterministic: the same file every run
"""
import os

import numpy as np
from PIL import Image

SIZE = 256
WAVES = 40
SLOPE = 0.22  # the steepest the surface leans, roughly (rad): a breeze on a pool


def ripples(size=SIZE, waves=WAVES, seed=7):
    rng = np.random.default_rng(seed)
    u = (np.arange(size) + 0.5) / size
    uu, vv = np.meshgrid(u, u)  # columns: u, rows: v (down the image)
    dh_du = np.zeros((size, size))
    dh_dv = np.zeros((size, size))
    for _ in range(waves):
        # Integer wave vectors (k cycles per tile) keep the tile seamless; longer waves higher.
        k = rng.integers(-6, 7, size=2)
        if not k.any():
            continue
        amplitude = 1.0 / np.linalg.norm(k) ** 1.5
        phase = rng.uniform(0, 2 * np.pi)
        arg = 2 * np.pi * (k[0] * uu + k[1] * vv) + phase
        dh_du += amplitude * 2 * np.pi * k[0] * np.cos(arg)
        dh_dv += amplitude * 2 * np.pi * k[1] * np.cos(arg)
    scale = SLOPE / np.percentile(np.hypot(dh_du, dh_dv), 99)
    # Tangent space: x = +u, y = −v, so ∂h/∂y = −∂h/∂v.
    n = np.stack([-dh_du * scale, dh_dv * scale, np.ones_like(dh_du)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.round((n + 1) * 0.5 * 255).astype(np.uint8)


if __name__ == "__main__":
    out = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples", "textures", "ripples.png")
    Image.fromarray(ripples()).save(out, optimize=True)
    print(out, os.path.getsize(out), "bytes")
