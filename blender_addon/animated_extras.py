"""What Blender's exporter does not animate: what glTF has no field for — a camera's thin lens
(focus, aperture, lens shift), a point or spot light's radius, and area lights (their power,
colour and size) — and a Glass or Refraction BSDF's IOR, Color and Roughness, which the exporter
does not understand (the add-on's hooks write their still values). The exporter samples only
what it knows, so a focus pull or a glass's index keyed in Blender would reach refrakt as its
value at the exported frame. These go out as KHR_animation_pointer channels: into refrakt's own
extras (`/cameras/i/extras/refrakt/focus`, `…/aperture`, `…/shift`,
`/extensions/KHR_lights_punctual/lights/i/extras/refrakt/radius`,
`/nodes/i/extras/refrakt/light/intensity`, `…/color`, `…/size`; docs/gltf.md, Animation) and the
glass's material (`/materials/i/extensions/KHR_materials_ior/ior`,
`…/pbrMetallicRoughness/baseColorFactor`, `…/roughnessFactor`), sampled at every frame of the
scene's range, as the exporter samples the rest, and only where the value changes."""

import json
import struct

import bpy

from . import extras

FLOAT = 5126  # glTF componentType


def _is_animated(idblock):
    """Whether an ID's values may change over the frames: keyed, driven, or (for an object)
    constrained or parented to something that is."""
    if idblock is None:
        return False
    data = getattr(idblock, "animation_data", None)
    if data is not None and (data.action is not None or len(data.drivers) or len(data.nla_tracks)):
        return True
    if isinstance(idblock, bpy.types.Object):
        return bool(idblock.constraints) or _is_animated(idblock.parent)
    return False


def _camera_holder(camera, scene):
    return next((o for o in scene.objects if o.data == camera), None)


def _lens_may_change(camera, scene):
    """A lens changes when its camera's data is animated, or it focuses on an object and that
    object or the camera moves."""
    if _is_animated(camera):
        return True
    focus_object = camera.dof.focus_object if camera.dof.use_dof else None
    return focus_object is not None and (_is_animated(focus_object) or _is_animated(_camera_holder(camera, scene)))


def _lens_values(camera, scene):
    """{pointer leaf: numbers} of the lens at the current frame, as the still export writes it."""
    lens = extras.camera_extras(camera, scene, extras.Warnings()) or {}
    out = {"shift": list(lens.get("shift", (0.0, 0.0)))}
    if "aperture" in lens:
        out["aperture"] = [lens["aperture"]]
        out["focus"] = [lens["focus"]]
    return out


def _tracks(doc, scene):
    """(pointer, value at the current frame) makers for everything that may change."""
    tracks = []
    for i, camera in enumerate(doc.get("cameras", [])):
        blender = bpy.data.cameras.get(camera.get("name", ""))
        if blender is not None and _lens_may_change(blender, scene):
            for leaf in ("aperture", "focus", "shift"):
                tracks.append((f"/cameras/{i}/extras/refrakt/{leaf}",
                               lambda b=blender, leaf=leaf: _lens_values(b, scene).get(leaf)))
    for i, light in enumerate(doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])):
        blender = bpy.data.lights.get(light.get("name", ""))
        if blender is not None and blender.type in ("POINT", "SPOT") and _is_animated(blender):
            tracks.append((f"/extensions/KHR_lights_punctual/lights/{i}/extras/refrakt/radius",
                           lambda b=blender: [b.shadow_soft_size]))
    for i, node in enumerate(doc.get("nodes", [])):
        obj = bpy.data.objects.get(node.get("name", ""))
        area = "light" in (node.get("extras") or {}).get("refrakt", {})
        if area and obj is not None and obj.type == "LIGHT" and (_is_animated(obj.data) or _is_animated(obj)):
            for leaf in ("intensity", "color", "size"):
                tracks.append((f"/nodes/{i}/extras/refrakt/light/{leaf}", lambda o=obj, leaf=leaf: _area_value(o, leaf)))
    for i, material in enumerate(doc.get("materials", [])):
        blender = bpy.data.materials.get(material.get("name", ""))
        if blender is not None and extras.glass_surface(blender) is not None and _is_animated(blender.node_tree):
            for leaf, pointer in GLASS_BSDF_POINTERS.items():
                tracks.append((f"/materials/{i}/{pointer}", lambda b=blender, leaf=leaf: _glass_bsdf_value(b, leaf)))
    return tracks


# A Glass BSDF's values, as the hooks write them still (gltf_hooks.py), by their glTF pointers.
GLASS_BSDF_POINTERS = {
    "ior": "extensions/KHR_materials_ior/ior",
    "color": "pbrMetallicRoughness/baseColorFactor",
    "roughness": "pbrMetallicRoughness/roughnessFactor",
}


def _glass_bsdf_value(material, leaf):
    """A Glass BSDF's index, colour (its Color in full: Cycles tints each surface by it) or
    roughness at the current frame."""
    ior, color, roughness = extras.glass_surface(material)
    return {"ior": [ior], "color": color + [1.0], "roughness": [roughness]}[leaf]


def _area_value(obj, leaf):
    """An area light's nits, colour or size at the current frame, as the still export writes it."""
    value = extras.area_light(obj, extras.Warnings())[leaf]
    return list(value) if isinstance(value, (list, tuple)) else [value]


def sample(doc, scene, seconds_per_frame):
    """{pointer: (times, values per frame)} of the tracks whose value changes over the range."""
    tracks = _tracks(doc, scene)
    if not tracks or scene.frame_end <= scene.frame_start:
        return {}
    frames = range(scene.frame_start, scene.frame_end + 1)
    values = {pointer: [] for pointer, _ in tracks}
    now = scene.frame_current, scene.frame_subframe
    try:
        for frame in frames:
            scene.frame_set(frame)
            for pointer, value in tracks:
                values[pointer].append(value())
    finally:
        scene.frame_set(now[0], subframe=now[1])
    times = [f * seconds_per_frame for f in frames]
    return {p: (times, v) for p, v in values.items()
            if None not in v and any(x != v[0] for x in v)}


def _read_glb(data):
    json_length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + json_length])
    at = 20 + json_length
    binary = b""
    if at + 8 <= len(data):
        length, kind = struct.unpack_from("<I4s", data, at)
        if kind == b"BIN\0":
            binary = bytes(data[at + 8:at + 8 + length])
    return doc, binary


def _write_glb(doc, binary):
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(binary), b"BIN\0") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def _accessor(doc, binary, numbers, kind, bounds=False):
    """Appends packed floats as a new buffer view and accessor; returns (binary, its index)."""
    binary += b"\0" * (-len(binary) % 4)
    flat = [x for v in numbers for x in (v if isinstance(v, list) else [v])]
    doc.setdefault("bufferViews", []).append({"buffer": 0, "byteOffset": len(binary), "byteLength": 4 * len(flat)})
    accessor = {"bufferView": len(doc["bufferViews"]) - 1, "componentType": FLOAT, "count": len(numbers), "type": kind}
    if bounds:  # (glTF requires min and max on an animation's input)
        accessor["min"], accessor["max"] = [min(flat)], [max(flat)]
    doc.setdefault("accessors", []).append(accessor)
    return binary + struct.pack(f"<{len(flat)}f", *flat), len(doc["accessors"]) - 1


def add_channels(path, scene, seconds_per_frame):
    """Adds the lens and radius channels to the .glb at `path` (to its first animation, the
    scene's, or to one of their own). Returns how many it added."""
    with open(path, "rb") as f:
        doc, binary = _read_glb(f.read())
    tracks = sample(doc, scene, seconds_per_frame)
    if not tracks:
        return 0
    animations = doc.setdefault("animations", [])
    if not animations:
        animations.append({"name": "refrakt", "channels": [], "samplers": []})
    animation = animations[0]
    times = next(iter(tracks.values()))[0]
    binary, input_ = _accessor(doc, binary, times, "SCALAR", bounds=True)
    for pointer, (_, values) in tracks.items():
        binary, output = _accessor(doc, binary, values, {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[len(values[0])])
        animation["samplers"].append({"input": input_, "output": output, "interpolation": "LINEAR"})
        animation["channels"].append({"sampler": len(animation["samplers"]) - 1, "target": {
            "path": "pointer", "extensions": {"KHR_animation_pointer": {"pointer": pointer}}}})
    buffers = doc.setdefault("buffers", [{}])
    buffers[0]["byteLength"] = len(binary)
    used = doc.setdefault("extensionsUsed", [])
    if "KHR_animation_pointer" not in used:
        used.append("KHR_animation_pointer")
    with open(path, "wb") as f:
        f.write(_write_glb(doc, binary))
    return len(tracks)
