#!/usr/bin/env python3
"""Converged caustic references from Mitsuba 3 (a renderer we did not write) for
tests/mitsuba_caustics.rs: a glass ball, the same ball as a mesh of 5120 flat facets, and the
glass Stanford bunny over a floor under the sun.

Each scene is rendered twice by Mitsuba: its particle tracer (`ptracer`: light paths from the sun
through the `dielectric` glass — Fresnel reflection and refraction — to the floor) gives all the
light the floor receives, and its `direct` integrator gives the light that arrives unrefracted
(shadow rays stop at glass). Their difference is the caustic: what refrakt's caustic maps hold.

How the floor is measured: it is a diffuse transmitter (transmittance 1) seen from below by an
camera looking up, so a pixel's radiance is E/π with E the irradiance on the floor's
top — and the floor reflects nothing back up into the glass. Pixel (i, j) of the written EXR is the
floor point x = −H + (i + ½)·2H/N, z = −H + (j + ½)·2H/N (checked below against the ball's shadow).
Values are irradiance in W/m² for a sun of 1 W/m² across its beam (refrakt: 683 lux).

    pip install mitsuba==3.5.2        (3.5.x runs on LLVM: the llvm_ad_rgb variant)
    python3 scripts/mitsuba_reference.py [--spp N]   # writes tests/data/mitsuba/{ball,facets,bunny}.exr

The bunny is read from ../shared/assets/bunny.obj (not part of this repository).
"""

import argparse
import math
import os
import tempfile
import time

import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_rgb")
import drjit as dr  # noqa: E402  (after the variant is set)


class DiffuseTransmitter(mi.BSDF):
    """A sheet that passes all the light it receives to its other side, diffusely (Lambert):
    f = 1/π between opposite sides, 0 on the same side. (Mitsuba 3.5 has no `difftrans`.)"""

    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.m_flags = mi.BSDFFlags.DiffuseTransmission | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
        self.m_components = [self.m_flags]

    def sample(self, ctx, si, sample1, sample2, active=True):
        wo = mi.warp.square_to_cosine_hemisphere(sample2)
        wo.z = dr.select(mi.Frame3f.cos_theta(si.wi) > 0, -wo.z, wo.z)  # to the other side
        bs = mi.BSDFSample3f()
        bs.wo = wo
        bs.pdf = mi.warp.square_to_cosine_hemisphere_pdf(mi.Vector3f(wo.x, wo.y, dr.abs(wo.z)))
        bs.eta = 1.0
        bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseTransmission)
        bs.sampled_component = 0
        return bs, mi.Color3f(1.0)  # f · |cos| / pdf = 1

    def _opposite(self, si, wo):
        return mi.Frame3f.cos_theta(si.wi) * mi.Frame3f.cos_theta(wo) < 0

    def eval(self, ctx, si, wo, active=True):
        value = dr.abs(mi.Frame3f.cos_theta(wo)) / dr.pi
        return dr.select(self._opposite(si, wo), mi.Color3f(value), mi.Color3f(0.0))

    def pdf(self, ctx, si, wo, active=True):
        return dr.select(self._opposite(si, wo), dr.abs(mi.Frame3f.cos_theta(wo)) / dr.pi, 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

    def to_string(self):
        return "DiffuseTransmitter[]"


mi.register_bsdf("difftrans_py", lambda props: DiffuseTransmitter(props))

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "tests", "data", "mitsuba")
BUNNY = os.path.join(ROOT, "..", "shared", "assets", "bunny.obj")

# Shared with tests/mitsuba_caustics.rs.
HALF = 1.0  # the image covers x, z in [−HALF, HALF]
PIXELS = 128
CAMERA_DISTANCE = 10.0
SUN = np.array([0.25, -1.0, 0.1]) / np.linalg.norm([0.25, -1.0, 0.1])  # direction of travel
IOR = 1.5
BALL = dict(centre=[0.0, 0.8, 0.0], radius=0.5)
BUNNY_SCALE, BUNNY_AT = 4.0, [0.07, 0.17, 0.01]


def floor_and_camera():
    return {
        "floor": {
            "type": "rectangle",
            # A 6 × 6 m sheet in the xz plane, facing +y.
            "to_world": mi.ScalarTransform4f.rotate([1, 0, 0], -90).scale(3.0),
            "bsdf": {"type": "difftrans_py"},
        },
        # A pinhole far below, looking straight up: the floor is a plane square to its axis, so
        # pixels map linearly onto it (ptracer cannot connect paths to an orthographic camera).
        "sensor": {
            "type": "perspective",
            "fov": 2 * math.degrees(math.atan(HALF / CAMERA_DISTANCE)),
            "to_world": mi.ScalarTransform4f.look_at(origin=[0, -CAMERA_DISTANCE, 0], target=[0, 0, 0], up=[0, 0, 1]),
            "film": {"type": "hdrfilm", "width": PIXELS, "height": PIXELS, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent"},
        },
        "sun": {"type": "directional", "direction": SUN.tolist(), "irradiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}},
    }


def glass():
    return {"type": "dielectric", "int_ior": IOR, "ext_ior": 1.0}


def ball_scene():
    s = floor_and_camera()
    s["ball"] = {"type": "sphere", "center": BALL["centre"], "radius": BALL["radius"], "bsdf": glass()}
    return s


def geodesic_sphere(radius, frequency):
    """refrakt's `mesh::geodesic_sphere` (src/scene/mesh.rs), vertex for vertex and triangle for
    triangle: each face of an icosahedron cut into frequency² triangles, projected onto the sphere."""
    t = (1.0 + math.sqrt(5.0)) / 2.0
    corners = np.array([(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
                        (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)], dtype=np.float64)
    faces = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
             [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    index, positions, triangles, f = {}, [], [], frequency

    def vertex(weights):
        key = tuple(sorted(w for w in weights if w[1] > 0))
        if key not in index:
            p = sum(corners[c] * w for c, w in key)
            positions.append(radius * (p / np.linalg.norm(p)))
            index[key] = len(positions) - 1
        return index[key]

    for a, b, c in faces:
        def at(i, j):
            return vertex([(a, f - i - j), (b, i), (c, j)])
        for i in range(f):
            for j in range(f - i):
                p, q, r = at(i, j), at(i + 1, j), at(i, j + 1)
                triangles.append((p, q, r))
                if i + j + 1 < f:
                    triangles.append((q, at(i + 1, j + 1), r))
    return np.array(positions), triangles


def facets_scene():
    """The ball as refrakt's `icosphere{ radius = 0.5, subdivisions = 4 }` (5120 triangles),
    shaded flat: each facet refracts about its own normal (Mitsuba's `face_normals`), as refrakt
    shades a mesh whose file has no normals."""
    positions, triangles = geodesic_sphere(BALL["radius"], 16)
    path = os.path.join(tempfile.gettempdir(), "refrakt_facets.obj")
    with open(path, "w") as out:
        out.writelines(f"v {x} {y} {z}\n" for x, y, z in positions)
        out.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in triangles)
    s = floor_and_camera()
    s["facets"] = {"type": "obj", "filename": path, "face_normals": True,
                   "to_world": mi.ScalarTransform4f.translate(BALL["centre"]), "bsdf": glass()}
    return s


CREASE_DEGREES = 30.0  # src/scene/mesh.rs: SMOOTH_CREASE_DEGREES (refrakt.mesh's smooth = 30)


def with_refrakt_normals(obj_path, out_path):
    """The OBJ again, with the shading normals refrakt gives a mesh that has none (MeshData::
    corner_normals): per corner, the area-weighted sum of the normals of the faces around its
    vertex that lie within the crease angle of the corner's own face. Both renderers then shade
    the same surface, and the comparison is of light transport alone."""
    positions, faces = [], []
    for line in open(obj_path):
        parts = line.split()
        if parts[:1] == ["v"]:
            positions.append([float(x) for x in parts[1:4]])
        elif parts[:1] == ["f"]:
            corners = [int(p.split("/")[0]) - 1 for p in parts[1:]]
            faces += [[corners[0], corners[k], corners[k + 1]] for k in range(1, len(corners) - 1)]
    v, f = np.array(positions, dtype=np.float32), np.array(faces)
    face = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    unit = face / np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-30)
    around = {}
    for k, tri in enumerate(f):
        for i in tri:
            around.setdefault(tuple(v[i]), []).append(k)
    cos_crease = math.cos(math.radians(CREASE_DEGREES))
    with open(out_path, "w") as out:
        out.writelines(f"v {x} {y} {z}\n" for x, y, z in v)
        for k, tri in enumerate(f):
            for i in tri:
                ring = [j for j in around[tuple(v[i])] if unit[j] @ unit[k] >= cos_crease]
                n = face[ring].sum(axis=0)
                n = n / np.linalg.norm(n) if np.linalg.norm(n) > 0 else unit[k]
                out.write(f"vn {n[0]} {n[1]} {n[2]}\n")
        out.writelines(f"f {a + 1}//{3 * k + 1} {b + 1}//{3 * k + 2} {c + 1}//{3 * k + 3}\n" for k, (a, b, c) in enumerate(f))
    return out_path


def bunny_scene():
    s = floor_and_camera()
    s["bunny"] = {
        "type": "obj",
        "filename": with_refrakt_normals(BUNNY, os.path.join(tempfile.gettempdir(), "refrakt_bunny_normals.obj")),
        "to_world": mi.ScalarTransform4f.translate(BUNNY_AT).scale(BUNNY_SCALE),
        "bsdf": glass(),
    }
    return s


def irradiance(scene, integrator, spp):
    """The floor's irradiance image (W/m²), rows along z and columns along x as documented."""
    s = dict(scene, type="scene", integrator=integrator)
    img = np.array(mi.render(mi.load_dict(s), spp=spp))[:, :, 1] * math.pi
    return orient(img)


def orient(img):
    # Mitsuba's film: row 0 at the top of the view. Looking up along +y with up = +z, the top is
    # +z and columns already run along +x (seen from below); flip the rows to z ascending.
    return img[::-1, :]


def check_orientation(direct):
    """The ball's shadow centre must sit where the sun projects the ball's centre."""
    t = BALL["centre"][1] / -SUN[1]
    expected = np.array(BALL["centre"]) + t * SUN
    axis = -HALF + (np.arange(PIXELS) + 0.5) * 2 * HALF / PIXELS
    shadow = direct < 0.5 * direct.max()
    z, x = np.meshgrid(axis, axis, indexing="ij")
    got = np.array([x[shadow].mean(), z[shadow].mean()])
    assert np.allclose(got, expected[[0, 2]], atol=0.02), f"shadow centre {got}, expected {expected[[0, 2]]}"


def write(name, caustic):
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, name + ".exr")
    rgb = np.repeat(caustic[:, :, None], 3, axis=2).astype(np.float32)
    mi.Bitmap(rgb, pixel_format=mi.Bitmap.PixelFormat.RGB).write(path)
    print(f"wrote {path}: caustic power {caustic.sum() * (2 * HALF / PIXELS) ** 2:.5f} W, peak {caustic.max():.3f} W/m²")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--spp", type=int, default=16384, help="particle tracer samples per pixel (light paths / pixel)")
    parser.add_argument("--only", choices=["ball", "facets", "bunny"], help="render one reference")
    args = parser.parse_args()
    scenes = {"ball": ball_scene, "facets": facets_scene, "bunny": bunny_scene}
    for name in [args.only] if args.only else scenes:
        scene = scenes[name]()
        started = time.time()
        total = irradiance(scene, {"type": "ptracer", "max_depth": 64, "hide_emitters": True}, args.spp)
        # A path tracer cannot reach the sun (a delta light) through glass: it sees exactly the
        # unrefracted light and the glass's shadow.
        direct = irradiance(scene, {"type": "path", "max_depth": 64}, 16)
        if name == "ball":
            check_orientation(direct)
        write(name, total - direct)
        print(f"  {name}: {time.time() - started:.0f} s")


if __name__ == "__main__":
    main()
