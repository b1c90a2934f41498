"""The scene as refrakt reads it: a .glb written by Blender's glTF exporter (with this add-on's
hooks adding refrakt's extras) and a Lua wrapper next to it that the user may extend."""

import hashlib
import json
import math
import os
import re
import struct
import tempfile
from dataclasses import dataclass

import addon_utils
import bpy

from . import animated_extras, extras, gltf_hooks


class ExportError(Exception):
    """The export failed; the message says why and what to do."""


@dataclass
class Paths:
    directory: str
    name: str

    @property
    def glb(self):
        return os.path.join(self.directory, self.name + ".glb")

    @property
    def lua(self):
        return os.path.join(self.directory, self.name + ".lua")

    @property
    def frames(self):
        return os.path.join(self.directory, "frames")

    @property
    def preview(self):
        return os.path.join(self.directory, self.name + ".preview.exr")

    @property
    def view_script(self):
        """The viewport's scene: the .glb seen from the viewport (viewport.py)."""
        return os.path.join(self.directory, self.name + ".view.lua")

    @property
    def view_preview(self):
        return os.path.join(self.directory, self.name + ".view.exr")

    def frame(self, k, last=None):
        """Frame k of a range ending at `last` (refrakt pads to the digits of the range's last
        frame, at least 4)."""
        width = max(4, len(str(last if last is not None else k)))
        return os.path.join(self.frames, f"{self.name}.{k:0{width}d}.exr")


def paths(scene):
    """Where the scene's files go. A path relative to an unsaved .blend has no folder to be
    relative to, so it goes to the system's temporary folder instead."""
    s = scene.refrakt
    name = bpy.path.clean_name(s.basename or scene.name)
    if s.directory.startswith("//") and not bpy.data.filepath:
        directory = os.path.join(tempfile.gettempdir(), "refrakt", name)
    else:
        directory = bpy.path.abspath(s.directory)
    return Paths(os.path.normpath(directory), name)


def fps(scene):
    """The frame rate the glTF exporter timed the animation with: it stamps frame k at
    k / (fps · fps_base) seconds (Blender's real rate is fps / fps_base; the two differ only for
    NTSC-style rates), and refrakt must sample at the same times for frame numbers to agree."""
    return scene.render.fps * scene.render.fps_base


def gltf_options(scene):
    """Blender glTF exporter settings for refrakt: cameras, punctual lights in the standard
    photometric units (refrakt divides by 683 lm/W as Blender's importer does; area lights,
    which glTF lacks, go out as node extras in the same units), Y up, and one animation baked
    from the scene's frame range, sampled every frame — with animated light power and colour,
    spot cones, camera field of view and material factors as KHR_animation_pointer channels
    (their light intensities and glass tints put right by `fix_animated_channels`; a lens's focus,
    aperture and shift and a light's radius added by `animated_extras`)."""
    return dict(
        export_format="GLB",
        use_active_scene=True,
        export_cameras=True,
        export_lights=True,
        export_import_convert_lighting_mode="SPEC",
        export_yup=True,
        export_apply=scene.refrakt.apply_modifiers,
        export_materials="EXPORT",
        export_extras=False,
        export_animations=True,
        export_animation_mode="SCENE",
        export_frame_range=True,
        export_force_sampling=True,
        export_frame_step=1,
        export_pointer_animation=True,
    )


LIGHT_CHANNEL = re.compile(r"^/extensions/KHR_lights_punctual/lights/(\d+)/(intensity|color)$")
BASE_COLOR_CHANNEL = re.compile(r"^/materials/(\d+)/pbrMetallicRoughness/baseColorFactor$")


def _glb_chunks(data, path):
    """(json, offset of the BIN chunk's data) of a .glb's bytes."""
    magic, _version, _length = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF":
        raise ExportError(f"{path} is not a binary glTF file")
    json_length, json_type = struct.unpack_from("<I4s", data, 12)
    if json_type != b"JSON":
        raise ExportError(f"{path} does not start with a JSON chunk")
    doc = json.loads(data[20:20 + json_length])
    bin_at = 20 + json_length
    bin_length, bin_type = struct.unpack_from("<I4s", data, bin_at) if bin_at + 8 <= len(data) else (0, b"")
    return doc, (bin_at + 8 if bin_type == b"BIN\0" and bin_length else None)


def _float_accessor(doc, bin_data, index):
    """(byte offset in the file, count) of a float accessor's tightly packed values."""
    accessor = doc["accessors"][index]
    view = doc["bufferViews"][accessor["bufferView"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[accessor["type"]]
    if accessor.get("componentType") != 5126 or view.get("byteStride", 4 * width) != 4 * width:
        raise ExportError(f"animation accessor {index} is not packed floats")
    return bin_data + view.get("byteOffset", 0) + accessor.get("byteOffset", 0), accessor["count"] * width


def _light_channel_fix(light, prop):
    """What the exporter's still value of a light's `prop` has that its animated channel lacks,
    as a function of (index among the channel's floats, value): a factor on the intensity, an
    rgb triple on the colour."""
    blender_light = bpy.data.lights.get(light.get("name", ""))
    if prop == "color":
        use = blender_light is not None and blender_light.use_temperature
        tint = list(blender_light.temperature_color) if use else [1.0, 1.0, 1.0]
        return lambda i, v: v * tint[i % 3]
    exposure = 2.0 ** blender_light.exposure if blender_light is not None else 1.0
    factor = (683.0 if light.get("type") == "directional" else 1.0 / (4 * math.pi)) * exposure
    if blender_light is not None and not blender_light.normalize:
        # The still value is times the light's area (its radius, the object's scale).
        holder = next((o for o in bpy.context.scene.objects if o.data == blender_light), None)
        if holder is not None:
            factor *= blender_light.area(matrix_world=holder.matrix_world)
    return lambda i, v: v * factor


def _is_principled_glass(material):
    """Whether an exported material is glass made with the Principled BSDF (transmission), whose
    base colour the still export takes the square root of (`gltf_hooks`, `_principled_tint`;
    not where the base colour also colours a diffuse base or metal and the root is the extras'
    tint)."""
    if "KHR_materials_transmission" not in (material.get("extensions") or {}):
        return False
    if "tint" in ((material.get("extras") or {}).get("refrakt") or {}):
        return False
    blender_material = bpy.data.materials.get(material.get("name", ""))
    return blender_material is not None and extras.glass_surface(blender_material) is None


def _channel_fix(pointer, doc):
    """How a channel aimed at `pointer` must change to say what the still export says, or None."""
    light = LIGHT_CHANNEL.match(pointer)
    if light:
        lights = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
        return _light_channel_fix(lights[int(light.group(1))], light.group(2))
    base = BASE_COLOR_CHANNEL.match(pointer)
    if base and _is_principled_glass(doc.get("materials", [])[int(base.group(1))]):
        return lambda i, v: math.sqrt(max(v, 0.0)) if i % 4 < 3 else v
    return None


def fix_animated_channels(path):
    """Puts Blender's KHR_animation_pointer channels into the units of the still values the
    export writes. Its exporter (4.5 and 5.0) writes an animated point or spot light's
    intensity as watts × 683 — 4π times the candela of its static `intensity`, watts / 4π ·
    683 — and a sun's as W/m², without the 683 lm/W of its static lux; both without the light's
    exposure, and without the area its still value is multiplied by when *Normalize* is off; an
    animated colour without the *Temperature* colour its still value is tinted by; and a
    Principled glass's animated Base Color as it is, where its still value is the square root
    (the tint per surface, `gltf_hooks`). `tests/blender/test_export.py` compares them at
    every frame, and fails should an exporter change this itself."""
    with open(path, "r+b") as f:
        data = bytearray(f.read())
        doc, bin_data = _glb_chunks(data, path)
        if bin_data is None:
            return
        fixed = set()
        for animation in doc.get("animations", []):
            for channel in animation.get("channels", []):
                pointer = channel["target"].get("extensions", {}).get("KHR_animation_pointer", {}).get("pointer", "")
                output = animation["samplers"][channel["sampler"]]["output"]
                fix = None if output in fixed else _channel_fix(pointer, doc)
                if fix is None:
                    continue
                fixed.add(output)
                at, n = _float_accessor(doc, bin_data, output)
                values = struct.unpack_from(f"<{n}f", data, at)
                struct.pack_into(f"<{n}f", data, at, *(fix(i, v) for i, v in enumerate(values)))
        f.seek(0)
        f.write(data)


def read_glb_json(path):
    """The JSON chunk of a .glb file."""
    with open(path, "rb") as f:
        return _glb_chunks(f.read(), path)[0]


def export(context, target=None):
    """Writes the scene to `target` (default: its .glb path) through a temporary file and a
    rename, so `refrakt watch` never reads half a file. Returns the warnings to show."""
    scene = context.scene
    where = paths(scene)
    target = target or where.glb
    os.makedirs(os.path.dirname(target), exist_ok=True)
    if "io_scene_gltf2" not in context.preferences.addons:
        addon_utils.enable("io_scene_gltf2", default_set=True)
    tmp = os.path.join(os.path.dirname(target), f".{os.path.basename(target)}.tmp-{os.getpid()}.glb")
    try:
        result = bpy.ops.export_scene.gltf(filepath=tmp, **gltf_options(scene))
        if "FINISHED" not in result:
            raise ExportError(f"Blender's glTF exporter did not finish ({', '.join(result)})")
        if gltf_hooks.failures:
            raise ExportError("refrakt's glTF export hook failed (a bug in the add-on, please report it): "
                              + "; ".join(gltf_hooks.failures))
        fix_animated_channels(tmp)
        animated_extras.add_channels(tmp, scene, 1.0 / fps(scene))
        data = read_glb_json(tmp)
        if not any("refrakt" in (s.get("extras") or {}) for s in data.get("scenes", [])):
            raise ExportError(
                "The refrakt settings did not reach the glTF file: the exporter calls refrakt's hooks only "
                "when the add-on is enabled in Preferences > Add-ons (not merely registered by a script)."
            )
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return list(gltf_hooks.warnings)


# --- the Lua wrapper -----------------------------------------------------------------------

WRAPPER_MARK = "-- refrakt-wrapper "


def lua_value(v, indent=""):
    """A Python value (from the extras) as a Lua literal."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v) if isinstance(v, int) else f"{v:.6g}"
    if isinstance(v, str):
        return json.dumps(v)  # a JSON string is a valid Lua string literal for what paths hold
    if isinstance(v, (list, tuple)):
        return "{" + ", ".join(lua_value(x) for x in v) + "}"
    inner = indent + "  "
    return "{\n" + "".join(f"{inner}{k} = {lua_value(x, inner)},\n" for k, x in v.items()) + indent + "}"


SETTING_CONSTRUCTORS = {"environment": "r.environment", "fog": "r.fog", "camera": "r.camera"}


def scene_fields(settings):
    """The fields of `r.scene{…}` for the settings (scene extras, and a camera if given)."""
    return "".join(
        f"  {key} = {SETTING_CONSTRUCTORS.get(key, '')}{lua_value(value, '  ')},\n" for key, value in settings.items()
    )


def wrapper_text(paths_, settings, blend_name):
    """The wrapper script: the scene settings as exported from Blender, written out so the user
    sees and can change them, and the glTF file as a subtree of the scene."""
    fields = scene_fields(settings)
    body = f"""-- {paths_.name}.lua: a refrakt scene around {paths_.name}.glb, exported from Blender ({blend_name}).
-- The glTF file brings the nodes, cameras, lights, materials and animation; the settings
-- below are the ones set in Blender's refrakt panel when this file was written.
-- Extend it by hand: once you edit it, exporting again from Blender updates {paths_.name}.glb
-- and leaves this file alone. Render it with `refrakt render {paths_.name}.lua --camera NAME`,
-- or from Blender with Render: Lua Wrapper in the refrakt panel.
local r = require("refrakt")

local scene = r.scene{{
{fields}}}

scene:add(r.gltf("{paths_.name}.glb"))

-- Your own nodes, e.g. a Luneburg lens:
-- scene:add(r.node{{ name = "lens", translation = {{0, 1, 0}}, shape = r.luneburg{{ radius = 0.3 }} }})

-- Animation on top of the glTF's (t in seconds; frame k is t = k / fps):
-- function update(scene, t)
--   scene:find("lens").translation = {{0, 1 + 0.1 * math.sin(t), 0}}
-- end

return scene
"""
    return f"{WRAPPER_MARK}{_checksum(body)}: generated; edit freely.\n{body}"


def write_atomically(path, text):
    """Writes through a temporary name and a rename, so `refrakt watch` never reads half a file."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = os.path.join(os.path.dirname(path), f".{os.path.basename(path)}.tmp-{os.getpid()}")
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)


def _checksum(body):
    return hashlib.sha256(body.encode()).hexdigest()[:16]


def is_untouched(text):
    """Whether a wrapper is exactly as the add-on generated it (so it may be regenerated)."""
    first, _, body = text.partition("\n")
    return first.startswith(WRAPPER_MARK) and first[len(WRAPPER_MARK):].split(":")[0] == _checksum(body)


def write_wrapper(scene, paths_):
    """Writes the wrapper unless the user has edited it. Returns True when written."""
    if os.path.exists(paths_.lua):
        with open(paths_.lua, encoding="utf-8") as f:
            if not is_untouched(f.read()):
                return False
    settings = extras.scene_extras(scene, paths_.directory, extras.Warnings())
    blend = os.path.basename(bpy.data.filepath) or "unsaved file"
    with open(paths_.lua, "w", encoding="utf-8") as f:
        f.write(wrapper_text(paths_, settings, blend))
    return True
