#!/usr/bin/env python3
"""Writes examples/still_life.glb: glass, its caustics and PBR receivers in one glTF scene, made
with nothing but the Python standard library (it reuses make_gltf_example.py's writer):

- a glass ball (KHR_materials_transmission + _ior + _volume, faintly amber) throwing a caustic
  onto the floor under a spot light;
- a polished copper ball (metallic 1, roughness 0.25) mirroring the studio environment, a red
  lacquered one (a rough base under a polished KHR_materials_clearcoat) and a small velvet one
  (KHR_materials_sheen);
- a tiled floor: a base colour texture and a metallic-roughness texture whose roughness is low
  on the tiles and high in the grout, so the tiles are glossy;
- a glowing panel (emissiveFactor × KHR_materials_emissive_strength);
- a leaf-pattern screen: a base colour texture with an alpha channel, alphaMode MASK (a cut-out).

    python3 scripts/make_pbr_example.py             # writes examples/still_life.glb
    refrakt render examples/still_life.glb --size 960x540 --format png --out docs/images
"""

import math
import struct
import zlib

from make_gltf_example import ROOT, Glb, glass, icosphere, look_at_quat, sphere_normals


def png(width, height, texel, alpha=False):
    """An 8-bit PNG whose texel (x, y) is texel(x, y): RGB or RGBA tuples."""
    rows = b"".join(b"\0" + b"".join(bytes(texel(x, y)) for x in range(width)) for y in range(height))
    chunk = lambda kind, data: struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    header = struct.pack(">IIBBBBB", width, height, 8, 6 if alpha else 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows, 9))
            + chunk(b"IEND", b""))


TILE = 16  # texels per tile, the last 2 of each the grout


def grout(x, y):
    return x % TILE >= TILE - 2 or y % TILE >= TILE - 2


def tile_color(x, y):
    if grout(x, y):
        return (205, 200, 190)
    shade = ((x // TILE) * 7 + (y // TILE) * 3) % 4
    return [(42, 62, 88), (38, 56, 80), (48, 70, 96), (40, 60, 84)][shade]


def tile_roughness(x, y):
    # glTF's metallic-roughness texture: roughness in G, metallic in B.
    return (0, 230, 0) if grout(x, y) else (0, 60, 0)


def leaves(x, y):
    """A screen of round holes: white where solid, alpha 0 in the holes."""
    cx, cy = (x % 16) - 7.5, (y % 16) - 7.5
    hole = cx * cx + cy * cy < 36
    return (235, 225, 200, 0 if hole else 255)


def texture(g, data):
    image = g.add("images", {"bufferView": g.view(data), "mimeType": "image/png"})
    return g.add("textures", {"source": image})


def ball(g, name, radius, material):
    v, f = icosphere(radius, 4)
    return g.add("meshes", {"name": name, "primitives": [{"attributes": {"POSITION": g.floats(v, "VEC3"),
                                                                         "NORMAL": g.floats(sphere_normals(v), "VEC3")},
                                                          "indices": g.indices(f), "material": material}]})


def quad(g, name, half_w, half_h, material, repeat=1.0):
    """A vertical quad in the xy plane, facing +z, UVs 0..repeat."""
    p = [(-half_w, -half_h, 0), (half_w, -half_h, 0), (half_w, half_h, 0), (-half_w, half_h, 0)]
    uv = [(0, repeat), (repeat, repeat), (repeat, 0), (0, 0)]
    return g.add("meshes", {"name": name, "primitives": [{"attributes": {
        "POSITION": g.floats(p, "VEC3"), "TEXCOORD_0": g.floats(uv, "VEC2")},
        "indices": g.indices([(0, 1, 2), (0, 2, 3)]), "material": material}]})


def main():
    g = Glb()
    g.json["extensionsUsed"] = ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                                "KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_clearcoat",
                                "KHR_materials_sheen"]
    crystal = glass(g, "Glass", 1.5, [1.0, 0.9, 0.75], 0.6)
    copper = g.add("materials", {"name": "Copper", "pbrMetallicRoughness": {
        "baseColorFactor": [0.95, 0.64, 0.54, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.25}})
    # Red lacquer: a rough red base under a polished clear coat (KHR_materials_clearcoat).
    lacquer = g.add("materials", {"name": "Lacquer", "pbrMetallicRoughness": {
        "baseColorFactor": [0.55, 0.04, 0.03, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5},
        "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.05}}})
    # Blue velvet: a dark base under a pale sheen (KHR_materials_sheen).
    velvet = g.add("materials", {"name": "Velvet", "pbrMetallicRoughness": {
        "baseColorFactor": [0.03, 0.04, 0.15, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_sheen": {"sheenColorFactor": [0.7, 0.75, 1.0], "sheenRoughnessFactor": 0.45}}})
    tiles = g.add("materials", {"name": "Tiles", "pbrMetallicRoughness": {
        "baseColorTexture": {"index": texture(g, png(64, 64, tile_color))},
        "metallicRoughnessTexture": {"index": texture(g, png(64, 64, tile_roughness))},
        "metallicFactor": 0.0, "roughnessFactor": 1.0}})
    glow = g.add("materials", {"name": "Glow", "pbrMetallicRoughness": {"baseColorFactor": [0.05, 0.05, 0.05, 1.0],
                                                                         "metallicFactor": 0.0},
                               "emissiveFactor": [1.0, 0.55, 0.25],
                               "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2.5}}})
    screen = g.add("materials", {"name": "Screen", "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": True,
                                 "pbrMetallicRoughness": {"baseColorTexture": {"index": texture(g, png(64, 64, leaves, alpha=True))},
                                                          "metallicFactor": 0.0, "roughnessFactor": 0.8}})

    floor = g.add("meshes", {"name": "Floor", "primitives": [{"attributes": {
        "POSITION": g.floats([(-4, 0, -4), (4, 0, -4), (4, 0, 4), (-4, 0, 4)], "VEC3"),
        "TEXCOORD_0": g.floats([(0, 0), (8, 0), (8, 8), (0, 8)], "VEC2")},
        "indices": g.indices([(0, 2, 1), (0, 3, 2)]), "material": tiles}]})

    g.json["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"name": "Key", "type": "spot", "color": [1.0, 0.95, 0.88], "intensity": 25000.0,
         "spot": {"innerConeAngle": math.radians(20), "outerConeAngle": math.radians(28)}}]}}
    g.add("cameras", {"name": "Camera", "type": "perspective",
                      "perspective": {"yfov": math.radians(36), "aspectRatio": 16 / 9, "znear": 0.05}})

    nodes = [
        g.add("nodes", {"name": "Floor", "mesh": floor}),
        g.add("nodes", {"name": "Glass", "mesh": ball(g, "Glass", 0.35, crystal), "translation": [0.0, 0.35, 0.3]}),
        g.add("nodes", {"name": "Copper", "mesh": ball(g, "Copper", 0.3, copper), "translation": [-0.95, 0.3, -0.1]}),
        g.add("nodes", {"name": "Lacquer", "mesh": ball(g, "Lacquer", 0.25, lacquer), "translation": [0.9, 0.25, -0.2]}),
        g.add("nodes", {"name": "Velvet", "mesh": ball(g, "Velvet", 0.15, velvet), "translation": [-0.55, 0.15, 0.75]}),
        g.add("nodes", {"name": "Panel", "mesh": quad(g, "Panel", 0.35, 0.5, glow), "translation": [1.7, 0.5, -1.3],
                        "rotation": [0.0, math.sin(math.radians(-20)), 0.0, math.cos(math.radians(-20))]}),
        g.add("nodes", {"name": "Screen", "mesh": quad(g, "Screen", 0.9, 0.7, screen, repeat=3.0), "translation": [-0.4, 0.7, -1.6]}),
    ]
    spot_at = [0.6, 3.2, -1.6]
    nodes.append(g.add("nodes", {"name": "Key", "translation": spot_at, "rotation": look_at_quat(spot_at, [0.0, 0.0, 0.9]),
                                 "extensions": {"KHR_lights_punctual": {"light": 0}}}))
    eye = [0.0, 1.2, 3.6]
    nodes.append(g.add("nodes", {"name": "Camera", "camera": 0, "translation": eye, "rotation": look_at_quat(eye, [0.0, 0.35, 0.0])}))
    g.add("scenes", {"name": "StillLife", "nodes": nodes,
                     "extras": {"refrakt": {"photons": 400000, "samples": 4, "volume": {"resolution": 128, "margin": 0.05},
                                            "environment": {"preset": "studio", "intensity": 0.45, "visible": True}}}})
    g.json["scene"] = 0
    out = ROOT / "examples" / "still_life.glb"
    g.write(out)
    print(f"wrote {out} ({out.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
