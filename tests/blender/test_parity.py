"""The Cycles parity suite's small scenes (scripts/cycles_parity.py): a glass ball on a floor
under a sun, a spot, an area light, a sky and an HDRI sky, tinted, frosted (roughness 0.15) and
fully rough (1) glass, the Stanford bunny and a glass of water under the sun — each built
by script, rendered by refrakt through its render engine at 64×36, and scored against the kept
Cycles references (tests/data/cycles/<scene>.exr: 128×72 at 4096 samples, 2×2 means), within
the bounds below. The full-size table is in docs/blender.md ("Parity with Cycles")."""

import pathlib

import bpy
import pytest

import cycles_parity as parity

DATA = pathlib.Path(__file__).resolve().parent.parent / "data" / "cycles"

# Per scene: the most relative L1 over the image and over the caustic region, and the range of
# the light's ratio (refrakt / Cycles). Measured on lavapipe (l1, caustic region, light):
# sun 0.017, 0.046, 0.993; spot 0.026, 0.026, 0.995; area 0.028, 0.037, 0.984; sky 0.011, 0.019,
# 0.998; tinted 0.016, 0.034, 0.993 (0.036, 0.045, 0.971 before the add-on took Cycles'
# √(Base Color) per surface for Principled glass); frosted 0.017, 0.039, 0.994 (0.019, 0.045, 0.990
# before the suns were sampled through rough glass). refrakt is deterministic: the margins are for
# other adapters' rounding. hdri 0.029, 0.055, 0.998; bunny 0.031, 0.115, 0.977 (the bunny's caustic
# region holds Cycles' speckle); rough (roughness 1) 0.057, 0.175, 0.968 (0.85 of Cycles' light
# before rough crossings kept the energy masking takes: pipeline::rough_albedo); water 0.017,
# 0.055, 0.997 (two seeds of Cycles' reference differ by 0.0075).
BOUNDS = {
    "sun": (0.025, 0.065, (0.975, 1.01)),
    "spot": (0.035, 0.04, (0.98, 1.01)),
    "area": (0.038, 0.05, (0.97, 1.0)),
    "sky": (0.016, 0.03, (0.985, 1.01)),
    "tinted": (0.022, 0.048, (0.975, 1.01)),
    "frosted": (0.027, 0.065, (0.975, 1.005)),
    "hdri": (0.041, 0.078, (0.98, 1.01)),
    "bunny": (0.044, 0.16, (0.96, 1.0)),
    "rough": (0.07, 0.21, (0.95, 1.0)),
    "water": (0.03, 0.08, (0.975, 1.01)),
}


@pytest.mark.parametrize("name", list(parity.SCENES))
def test_refrakt_renders_the_parity_scene_as_cycles_does(name, addon, real_refrakt, tmp_path):
    got, caustic = parity.refrakt_render(bpy, name, parity.SMALL_SIZE, parity.REFRAKT_SMALL, tmp_path, real_refrakt)
    reference = parity.read_rgb(DATA / f"{name}.exr")
    s = parity.score(got, reference, parity.caustic_region(caustic))
    print(f"{name}: {s}")
    l1, caustic_l1, (low, high) = BOUNDS[name]
    assert s["l1"] <= l1 and s["caustic_l1"] <= caustic_l1 and low <= s["light"] <= high, (name, s)


def test_frosted_glass_at_16_samples_is_no_noisier_than_cycles_at_64(addon, real_refrakt, tmp_path):
    """The frosted ball (roughness 0.15) at the small size: refrakt's noise over the ball at 16
    samples per pixel (its deviation from 256 samples of the same photons) no more than half
    Cycles' at 64 (two seeds). Measured on lavapipe: 0.059 against 0.324 (0.47 against 0.37 at
    full size before the sun's glints were sampled through rough glass); full size in
    docs/blender.md."""
    n = parity.noise(bpy, parity.SMALL_SIZE, parity.REFRAKT_SMALL, tmp_path, real_refrakt)
    print(f"frosted noise: {n}")
    assert n["pixels"] > 100, n
    assert 0.0 < n["refrakt"] <= 0.5 * n["cycles"], n
