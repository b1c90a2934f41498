#!/usr/bin/env python3
"""Writes examples/pendulum.glb, refrakt's own animated glTF example, with nothing but the
Python standard library (so the file is reproducible and its making readable):

- a glass ball (an icosphere, KHR_materials_transmission + _ior + _volume, amber) swinging on a
  pendulum: a pivot node with a LINEAR rotation channel sampled at 24 fps from θ(t) = A·sin(2πt/T);
- a glass drop whose morph target squashes it, its weight animated LINEARly;
- a Luneburg lens, marked by refrakt's node extras (an empty node with a radius);
- a floor with a checker base color texture (a 64×64 PNG made here), a KHR_lights_punctual
  spot light in candela, a perspective camera, and refrakt's scene extras (photons, samples,
  volume, environment preset).

The animation loops every 2 s: render frames 0..47 at 24 fps.

    python3 scripts/make_gltf_example.py            # writes examples/pendulum.glb
"""

import json
import math
import pathlib
import struct
import zlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
PERIOD = 2.0  # seconds
FPS = 24
SWING = math.radians(28.0)


class Glb:
    def __init__(self):
        self.json = {"asset": {"version": "2.0", "generator": "refrakt scripts/make_gltf_example.py"}}
        self.bin = bytearray()

    def add(self, key, value):
        self.json.setdefault(key, []).append(value)
        return len(self.json[key]) - 1

    def view(self, data):
        while len(self.bin) % 4:
            self.bin.append(0)
        offset = len(self.bin)
        self.bin += data
        return self.add("bufferViews", {"buffer": 0, "byteOffset": offset, "byteLength": len(data)})

    def floats(self, rows, kind):
        flat = [x for row in rows for x in (row if isinstance(row, (list, tuple)) else [row])]
        view = self.view(struct.pack(f"<{len(flat)}f", *flat))
        acc = {"bufferView": view, "componentType": 5126, "count": len(rows), "type": kind}
        if kind in ("SCALAR", "VEC3"):
            n = 1 if kind == "SCALAR" else 3
            acc["min"] = [min(flat[i::n]) for i in range(n)]
            acc["max"] = [max(flat[i::n]) for i in range(n)]
        return self.add("accessors", acc)

    def indices(self, triangles):
        flat = [i for t in triangles for i in t]
        view = self.view(struct.pack(f"<{len(flat)}H", *flat))
        return self.add("accessors", {"bufferView": view, "componentType": 5123, "count": len(flat), "type": "SCALAR"})

    def write(self, path):
        while len(self.bin) % 4:
            self.bin.append(0)
        self.json["buffers"] = [{"byteLength": len(self.bin)}]
        text = json.dumps(self.json, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 4)
        total = 12 + 8 + len(text) + 8 + len(self.bin)
        with open(path, "wb") as f:
            f.write(struct.pack("<4sII", b"glTF", 2, total))
            f.write(struct.pack("<I4s", len(text), b"JSON") + text)
            f.write(struct.pack("<I4s", len(self.bin), b"BIN\0") + bytes(self.bin))


def icosphere(radius, subdivisions):
    """An icosahedron subdivided `subdivisions` times, projected onto the sphere."""
    t = (1 + 5 ** 0.5) / 2
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
             (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
             (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5),
             (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    verts = [tuple(c / math.sqrt(sum(x * x for x in v)) for c in v) for v in verts]
    for _ in range(subdivisions):
        cache, out = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = [(p + q) / 2 for p, q in zip(verts[a], verts[b])]
                n = math.sqrt(sum(x * x for x in m))
                verts.append(tuple(x / n for x in m))
                cache[key] = len(verts) - 1
            return cache[key]

        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            out += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = out
    return [tuple(radius * x for x in v) for v in verts], faces


def unit(v):
    n = math.sqrt(sum(x * x for x in v))
    return tuple(x / n for x in v)


def sphere_normals(vertices):
    """A sphere's normals at its vertices (centred on the origin): smooth, as an exporter writes them."""
    return [unit(v) for v in vertices]


def checker_png(squares=8, texels=8, dark=(150, 75, 55), light=(225, 215, 190)):
    """A checkerboard PNG (RGB, 8-bit) of squares × squares, each texels × texels wide, so the
    bilinear lookup keeps the edges sharp."""
    n = squares * texels
    square = lambda x, y: light if (x // texels + y // texels) % 2 else dark
    rows = b"".join(b"\0" + b"".join(bytes(square(x, y)) for x in range(n)) for y in range(n))
    chunk = lambda kind, data: struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", n, n, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


def look_at_quat(eye, target):
    """The glTF rotation (x, y, z, w) that turns local −Z toward `target` with +Y up."""
    f = [t - e for t, e in zip(target, eye)]
    n = math.sqrt(sum(x * x for x in f))
    f = [x / n for x in f]
    r = [-f[2], 0.0, f[0]]  # f × (0, 1, 0)
    n = math.sqrt(sum(x * x for x in r))
    r = [x / n for x in r]
    u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]]
    m = [r, u, [-x for x in f]]  # columns: right, up, back
    trace = m[0][0] + m[1][1] + m[2][2]
    w = math.sqrt(max(0.0, 1 + trace)) / 2
    return [(m[1][2] - m[2][1]) / (4 * w), (m[2][0] - m[0][2]) / (4 * w), (m[0][1] - m[1][0]) / (4 * w), w]


def glass(g, name, ior, color, distance):
    return g.add("materials", {"name": name, "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.0}, "extensions": {
        "KHR_materials_transmission": {"transmissionFactor": 1.0},
        "KHR_materials_ior": {"ior": ior},
        "KHR_materials_volume": {"thicknessFactor": 0.5, "attenuationColor": color, "attenuationDistance": distance}}})


def main():
    g = Glb()
    g.json["extensionsUsed"] = ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume", "KHR_lights_punctual"]
    amber = glass(g, "Amber", 1.52, [1.0, 0.72, 0.35], 0.4)
    water = glass(g, "Water", 1.33, [0.75, 0.9, 1.0], 0.5)
    view = g.view(checker_png())
    g.add("images", {"bufferView": view, "mimeType": "image/png"})
    g.add("textures", {"source": 0})
    floor_mat = g.add("materials", {"name": "Floor", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0}})

    ball_v, ball_f = icosphere(0.3, 3)
    ball = g.add("meshes", {"name": "Ball", "primitives": [{"attributes": {"POSITION": g.floats(ball_v, "VEC3"),
                                                                           "NORMAL": g.floats(sphere_normals(ball_v), "VEC3")},
                                                             "indices": g.indices(ball_f), "material": amber}]})
    drop_v, drop_f = icosphere(0.25, 3)
    # The morph target: squashed to 60 % height and 125 % width, resting on the same bottom point.
    squash = [(0.25 * x, -0.4 * (y + 0.25), 0.25 * z) for x, y, z in drop_v]
    # The squashed drop's normals: a sphere's scaled by the inverse of the squash (1.25, 0.6, 1.25).
    round_n = sphere_normals(drop_v)
    squashed_n = [unit((x / 1.25, y / 0.6, z / 1.25)) for x, y, z in round_n]
    drop = g.add("meshes", {"name": "Drop", "weights": [0.0], "primitives": [{
        "attributes": {"POSITION": g.floats(drop_v, "VEC3"), "NORMAL": g.floats(round_n, "VEC3")},
        "indices": g.indices(drop_f), "material": water,
        "targets": [{"POSITION": g.floats(squash, "VEC3"),
                     "NORMAL": g.floats([tuple(b - a for a, b in zip(n0, n1)) for n0, n1 in zip(round_n, squashed_n)], "VEC3")}]}]})
    floor = g.add("meshes", {"name": "Floor", "primitives": [{"attributes": {
        "POSITION": g.floats([(-5, 0, -5), (5, 0, -5), (5, 0, 5), (-5, 0, 5)], "VEC3"),
        "TEXCOORD_0": g.floats([(0, 0), (5, 0), (5, 5), (0, 5)], "VEC2")},
        "indices": g.indices([(0, 2, 1), (0, 3, 2)]), "material": floor_mat}]})

    g.json["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"name": "Key", "type": "spot", "color": [1.0, 0.95, 0.85], "intensity": 6000.0,
         "spot": {"innerConeAngle": math.radians(18), "outerConeAngle": math.radians(25)}}]}}
    g.add("cameras", {"name": "Camera", "type": "perspective",
                      "perspective": {"yfov": math.radians(38), "aspectRatio": 16 / 9, "znear": 0.05}})

    nodes = {}
    nodes["Floor"] = g.add("nodes", {"name": "Floor", "mesh": floor})
    nodes["Ball"] = g.add("nodes", {"name": "Ball", "mesh": ball, "translation": [0.0, -1.15, 0.0]})
    nodes["Pivot"] = g.add("nodes", {"name": "Pivot", "translation": [0.0, 1.6, 0.0], "children": [nodes["Ball"]]})
    nodes["Drop"] = g.add("nodes", {"name": "Drop", "mesh": drop, "translation": [1.05, 0.25, 0.35]})
    nodes["Lens"] = g.add("nodes", {"name": "Lens", "translation": [-1.05, 0.4, 0.2],
                                    "extras": {"refrakt": {"field": "luneburg", "radius": 0.35}}})
    # Behind and above the objects, so their caustics and shadows fall toward the camera.
    spot_at = [1.0, 3.4, -2.2]
    nodes["Key"] = g.add("nodes", {"name": "Key", "translation": spot_at, "rotation": look_at_quat(spot_at, [0.0, 0.0, 0.8]),
                                   "extensions": {"KHR_lights_punctual": {"light": 0}}})
    eye = [0.0, 1.25, 4.3]
    nodes["Camera"] = g.add("nodes", {"name": "Camera", "camera": 0, "translation": eye, "rotation": look_at_quat(eye, [0.0, 0.55, 0.0])})

    # The pendulum: θ(t) = A sin(2πt/T) about +Z, sampled every frame of one period.
    times = [k / FPS for k in range(int(PERIOD * FPS) + 1)]
    swing = [(0.0, 0.0, math.sin(0.5 * SWING * math.sin(2 * math.pi * t / PERIOD)),
              math.cos(0.5 * SWING * math.sin(2 * math.pi * t / PERIOD))) for t in times]
    # The drop squashes and recovers twice a period.
    key_t = [0.0, 0.5, 1.0, 1.5, 2.0]
    weights = [0.0, 1.0, 0.0, 1.0, 0.0]
    samplers = [{"input": g.floats(times, "SCALAR"), "output": g.floats(swing, "VEC4"), "interpolation": "LINEAR"},
                {"input": g.floats(key_t, "SCALAR"), "output": g.floats(weights, "SCALAR"), "interpolation": "LINEAR"}]
    g.add("animations", {"name": "Swing", "samplers": samplers, "channels": [
        {"sampler": 0, "target": {"node": nodes["Pivot"], "path": "rotation"}},
        {"sampler": 1, "target": {"node": nodes["Drop"], "path": "weights"}}]})

    g.add("scenes", {"name": "Pendulum", "nodes": [nodes[n] for n in ("Floor", "Pivot", "Drop", "Lens", "Key", "Camera")],
                     "extras": {"refrakt": {"photons": 300000, "samples": 4, "volume": {"resolution": 128, "margin": 0.05},
                                            "environment": {"preset": "sky", "intensity": 0.5, "visible": True}}}})
    g.json["scene"] = 0
    out = ROOT / "examples" / "pendulum.glb"
    g.write(out)
    print(f"wrote {out} ({out.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
