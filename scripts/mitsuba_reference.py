#!/usr/bin/env python3
"""Converged caustic references from Mitsuba 3 (a renderer we did not write) for
tests/mitsuba_caustics.rs: a glass ball, the same ball as a mesh of 5120 flat facets, and the
glass Stanford bunny over a floor under the sun; and the glass ball under an environment image.

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
    python3 scripts/mitsuba_reference.py [--spp N]   # writes tests/data/mitsuba/{ball,facets,bunny,hdri}.exr
    python3 scripts/mitsuba_reference.py --only hdri # just one of them

The stored `ball` and `bunny` are finer than this script's default: 2²⁰ light paths per pixel from
Mitsuba 3.9.1's `cuda_ad_rgb` on the GPU machine (`scripts/compare_mitsuba_gpu.py mitsuba`, which
imports these scenes and writes `<scene>_reference.exr`; copied here as `<scene>.exr`). Mitsuba
3.5.x's CUDA particle tracer is wrong (an open floor twice as bright); 3.9.1's is right.

The bunny is read from ../shared/assets/bunny.obj (not part of this repository), or from
$REFRAKT_BUNNY; $REFRAKT_MITSUBA_VARIANT picks another variant (scripts/compare_mitsuba_gpu.py
imports this file for its scenes with `cuda_ad_rgb`).

`hdri` (`hdri_reference`): the ball lit only by an environment image that this script makes and
writes as tests/data/mitsuba/hdri_sky.exr (256×128 half floats in refrakt's equirectangular
convention: a sky gradient of 0.1–0.36 W/m²/sr, black below the horizon, and a sun 3° across,
60° up, of 6 W/m²), given to Mitsuba's `envmap` resampled to its own convention (see
MITSUBA_SKY_SIZE). Its values are the caustic irradiance in W/m² for the image's radiance as it is
(envmap scale 1; refrakt also reads the image as W/m²/sr, so no 683 enters). Before rendering it
checks that the envmap holds the same radiance field as refrakt's texels (pointwise, and ∫ L dω and
the open floor's irradiance within 0.1 %), that Mitsuba's direct integrator and particle tracer
give the open floor that irradiance (within 1 %), and after, that the ball's shadow and caustic lie
where the image's sun puts them. 65536 light paths per pixel (with control variates, see
`hdri_reference`); 632 s on a 2-core machine shared with a build (565 s of it the
particle tracer, twice; 54 s the direct light, 8192 spp, twice).

`resting` (`resting_scene`): the ball (r = 0.5 m) resting on the floor, touching it at the
origin, under a vertical sun: its caustic converges under it, inside its shadow, and the floor
between the caustic and the shadow's edge is dark (tests/contact.rs).

`seen_through` (`seen_through_reference`): that resting ball on a grey floor (albedo 0.5) under a
small spherical light (r = 5 cm, 2000 cd), seen from 45° by a pinhole camera: Mitsuba's path
tracer's radiance, 64², with alpha marking the pixels that see the floor through the ball.

`rim_view` (`rim_view_reference`): the same ball, floor and camera under a vertical sun of 1 W/m²,
by the particle tracer: the floor under and around the ball's rim seen directly (alpha marks
those pixels), 64², 262144 light paths per pixel (about 2 min here).

`white_room` (`white_room_reference`): a closed white room (4 × 3 × 4 m, albedo 0.75) with a glass
ball (r = 0.4 m, 0.2 m above the floor) under a spot of 300 cd pointing down past it, seen by a
pinhole camera from a corner: the radiance of every pixel that sees a receiver directly (Mitsuba's
particle tracer, 64 bounces: direct, caustic and bounced light), in W/m²/sr, 64² pixels; alpha
marks the pixels to compare (0 where the camera's ray meets the ball or its edge, which a
particle tracer cannot see through).
"""

import argparse
import math
import os
import tempfile
import time

import mitsuba as mi
import numpy as np

# (scripts/compare_mitsuba_gpu.py sets REFRAKT_MITSUBA_VARIANT=cuda_ad_rgb on a GPU machine.)
mi.set_variant(os.environ.get("REFRAKT_MITSUBA_VARIANT", "llvm_ad_rgb"))
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
BUNNY = os.environ.get("REFRAKT_BUNNY", os.path.join(ROOT, "..", "shared", "assets", "bunny.obj"))

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
    }


def under_the_sun(scene):
    scene["sun"] = {"type": "directional", "direction": SUN.tolist(), "irradiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}
    return scene


def glass():
    return {"type": "dielectric", "int_ior": IOR, "ext_ior": 1.0}


def the_ball():
    return {"type": "sphere", "center": BALL["centre"], "radius": BALL["radius"], "bsdf": glass()}


def ball_scene():
    s = under_the_sun(floor_and_camera())
    s["ball"] = the_ball()
    return s


# Shared with tests/contact.rs: the ball resting on the floor under a vertical sun.
RESTING = dict(centre=[0.0, 0.5, 0.0], radius=0.5)


def resting_scene():
    s = floor_and_camera()
    s["sun"] = {"type": "directional", "direction": [0.0, -1.0, 0.0], "irradiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}
    s["ball"] = {"type": "sphere", "center": RESTING["centre"], "radius": RESTING["radius"], "bsdf": glass()}
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
    s = under_the_sun(floor_and_camera())
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
    s = under_the_sun(floor_and_camera())
    s["bunny"] = {
        "type": "obj",
        "filename": with_refrakt_normals(BUNNY, os.path.join(tempfile.gettempdir(), "refrakt_bunny_normals.obj")),
        "to_world": mi.ScalarTransform4f.translate(BUNNY_AT).scale(BUNNY_SCALE),
        "bsdf": glass(),
    }
    return s


# The `hdri` reference: the ball under an environment image instead of the sun. The image is made
# here (`sky_image`) and written in refrakt's equirectangular convention (Blender's, Y up: texel
# column x spans u ∈ [x/W, (x+1)/W] with φ = 2π(u − ½) = atan2(d.z, d.x), row y — row 0 at the
# top — spans elevations β ∈ [(½ − (y+1)/H)π, (½ − y/H)π]; d = (cos β cos φ, sin β, cos β sin φ)).
# refrakt lights with it as pbrt's image infinite light does: radiance constant over each texel.
SKY_FILE = os.path.join(OUT, "hdri_sky.exr")
SKY_SIZE = (256, 128)  # width, height
SUN_ELEVATION, SUN_AZIMUTH = math.radians(60.0), 2.2  # refrakt's φ of the sun: atan2(d.z, d.x)
SUN_HALF_ANGLE = math.radians(1.5)  # a disc 3° across
SUN_IRRADIANCE = 6.0  # W/m² (channel mean) on a plane facing it: ~6× the sky's on the floor
SUN_COLOUR = np.array([1.08, 1.0, 0.92])
TOWARD_SKY_SUN = np.array([math.cos(SUN_ELEVATION) * math.cos(SUN_AZIMUTH), math.sin(SUN_ELEVATION),
                           math.cos(SUN_ELEVATION) * math.sin(SUN_AZIMUTH)])
# Mitsuba's envmap (src/emitters/envmap.cpp) reads its image differently: bilinearly between
# texel values held at u = (x + ½)/W (φ_m = 2πu) and at θ = y·π/(H − 1) from +Y — rows 0 and
# H − 1 on the poles — with d = (sin φ_m sin θ, cos θ, −cos φ_m sin θ). The same direction has
# θ = π/2 − β and φ_m = φ + π/2, i.e. u_mitsuba = u_refrakt − ¼. It is given refrakt's piecewise
# constant field sampled 8× finer (texel values at its grid points; the mean of the two sides on
# a row edge), so its bilinear ramps are 1/8 texel wide and keep the energy (`check_sky`).
MITSUBA_SKY_SIZE = (2048, 1025)


def sky_radiance(d):
    """The continuous sky (before it is averaged over texels): a gradient from a blue zenith to a
    paler horizon, brighter toward the sun's azimuth, the sun's disc, and black below the horizon
    (so that nothing lights the floor from below, which Mitsuba's transmitting floor would pass up)."""
    h = 1.0 - np.clip(d[..., 1], 0.0, 1.0)
    toward = 0.5 * (1.0 + (d[..., 0] * TOWARD_SKY_SUN[0] + d[..., 2] * TOWARD_SKY_SUN[2]) / math.cos(SUN_ELEVATION)
                    / np.maximum(np.hypot(d[..., 0], d[..., 2]), 1e-9))
    sky = np.stack([0.10 + 0.12 * h + 0.08 * toward * h, 0.16 + 0.10 * h + 0.05 * toward * h, 0.34 - 0.04 * h + 0.02 * toward], axis=-1)
    sun_radiance = SUN_IRRADIANCE / (2.0 * math.pi * (1.0 - math.cos(SUN_HALF_ANGLE)))
    in_sun = (d @ TOWARD_SKY_SUN) >= math.cos(SUN_HALF_ANGLE)
    sky = sky + in_sun[..., None] * sun_radiance * SUN_COLOUR
    return np.where(d[..., 1:2] >= 0.0, sky, 0.0)


def refrakt_texel_edges(width, height):
    """sin β at the rows' edges (top to bottom) and φ at the columns' edges."""
    sin_edges = np.sin((0.5 - np.arange(height + 1) / height) * math.pi)
    phi_edges = (np.arange(width + 1) / width - 0.5) * 2.0 * math.pi
    return sin_edges, phi_edges


def sky_image(k=8):
    """The refrakt-convention image: each texel the mean of `sky_radiance` over its solid angle
    (k × k samples, equal-area: uniform in φ and sin β)."""
    w, h = SKY_SIZE
    sin_edges, _ = refrakt_texel_edges(w, h)
    t = (np.arange(k) + 0.5) / k
    s = sin_edges[:-1, None] + (sin_edges[1:] - sin_edges[:-1])[:, None] * t[None, :]  # (h, k)
    phi = ((np.arange(w)[:, None] + t[None, :]) / w - 0.5) * 2.0 * math.pi  # (w, k)
    s, phi = s[:, :, None, None], phi[None, None, :, :]
    c = np.sqrt(np.maximum(1.0 - s * s, 0.0))
    d = np.stack(np.broadcast_arrays(c * np.cos(phi), s, c * np.sin(phi)), axis=-1)  # (h, k, w, k, 3)
    return sky_radiance(d).mean(axis=(1, 3))


def refrakt_lookup(sky, d):
    """refrakt's radiance along world directions d (…, 3): the texel it falls in (`dir_to_uv`)."""
    h, w = sky.shape[:2]
    u = 0.5 + np.arctan2(d[..., 2], d[..., 0]) / (2.0 * math.pi)
    v = 1.0 - (0.5 + np.arcsin(np.clip(d[..., 1], -1.0, 1.0)) / math.pi)
    x = np.floor(u * w).astype(int) % w
    y = np.clip(np.floor(v * h).astype(int), 0, h - 1)
    return sky[y, x]


def mitsuba_sky(sky):
    """The image to give Mitsuba's envmap for the same radiance field (see MITSUBA_SKY_SIZE)."""
    h, w = sky.shape[:2]
    wm, hm = MITSUBA_SKY_SIZE
    rows = np.arange(hm) / (hm - 1) * h  # θ/π in refrakt rows (β = π/2 − θ)
    cols = ((np.arange(wm) + 0.5) / wm + 0.25) * w  # u_refrakt = u_mitsuba + ¼, in columns
    out = 0.0
    for dy in (-1e-4, 1e-4):  # on an edge between two rows: their mean
        for dx in (-1e-4, 1e-4):
            y = np.clip(np.floor(rows + dy).astype(int), 0, h - 1)
            x = np.floor(cols + dx).astype(int) % w
            out = out + sky[y][:, x]
    return (out / 4.0).astype(np.float32)


def sky_integrals(sky):
    """∫ L dω (rgb) and the irradiance of an open floor, E = ∫ L max(ω_y, 0) dω, of refrakt's
    piecewise constant field, in closed form: a texel spans Δφ (sin β_top − sin β_bottom) sr and
    gives the floor Δφ (sin² β_top − sin² β_bottom)/2 (rows above the horizon)."""
    h, w = sky.shape[:2]
    s, _ = refrakt_texel_edges(w, h)
    dphi = 2.0 * math.pi / w
    omega = dphi * (s[:-1] - s[1:])
    floor = dphi * (np.maximum(s[:-1], 0) ** 2 - np.maximum(s[1:], 0) ** 2) / 2.0
    return (sky * omega[:, None, None]).sum(axis=(0, 1)), (sky * floor[:, None, None]).sum(axis=(0, 1))


def write_sky():
    """Writes the refrakt-convention image (half floats) and returns it as written."""
    os.makedirs(OUT, exist_ok=True)
    mi.Bitmap(sky_image().astype(np.float16), pixel_format=mi.Bitmap.PixelFormat.RGB).write(SKY_FILE)
    sky = np.array(mi.Bitmap(SKY_FILE), dtype=np.float64)[:, :, :3]
    print(f"wrote {SKY_FILE}: {sky.shape[1]}×{sky.shape[0]}, {os.path.getsize(SKY_FILE)} bytes")
    return sky


def envmap(sky):
    return {"type": "envmap", "bitmap": mi.Bitmap(mitsuba_sky(sky), pixel_format=mi.Bitmap.PixelFormat.RGB), "scale": 1.0}


def hdri_scene(sky, ball=True):
    s = floor_and_camera()
    # The floor cut to 2.2 × 2.2 m (the view is 2 × 2): it sends no light back up and nothing
    # lights it from below, so this changes nothing in view — but the envmap's light paths start
    # on a disc across the scene's bounding sphere, and this one is 2.5× narrower: 6× more of them
    # meet the ball.
    s["floor"] = dict(s["floor"], to_world=mi.ScalarTransform4f.rotate([1, 0, 0], -90).scale(1.1))
    s["sky"] = envmap(sky)
    if ball:
        s["ball"] = the_ball()
    return s


def sphere_directions(n):
    """n directions spread evenly in solid angle (a Fibonacci lattice), each worth 4π/n sr."""
    i = np.arange(n) + 0.5
    y = 1.0 - 2.0 * i / n
    phi = math.pi * (1.0 + 5.0 ** 0.5) * i
    r = np.sqrt(1.0 - y * y)
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=-1)


def check_sky(sky):
    """Mitsuba's envmap, evaluated along many directions, against refrakt's lookup of the image:
    equal (to float rounding) wherever Mitsuba does not interpolate — all but the strips within
    1/16 texel of a column's edge and 1/8 of a row's — and the same ∫ L dω and open-floor
    irradiance (within 0.1 %) over the whole sphere, ramps included."""
    emitter = mi.load_dict(envmap(sky))
    d = sphere_directions(4_000_000)
    si = dr.zeros(mi.SurfaceInteraction3f, len(d))
    si.wi = mi.Vector3f(*(-d.T.astype(np.float32)))
    got = np.array(emitter.eval(si), dtype=np.float64)  # (n, 3)
    want = refrakt_lookup(sky, d)
    h, w = sky.shape[:2]
    col = (0.5 + np.arctan2(d[:, 2], d[:, 0]) / (2.0 * math.pi)) * w
    row = (0.5 - np.arcsin(d[:, 1]) / math.pi) * h
    inside = (np.abs(col - np.round(col)) > 1 / 16 + 1e-3) & (np.abs(row - np.round(row)) > 1 / 8 + 1e-3)
    worst = (np.abs(got - want) / np.maximum(want, 1e-3))[inside].max()
    l1 = np.abs(got - want).sum() / want.sum()
    turned = refrakt_lookup(sky, d[:, [2, 1, 0]] * [-1, 1, 1])  # a quarter turn off: what u ± ¼ would give
    l1_turned = np.abs(got - turned).sum() / want.sum()
    omega = 4.0 * math.pi / len(d)
    integral, floor = sky_integrals(sky)
    got_integral = got.sum(axis=0) * omega
    got_floor = (got * np.maximum(d[:, 1:2], 0)).sum(axis=0) * omega
    print(f"  Mitsuba's envmap vs refrakt's texels along {len(d)} directions: off texel edges ({100 * inside.mean():.0f} % of them) "
          f"within {worst:.1e}; over all, relative L1 {l1:.3f} (the ramps at the sun's edges; a quarter turn off: {l1_turned:.2f})")
    print(f"  ∫ L dω: Mitsuba {got_integral} vs refrakt {integral}; open floor E: Mitsuba {got_floor} vs refrakt {floor} W/m²")
    assert worst < 1e-5 and l1 < 0.2 < l1_turned, (worst, l1, l1_turned)
    assert np.all(np.abs(got_integral / integral - 1) < 1e-3) and np.all(np.abs(got_floor / floor - 1) < 1e-3)
    return floor


def rgb_irradiance(scene, integrator, spp, seed=0):
    """As `irradiance`, all three channels."""
    s = dict(scene, type="scene", integrator=integrator)
    return orient(np.array(mi.render(mi.load_dict(s), spp=spp, seed=seed)) * math.pi)


def check_hdri_floor(sky, floor):
    """The open floor, rendered by Mitsuba's direct light integrator and by its particle tracer,
    gets the irradiance integrated from refrakt's texels (within 1 %)."""
    for name, integrator, spp in [("direct", {"type": "direct"}, 64), ("ptracer", {"type": "ptracer", "max_depth": 64, "hide_emitters": True}, 256)]:
        e = rgb_irradiance(hdri_scene(sky, ball=False), integrator, spp).mean(axis=(0, 1))
        print(f"  open floor, Mitsuba {name}: E = {e} vs {floor} W/m² ({np.array2string(100 * (e / floor - 1), precision=2)} %)")
        assert np.all(np.abs(e / floor - 1) < 0.01), (name, e, floor)


def check_hdri_sun(direct, caustic):
    """The ball's shadow from the image's sun and its sun caustic both centre on the ball's
    centre projected along the sun's direction (from the image's own row and column, by
    refrakt's convention)."""
    # The sun's direction from the written image: the mean direction of its texels (all those far
    # brighter than the sky), weighted by radiance × solid angle.
    sky = np.array(mi.Bitmap(SKY_FILE), dtype=np.float64)[:, :, 1]
    h, w = sky.shape
    y, x = np.nonzero(sky > 10.0)
    u, v = (x + 0.5) / w, (y + 0.5) / h
    phi, beta = (u - 0.5) * 2 * math.pi, (0.5 - v) * math.pi
    d = np.stack([np.cos(beta) * np.cos(phi), np.sin(beta), np.cos(beta) * np.sin(phi)], axis=-1)
    toward = (d * (sky[y, x] * np.cos(beta))[:, None]).sum(axis=0)
    toward /= np.linalg.norm(toward)
    centre = np.array(BALL["centre"])
    expected = (centre - centre[1] / toward[1] * toward)[[0, 2]]
    axis = -HALF + (np.arange(PIXELS) + 0.5) * 2 * HALF / PIXELS
    z, xx = np.meshgrid(axis, axis, indexing="ij")
    shadow = direct < 0.5 * direct.max()
    bright = caustic > 0.5 * caustic.max()
    got_shadow = np.array([xx[shadow].mean(), z[shadow].mean()])
    got_caustic = (np.array([(xx * caustic)[bright].sum(), (z * caustic)[bright].sum()]) / caustic[bright].sum())
    print(f"  the image's sun toward {toward} (set: {TOWARD_SKY_SUN}); ball centre projected to (x, z) = {expected}: "
          f"shadow centre {got_shadow}, bright caustic's centroid {got_caustic}")
    assert np.allclose(got_shadow, expected, atol=0.02), (got_shadow, expected)
    assert np.allclose(got_caustic, expected, atol=0.03), (got_caustic, expected)


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


def hdri_reference(spp):
    """The ball's caustic under the environment image: Mitsuba's particle tracer minus its direct
    light integrator, as for the sun — each with a control variate, as the sky's and sun's direct
    light (~6 W/m² on every pixel) would otherwise bury the caustic (~1 W/m² on average) in noise:

    * the particle tracer also renders the scene with the ball made of `null` (light passes it
      untouched; it keeps the scene's bounds, so the emitter's rays start where they did) from the
      same seed: light paths that miss the ball are the same in both and cancel;
    * the direct integrator also renders the floor without the ball from the same seed: samples
      whose rays miss the ball cancel.

    Both stand-ins have a known mean, the open floor's irradiance E (`sky_integrals`, checked by
    `check_hdri_floor`), so caustic = (ptracer − ptracer_null + E) − (direct − direct_open + E).
    (Measured at 1024 spp: the relative L1 noise of the particle tracer's part drops from 0.23 to
    0.11 with it, and the direct part's from 0.050 to 0.020.)"""
    sky = write_sky()
    floor = check_sky(sky)
    check_hdri_floor(sky, floor)
    scene, clear, open_floor = hdri_scene(sky), hdri_scene(sky), hdri_scene(sky, ball=False)
    clear["ball"] = dict(clear["ball"], bsdf={"type": "null"})
    ptracer = {"type": "ptracer", "max_depth": 64, "hide_emitters": True, "samples_per_pass": min(spp, 1024)}
    started = time.time()
    through_glass = rgb_irradiance(scene, ptracer, spp, seed=1) - rgb_irradiance(clear, ptracer, spp, seed=1)
    print(f"  particle tracer, {spp} spp, twice: {time.time() - started:.0f} s")
    # Direct light as a path tracer sees it: shadow rays toward the environment stop at glass,
    # and its BSDF-sampled rays that meet glass end there (depth 2).
    started, direct_spp = time.time(), max(spp // 8, 1)
    shadow = rgb_irradiance(scene, {"type": "direct"}, direct_spp, seed=2) - rgb_irradiance(open_floor, {"type": "direct"}, direct_spp, seed=2)
    print(f"  direct light, {direct_spp} spp, twice: {time.time() - started:.0f} s")
    caustic = through_glass - shadow
    check_hdri_sun(floor[1] + shadow[:, :, 1], caustic[:, :, 1])
    return caustic


def write(name, caustic):
    """The caustic as an RGB EXR: one channel repeated (the sun's are grey), or its three."""
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, name + ".exr")
    rgb = caustic if caustic.ndim == 3 else np.repeat(caustic[:, :, None], 3, axis=2)
    mi.Bitmap(rgb.astype(np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(path)
    green = rgb[:, :, 1]
    print(f"wrote {path}: caustic power {green.sum() * (2 * HALF / PIXELS) ** 2:.5f} W, peak {green.max():.3f} W/m² (green)")


# Shared with tests/mitsuba_caustics.rs (`white_room_scene`).
ROOM = dict(lo=[-2.0, 0.0, -2.0], hi=[2.0, 3.0, 2.0], albedo=0.75)
ROOM_BALL = dict(centre=[0.3, 0.6, 0.0], radius=0.4)
ROOM_SPOT = dict(position=[0.0, 2.9, 0.0], target=[0.3, 0.0, 0.0], candela=300.0, angle=30.0, blend=0.02)
ROOM_CAMERA = dict(position=[-1.7, 2.4, 1.8], target=[0.3, 0.5, 0.0], fov=70.0, pixels=64)


def camera_rays(cam):
    """refrakt's pinhole rays through pixel centres (vertical fov, image rows downward), as
    unit directions [row, column, xyz]."""
    eye, target = np.array(cam["position"]), np.array(cam["target"])
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    n = cam["pixels"]
    half = math.tan(math.radians(cam["fov"]) / 2)
    s = (np.arange(n) + 0.5) / n * 2 - 1
    x, y = np.meshgrid(s * half, -s * half)
    d = forward + x[..., None] * right + y[..., None] * up
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def ball_mask(cam, ball, margin):
    """1 where the ray through a pixel's centre passes the ball (radius × margin) by, 0 where
    it meets it."""
    d = camera_rays(cam)
    oc = np.array(cam["position"]) - np.array(ball["centre"])
    b = d @ oc
    disc = b * b - (oc @ oc - (ball["radius"] * margin) ** 2)
    return (disc < 0).astype(np.float32)


def pinhole_sensor(cam):
    """A Mitsuba camera that is refrakt's pinhole `cam` (vertical fov, square, box-filtered pixels)."""
    return {
        "type": "perspective",
        "fov": cam["fov"],
        "fov_axis": "y",
        "to_world": mi.ScalarTransform4f.look_at(origin=cam["position"], target=cam["target"], up=[0, 1, 0]),
        "film": {"type": "hdrfilm", "width": cam["pixels"], "height": cam["pixels"], "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        "sampler": {"type": "independent"},
    }


def white_room_scene():
    lo, hi = np.array(ROOM["lo"]), np.array(ROOM["hi"])
    spot, cam = ROOM_SPOT, ROOM_CAMERA
    radiant = spot["candela"] / 683.0  # refrakt: cd / 683 lm/W = W/sr
    return {
        "type": "scene",
        # Seen from inside: normals flipped inward (Mitsuba's diffuse reflects on its front).
        "room": {
            "type": "cube",
            "flip_normals": True,
            "to_world": mi.ScalarTransform4f.translate(((lo + hi) / 2).tolist()).scale(((hi - lo) / 2).tolist()),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [ROOM["albedo"]] * 3}},
        },
        "ball": {"type": "sphere", "center": ROOM_BALL["centre"], "radius": ROOM_BALL["radius"], "bsdf": glass()},
        "spot": {
            "type": "spot",
            "to_world": mi.ScalarTransform4f.look_at(origin=spot["position"], target=spot["target"], up=[0, 0, 1]),
            "intensity": {"type": "rgb", "value": [radiant] * 3},
            "cutoff_angle": spot["angle"],
            "beam_width": spot["angle"] * (1 - spot["blend"]),
        },
        "sensor": pinhole_sensor(cam),
        "integrator": {"type": "ptracer", "max_depth": 66, "hide_emitters": True, "samples_per_pass": 256},
    }


def white_room_reference(spp):
    """The room's radiance image with alpha = the pixels to compare (`ball_mask`, the ball grown
    by a pixel's width at its distance so edge pixels are left out too). Checks that the particle
    tracer sees nothing through the ball (it cannot), which fixes the image's orientation."""
    started = time.time()
    img = np.array(mi.render(mi.load_dict(white_room_scene()), spp=spp), dtype=np.float32)
    print(f"  particle tracer, {spp} spp: {time.time() - started:.0f} s")
    cam = ROOM_CAMERA
    distance = np.linalg.norm(np.array(cam["position"]) - np.array(ROOM_BALL["centre"]))
    pixel = 2 * math.tan(math.radians(cam["fov"]) / 2) / cam["pixels"] * distance
    mask = ball_mask(cam, ROOM_BALL, 1 + 2 * pixel / ROOM_BALL["radius"])
    inner = ball_mask(cam, ROOM_BALL, 0.9)
    through, room = img[inner == 0].mean(), img[mask == 1].mean()
    print(f"  mean radiance: seen through the ball {through:.5f}, the room {room:.5f} W/m²/sr; {int(mask.sum())} pixels compared")
    assert through < 0.1 * room, "the ball should be dark to a particle tracer: is the image mirrored?"
    return np.concatenate([img, mask[..., None]], axis=-1)


# Shared with tests/contact.rs (`resting_ball_from_45`).
THROUGH_FLOOR_ALBEDO = 0.5
THROUGH_LIGHT = dict(position=[0.6, 2.2, -0.4], radius=0.05, candela=2000.0)
THROUGH_CAMERA = dict(position=[0.0, 1.6, 1.6], target=[0.0, 0.3, 0.0], fov=36.0, pixels=64)


def seen_through_scene():
    light = THROUGH_LIGHT
    # A sphere of radius r and radiance L has intensity L·πr² toward every direction.
    radiance = light["candela"] / 683.0 / (math.pi * light["radius"] ** 2)
    cam = THROUGH_CAMERA
    return {
        "type": "scene",
        "floor": {
            "type": "rectangle",
            "to_world": mi.ScalarTransform4f.rotate([1, 0, 0], -90).scale(3.0),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [THROUGH_FLOOR_ALBEDO] * 3}},
        },
        "ball": {"type": "sphere", "center": RESTING["centre"], "radius": RESTING["radius"], "bsdf": glass()},
        "bulb": {
            "type": "sphere",
            "center": light["position"],
            "radius": light["radius"],
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [radiance] * 3}},
        },
        "sensor": pinhole_sensor(cam),
        "integrator": {"type": "path", "max_depth": 64, "hide_emitters": True},
    }


def seen_through_reference(spp):
    """The resting ball (`RESTING`) on a grey floor under a small spherical light, seen from 45°:
    the radiance of every pixel, by Mitsuba's path tracer (64 bounces: what the floor's direct,
    caustic and bounced light look like through the glass), in W/m²/sr; alpha marks the pixels
    whose centre ray meets the ball well inside its outline (radius × 0.95): the floor seen
    through it."""
    started = time.time()
    img = np.array(mi.render(mi.load_dict(seen_through_scene()), spp=spp), dtype=np.float32)
    print(f"  path tracer, {spp} spp: {time.time() - started:.0f} s")
    through = 1.0 - ball_mask(THROUGH_CAMERA, RESTING, 0.95)
    print(f"  mean radiance through the ball {img[through == 1].mean():.5f} W/m²/sr over {int(through.sum())} pixels")
    return np.concatenate([img, through[..., None]], axis=-1)


# Shared with tests/contact.rs (`rim_view`): floor points within this distance of the contact.
RIM_VIEW_REACH = 0.8


def rim_view_scene():
    """`seen_through`'s resting ball, grey floor and 45° camera under a vertical sun of 1 W/m²
    instead of the bulb, by the particle tracer (a path tracer cannot reach a delta light through
    glass)."""
    s = seen_through_scene()
    del s["bulb"]
    s["sun"] = {"type": "directional", "direction": [0.0, -1.0, 0.0], "irradiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}
    s["integrator"] = {"type": "ptracer", "max_depth": 64, "hide_emitters": True}
    return s


def rim_view_reference(spp):
    """The floor under and around the rim of the resting ball, seen directly from 45° (the
    issue's "floor under the rim at pixel scale"): the caustic converging under the ball, the dark
    ring out to its shadow's edge and the lit floor beyond, in W/m²/sr, 64²; alpha marks the
    pixels whose centre ray passes the ball by (radius × 1.05) and meets the floor within
    `RIM_VIEW_REACH` of the contact."""
    started = time.time()
    img = np.array(mi.render(mi.load_dict(rim_view_scene()), spp=spp), dtype=np.float32)
    print(f"  particle tracer, {spp} spp: {time.time() - started:.0f} s")
    cam = THROUGH_CAMERA
    d = camera_rays(cam)
    t = -cam["position"][1] / d[..., 1]
    floor = np.array(cam["position"]) + t[..., None] * d
    near = (t > 0) & (np.hypot(floor[..., 0], floor[..., 2]) < RIM_VIEW_REACH)
    compared = ball_mask(cam, RESTING, 1.05) * near
    lit = THROUGH_FLOOR_ALBEDO / math.pi
    print(f"  {int(compared.sum())} pixels compared, mean {img[compared == 1].mean():.5f} W/m²/sr (the open floor {lit:.5f})")
    return np.concatenate([img, compared[..., None]], axis=-1)


SPP = {"ball": 16384, "facets": 16384, "bunny": 16384, "hdri": 65536, "white_room": 16384, "resting": 16384, "seen_through": 65536,
       "rim_view": 262144}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--spp", type=int, help=f"particle tracer samples per pixel (light paths / pixel; default {SPP})")
    parser.add_argument("--only", choices=list(SPP), help="render one reference")
    args = parser.parse_args()
    scenes = {"ball": ball_scene, "facets": facets_scene, "bunny": bunny_scene, "resting": resting_scene}
    for name in [args.only] if args.only else SPP:
        spp = args.spp or SPP[name]
        started = time.time()
        if name == "hdri":
            write(name, hdri_reference(spp))
            print(f"  {name}: {time.time() - started:.0f} s")
            continue
        if name in ("white_room", "seen_through", "rim_view"):
            rgba = {"white_room": white_room_reference, "seen_through": seen_through_reference, "rim_view": rim_view_reference}[name](spp)
            path = os.path.join(OUT, name + ".exr")
            mi.Bitmap(rgba, pixel_format=mi.Bitmap.PixelFormat.RGBA).write(path)
            print(f"wrote {path}  {name}: {time.time() - started:.0f} s")
            continue
        scene = scenes[name]()
        total = irradiance(scene, {"type": "ptracer", "max_depth": 64, "hide_emitters": True}, spp)
        # A path tracer cannot reach the sun (a delta light) through glass: it sees exactly the
        # unrefracted light and the glass's shadow.
        direct = irradiance(scene, {"type": "path", "max_depth": 64}, 16)
        if name == "ball":
            check_orientation(direct)
        write(name, total - direct)
        print(f"  {name}: {time.time() - started:.0f} s")


if __name__ == "__main__":
    main()
