"""Blender data → the `extras.refrakt` objects refrakt's glTF importer reads (docs/gltf.md):

- `scenes[i].extras.refrakt`: photons, bounces, samples, volume, fog, environment;
- `nodes[i].extras.refrakt`: an analytic index field, or `{"role": "ignore"}`, or a point or
  spot light's `light_radius`, or an area light (`light`, a rect: glTF has no area lights);
- `materials[i].extras.refrakt`: absorption, scattering, g, boundary of the medium inside.

Everything is converted to refrakt's frame (Y up, as the glTF exporter's +Y Up option does) and
units (metres, per-metre coefficients, radiance in Blender's radiometric units). Node settings
that cannot be read (a texture on a volume density, an unknown shader) fall back to defaults and
add a warning, which the export operator shows.
"""

import math
import os

import bpy
from mathutils import Euler, Matrix, Vector


class Warnings(list):
    """Messages for the user, one per problem (duplicates dropped)."""

    def add(self, message):
        if message not in self:
            self.append(message)

    def add_about(self, name, message):
        """`message` once however many objects it concerns, naming each: "message: 'A', 'B'"."""
        prefix, quoted = message + ": ", f"'{name}'"
        for i, line in enumerate(self):
            if line.startswith(prefix):
                if quoted not in line[len(prefix):].split(", "):
                    self[i] = f"{line}, {quoted}"
                return
        self.append(prefix + quoted)


def to_yup(v):
    """Blender's Z-up (x, y, z) → glTF's Y-up (x, z, −y), as the glTF exporter converts."""
    return [v[0], v[2], -v[1]]


def _value(socket, warnings, owner):
    """A socket's constant value; a linked socket (a texture, a math node) cannot become one
    number for the whole medium, so its unlinked default is used and the user is told."""
    if socket.is_linked:
        warnings.add(f"{owner}: '{socket.name}' is driven by nodes; refrakt uses its plain value {_fmt(socket.default_value)}")
    value = socket.default_value
    return list(value)[:3] if hasattr(value, "__len__") else float(value)


def _fmt(value):
    return ", ".join(f"{v:.3g}" for v in value[:3]) if hasattr(value, "__len__") else f"{value:.3g}"


def _clamp01(c):
    return [min(max(x, 0.0), 1.0) for x in c]


class Medium:
    """Absorption and scattering coefficients per metre (RGB) and the scattering anisotropy,
    with Cycles' meaning of the volume nodes' settings."""

    def __init__(self, absorption=(0.0, 0.0, 0.0), scattering=(0.0, 0.0, 0.0), g=0.0):
        self.absorption = list(absorption)
        self.scattering = list(scattering)
        self.g = g

    def scaled(self, k):
        return Medium([k * a for a in self.absorption], [k * s for s in self.scattering], self.g)

    def plus(self, other):
        # Anisotropies of two scatterers combine weighted by how much each scatters.
        wa, wb = sum(self.scattering), sum(other.scattering)
        g = (self.g * wa + other.g * wb) / (wa + wb) if wa + wb > 0 else 0.0
        return Medium(
            [a + b for a, b in zip(self.absorption, other.absorption)],
            [a + b for a, b in zip(self.scattering, other.scattering)],
            g,
        )

    def is_empty(self):
        return not any(self.absorption) and not any(self.scattering)


def medium_from_node(node, warnings, owner):
    """The medium a volume shader node describes; None for nodes refrakt cannot read.

    Cycles: Volume Absorption gives σa = density·(1 − color); Volume Scatter σs = density·color;
    Principled Volume σs = density·color, σa = density·(1 − color)·(1 − absorption color).
    """
    kind = node.bl_idname
    if kind == "ShaderNodeVolumeAbsorption":
        d = _value(node.inputs["Density"], warnings, owner)
        c = _clamp01(_value(node.inputs["Color"], warnings, owner))
        return Medium(absorption=[d * (1.0 - x) for x in c])
    if kind == "ShaderNodeVolumeScatter":
        d = _value(node.inputs["Density"], warnings, owner)
        c = _clamp01(_value(node.inputs["Color"], warnings, owner))
        return Medium(scattering=[d * x for x in c], g=_value(node.inputs["Anisotropy"], warnings, owner))
    if kind == "ShaderNodeVolumePrincipled":
        d = _value(node.inputs["Density"], warnings, owner)
        c = _clamp01(_value(node.inputs["Color"], warnings, owner))
        ac = _clamp01(_value(node.inputs["Absorption Color"], warnings, owner))
        return Medium(
            absorption=[d * (1.0 - x) * (1.0 - y) for x, y in zip(c, ac)],
            scattering=[d * x for x in c],
            g=_value(node.inputs["Anisotropy"], warnings, owner),
        )
    if kind == "ShaderNodeAddShader":
        parts = [medium_from_socket(s, warnings, owner) for s in node.inputs if s.is_linked]
        total = Medium()
        for part in parts:
            total = total.plus(part)
        return total
    if kind == "ShaderNodeMixShader":
        fac = _value(node.inputs[0], warnings, owner)
        a = medium_from_socket(node.inputs[1], warnings, owner)
        b = medium_from_socket(node.inputs[2], warnings, owner)
        return a.scaled(1.0 - fac).plus(b.scaled(fac))
    warnings.add(f"{owner}: refrakt cannot read the volume node '{node.name}' ({node.bl_label}); it is left out")
    return Medium()


def medium_from_socket(socket, warnings, owner):
    if not socket.is_linked:
        return Medium()
    return medium_from_node(socket.links[0].from_node, warnings, owner)


def _output_node(id_data):
    """The active output node of a material's or world's nodes; None when it renders without
    nodes (Blender 5 always uses nodes and deprecates `use_nodes`)."""
    if bpy.app.version < (5, 0, 0) and not id_data.use_nodes:
        return None
    tree = id_data.node_tree
    return tree.get_output_node("CYCLES") if tree is not None else None


def node_medium(id_data, warnings):
    """The medium connected to the Volume input of a material's or world's active output."""
    out = _output_node(id_data)
    if out is None or "Volume" not in out.inputs:
        return Medium()
    return medium_from_socket(out.inputs["Volume"], warnings, id_data.name)


def material_extras(material, warnings):
    s = material.refrakt
    if s.medium == "CUSTOM":
        medium = Medium(s.absorption, s.scattering, s.anisotropy)
    else:
        medium = node_medium(material, warnings)
    out = {}
    if not medium.is_empty():
        out = {"absorption": medium.absorption, "scattering": medium.scattering, "g": medium.g}
    if s.boundary > 0.0:
        out["boundary"] = s.boundary
    if s.surface != "AUTO":
        out["thin"] = s.surface == "THIN"
    if s.priority != 0:
        out["priority"] = s.priority
    if not _keeps_multiscattered_light(material, warnings):
        out["multiscatter"] = False
    return out or None


def _surface_node(material):
    """The node on the material output's Surface, if any."""
    out = _output_node(material)
    if out is None or not out.inputs["Surface"].is_linked:
        return None
    return out.inputs["Surface"].links[0].from_node


def _keeps_multiscattered_light(material, warnings):
    """Whether rough glass keeps the light its microfacets' masking takes: Cycles' *Multiscatter
    GGX* (the Principled and Glass BSDFs' default) does, its *GGX* and *Beckmann* do not (refrakt's
    `multiscatter = false`; Beckmann's lobe is drawn as GGX's, with a warning)."""
    node = _surface_node(material)
    distribution = getattr(node, "distribution", "MULTI_GGX") if node is not None else "MULTI_GGX"
    if distribution == "BECKMANN":
        warnings.add(f"Material '{material.name}': refrakt's rough glass is GGX; its Beckmann distribution is drawn as "
                     "single-scattering GGX of the same roughness")
    return distribution not in ("GGX", "BECKMANN")


def glass_surface(material):
    """(ior, color, roughness) of a Glass or Refraction BSDF on the material's surface, which the
    glTF exporter does not understand (it reads only the Principled BSDF); None otherwise."""
    node = _surface_node(material)
    if node is None or node.bl_idname not in ("ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction"):
        return None
    inputs = node.inputs
    return float(inputs["IOR"].default_value), list(inputs["Color"].default_value)[:3], float(inputs["Roughness"].default_value)


def attenuation(absorption):
    """KHR_materials_volume's (attenuationColor, attenuationDistance) for per-metre absorption
    σa: the color light keeps after 1 m, exp(−σa). The glTF exporter instead writes the Volume
    Absorption color as is with distance 1/density, i.e. σ = −ln(color)·density, which is not
    what Cycles renders (σ = (1 − color)·density)."""
    return [math.exp(-a) for a in absorption], 1.0


# --- objects -------------------------------------------------------------------------------

def _local_half_extents(obj):
    if obj.type == "EMPTY":
        return [obj.empty_display_size] * 3
    corners = [list(c) for c in obj.bound_box]
    return [(max(c[i] for c in corners) - min(c[i] for c in corners)) / 2.0 for i in range(3)]


LUMENS_PER_WATT = 683.0
MIN_SIZE = 1e-4  # metres


def area_light(obj, warnings):
    """A Blender area light as refrakt's rect, or for a disk or ellipse its disk
    (`nodes[i].extras.refrakt.light`): its size (a disk's diameters) in the node's local X and Y
    (the exporter's light nodes keep Blender's local axes, −Z forward) and its radiance in nits.

    Cycles makes an area light of power P W and area A (its size times the object's scale, π/4 of
    the bounding rectangle for a disk or ellipse) a Lambertian emitter of radiance
    L = P / (π · A) W/(m²·sr) from its front face (with *Normalize* off, L = P / π), times
    2^exposure; refrakt's rect takes nits, L · 683 lm/W, as the glTF exporter's standard lighting
    mode turns point-light watts into candela. The scale is read at the exported frame (refrakt
    sizes a rect by its extras, not by its node's scale)."""
    light = obj.data
    axes = obj.matrix_world.to_3x3()
    sx, sy = axes.col[0].length, axes.col[1].length
    # refrakt needs a rect of some size; a vanishing one keeps its power (and so a huge radiance).
    width = max(light.size * sx, MIN_SIZE)
    height = max((light.size_y if light.shape in ("RECTANGLE", "ELLIPSE") else light.size) * sy, MIN_SIZE)
    round_ = light.shape in ("DISK", "ELLIPSE")
    area = width * height * (math.pi / 4.0 if round_ else 1.0)
    power = light.energy * 2.0 ** getattr(light, "exposure", 0.0)
    normalize = getattr(light, "normalize", True)
    radiance = power / (math.pi * area) if normalize else power / math.pi
    spread = getattr(light, "spread", math.pi)
    if spread < math.pi - 1e-4:
        warnings.add(f"Area light '{obj.name}': its spread is {math.degrees(spread):.0f}°, but refrakt's rect light "
                     "emits as a plain diffuse panel (Cycles' 180°): its light falls wider and dimmer than in Cycles")
    color = list(light.color)
    if getattr(light, "use_temperature", False):
        color = [c * t for c, t in zip(color, light.temperature_color)]
    return {"type": "disk" if round_ else "rect", "size": [width, height], "color": color, "intensity": radiance * LUMENS_PER_WATT}


def node_extras(obj, scene, warnings=None):
    """A node's extras: an index field, or 'ignore' (the volume bounds object, or by choice);
    a point or spot light's radius (glTF's KHR_lights_punctual has none); an area light (which
    KHR_lights_punctual lacks, so Blender's exporter writes none); whether the camera sees the
    light (Object ▸ Visibility ▸ Ray Visibility ▸ Camera; off on new lights in Blender 4.5)."""
    warnings = Warnings() if warnings is None else warnings
    s = obj.refrakt
    if s.role == "IGNORE" or obj == scene.refrakt.volume_bounds:
        return {"role": "ignore"}
    seen = {"light_visible": bool(getattr(obj, "visible_camera", False))}
    if obj.type == "LIGHT" and obj.data.type in ("POINT", "SPOT"):
        return {"light_radius": obj.data.shadow_soft_size, **seen}
    if obj.type == "LIGHT" and obj.data.type == "AREA":
        # A Cycles portal only guides the sampling of the World's light: it emits nothing.
        portal = getattr(getattr(obj.data, "cycles", None), "is_portal", False)
        return None if portal else {"light": area_light(obj, warnings), **seen}
    if s.role != "FIELD":
        return None
    half = _local_half_extents(obj) if s.use_bounds else None
    field = s.field.lower()
    out = {"field": field}
    if field in ("luneburg", "sphere"):
        out["radius"] = max(half) if half else s.radius
    else:
        # Local axes too go to Y up: the slab's gradient runs along Blender's local Z, glTF's Y.
        size = [2.0 * h for h in half] if half else list(s.size)
        out["size"] = [size[0], size[2], size[1]]
    if field != "luneburg":
        out["ior"] = s.ior
    if field == "slab":
        out["gradient"] = s.gradient
    if s.boundary > 0.0:
        out["boundary"] = s.boundary
    return out


# --- cameras -------------------------------------------------------------------------------

# The widest aperture refrakt reads (`cameras[i].extras.refrakt.aperture`), metres.
MAX_APERTURE = 100.0

def camera_extras(camera, scene, warnings):
    """A camera's lens shift and depth of field as refrakt's (None where it has neither)."""
    out = {}
    shift = camera_shift(camera, scene)
    if shift != (0.0, 0.0):
        out["shift"] = list(shift)
    out.update(_thin_lens(camera, scene, warnings) or {})
    return out or None


def camera_shift(camera, scene):
    """Shift X/Y in refrakt's unit, fractions of the frame's larger side. Blender's are fractions
    of the side its sensor fits (Auto: the larger one; Horizontal: the width; Vertical: the
    height), perspective and orthographic alike."""
    w, h = scene.render.resolution_x, scene.render.resolution_y
    fitted = {"HORIZONTAL": w, "VERTICAL": h}.get(camera.sensor_fit, max(w, h))
    k = fitted / max(w, h)
    return camera.shift_x * k, camera.shift_y * k


def _thin_lens(camera, scene, warnings):
    """A camera's depth of field as refrakt's thin lens, the way Cycles sets up its own: the
    aperture's diameter is the focal length over the f-stop, the plane in focus at the *Focus
    Distance* or — with a *Focus Object* — at that object's distance along the view (from the
    first camera object using this camera, when exported), the polygon turned as Cycles turns
    it (a flat side toward *Rotation*, where refrakt puts a corner). None without depth of
    field (and for orthographic cameras, which refrakt keeps sharp)."""
    dof = camera.dof
    if not dof.use_dof or camera.type != "PERSP":
        return None
    aperture = camera.lens * 1e-3 / max(dof.aperture_fstop, 1e-5)
    if aperture > MAX_APERTURE:
        warnings.add(f"Camera '{camera.name}': an f-stop of {dof.aperture_fstop:g} makes an aperture of {aperture:.3g} m; "
                     f"refrakt takes at most {MAX_APERTURE:g} m")
    out = {"aperture": min(aperture, MAX_APERTURE), "focus": max(dof.focus_distance, 1e-3)}
    if dof.focus_object is not None:
        holder = next((o for o in scene.objects if o.data == camera), None)
        if holder is not None:
            view = (holder.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0))).normalized()
            target = dof.focus_object.matrix_world.translation - holder.matrix_world.translation
            out["focus"] = max(abs(target.dot(view)), 1e-3)  # (Cycles: |distance| along the view)
    if dof.aperture_blades >= 3:
        out["blades"] = dof.aperture_blades
        out["blade_rotation"] = math.degrees(dof.aperture_rotation) + 180.0 / dof.aperture_blades
    if abs(dof.aperture_ratio - 1.0) > 1e-6:
        warnings.add(f"Camera '{camera.name}': its aperture ratio {dof.aperture_ratio:g} (anamorphic bokeh) is not carried; "
                     "refrakt's aperture is round or a regular polygon")
    return out


# --- scene ---------------------------------------------------------------------------------

def _world_box(obj):
    corners = [obj.matrix_world @ Vector(c) for c in obj.bound_box]
    yup = [to_yup(c) for c in corners]
    return [min(c[i] for c in yup) for i in range(3)], [max(c[i] for c in yup) for i in range(3)]


def world_in_frames(scene):
    """Whether camera rays that meet nothing see the World. With refrakt as the render engine,
    as in Cycles: unless Film ▸ Transparent is on. For frames laid over Blender's own render of
    the same world (another engine renders the scene): only with *World in Frames*."""
    if scene.render.engine == "REFRAKT":
        return not scene.render.film_transparent
    return scene.refrakt.show_environment


def environment(scene, directory, warnings):
    """The world as refrakt's environment: radiance = color × intensity in Blender's units, or an
    equirectangular image (path relative to the exported file) turned as its Mapping node turns it.
    Refracted and reflected rays always see it; the camera as `world_in_frames` says."""
    env = {"visible": world_in_frames(scene)}
    world = scene.world
    if world is None:
        return {**env, "color": [0.0, 0.0, 0.0], "intensity": 1.0}
    out = _output_node(world)
    if out is None:
        return {**env, "color": list(world.color), "intensity": 1.0}
    surface = out.inputs["Surface"]
    if not surface.is_linked:
        return {**env, "color": [0.0, 0.0, 0.0], "intensity": 1.0}
    background = surface.links[0].from_node
    if background.bl_idname != "ShaderNodeBackground":
        warnings.add(f"World '{world.name}': refrakt reads a Background node on the World Output; "
                     f"found '{background.bl_label}', using the viewport color")
        return {**env, "color": list(world.color), "intensity": 1.0}
    strength = _value(background.inputs["Strength"], warnings, world.name)
    color = background.inputs["Color"]
    if not color.is_linked:
        return {**env, "color": list(color.default_value)[:3], "intensity": strength}
    texture = color.links[0].from_node
    image = getattr(texture, "image", None) if texture.bl_idname == "ShaderNodeTexEnvironment" else None
    path = bpy.path.abspath(image.filepath, library=image.library) if image else ""
    if not image or image.packed_file or not os.path.isfile(path):
        warnings.add(f"World '{world.name}': the background color comes from '{texture.bl_label}', which refrakt "
                     "can only read as an Environment Texture of an image file on disk; using the viewport color")
        return {**env, "color": list(world.color), "intensity": strength}
    return {**env, "image": _relative(path, directory), "intensity": strength, **_mapping_turn(texture, world.name, warnings)}


def _relative(path, directory):
    try:
        return os.path.relpath(path, directory).replace(os.sep, "/")
    except ValueError:  # another drive on Windows
        return path


# Blender's Z-up frame → refrakt's Y-up one (as glTF's exporter converts): (x, y, z) → (x, z, −y).
Z_UP_TO_Y_UP = Matrix(((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)))


def _mapping_turn(texture, world_name, warnings):
    """refrakt's environment `rotation` (degrees about +Y) and `tilt` (a unit quaternion x, y, z,
    w) from a Mapping node feeding the texture's Vector.

    Blender's Mapping turns the lookup direction: the image is read along M·d, M = R (Euler XYZ:
    R_z·R_y·R_x) for the Point, Vector and Normal types, R⁻¹ for Texture. refrakt turns the
    environment itself: what the image holds along r is seen along Q·r, i.e. it is read along
    Q⁻¹·d. In refrakt's frame (C: Z up → Y up) that makes Q = C·M⁻¹·C⁻¹. A turn about Z alone is
    a turn about refrakt's +Y, written as `rotation` (so θ' = −θ for the Point type); anything
    else goes whole into `tilt`. Location and scale do not turn a direction: they are warned."""
    vector = texture.inputs["Vector"]
    if not (vector.is_linked and vector.links[0].from_node.bl_idname == "ShaderNodeMapping"):
        return {"rotation": 0.0}
    mapping = vector.links[0].from_node
    inputs = mapping.inputs
    moves = mapping.vector_type in ("POINT", "TEXTURE")  # (a Vector's or Normal's location is unused)
    location = inputs["Location"].default_value if moves else (0.0, 0.0, 0.0)
    scale = inputs["Scale"].default_value if "Scale" in inputs else (1.0, 1.0, 1.0)
    if any(abs(c) > 1e-6 for c in location) or any(abs(c - 1.0) > 1e-6 for c in scale):
        warnings.add(f"World '{world_name}': refrakt turns the environment by its Mapping node's rotation; "
                     "the Mapping's location and scale are not used")
    euler = inputs["Rotation"].default_value
    inverse = mapping.vector_type == "TEXTURE"
    if abs(euler[0]) < 1e-6 and abs(euler[1]) < 1e-6:
        angle = math.degrees(euler[2])
        return {"rotation": angle if inverse else -angle}
    lookup = Euler(tuple(euler), "XYZ").to_matrix()
    if inverse:
        lookup = lookup.transposed()
    q = (Z_UP_TO_Y_UP @ lookup.transposed() @ Z_UP_TO_Y_UP.transposed()).to_quaternion()
    return {"rotation": 0.0, "tilt": [q.x, q.y, q.z, q.w]}


def fog(scene, warnings):
    s = scene.refrakt
    if s.fog == "CUSTOM":
        medium = Medium([s.fog_absorption] * 3, [s.fog_density * c for c in s.fog_color], s.fog_anisotropy)
    elif s.fog == "WORLD" and scene.world is not None:
        medium = node_medium(scene.world, warnings)
        if medium.is_empty():
            warnings.add(f"Fog is set to the World volume, but World '{scene.world.name}' has none")
    else:
        return None
    return {"scattering": medium.scattering, "absorption": medium.absorption, "g": medium.g}


def scene_extras(scene, directory, warnings):
    s = scene.refrakt
    volume = {
        "resolution": s.volume_resolution,
        "margin": s.volume_margin,
        "boundary": s.volume_boundary,
        "step": s.volume_step,
        "contact": s.volume_contact,
    }
    if s.volume_bounds is not None:
        volume["min"], volume["max"] = _world_box(s.volume_bounds)
    out = {
        "photons": s.photons,
        "bounces": s.bounces,
        "samples": s.samples,
        "volume": volume,
        "environment": environment(scene, directory, warnings),
    }
    fog_settings = fog(scene, warnings)
    if fog_settings is not None:
        out["fog"] = fog_settings
    out.update(motion_blur(scene, warnings))
    return out


def motion_blur(scene, warnings):
    """Render ▸ Motion Blur as refrakt's shutter (frames, around each frame's time) and the
    instants it renders across it; {} when off. refrakt centres the shutter on the frame, as
    Cycles' default Position; Start and End are warned of."""
    r = scene.render
    if not r.use_motion_blur:
        return {}
    position = getattr(r, "motion_blur_position", "CENTER")
    if position != "CENTER":
        warnings.add(f"Motion blur's Position is {position.title()}: refrakt centres the shutter on the frame")
    return {"shutter": r.motion_blur_shutter, "motion_steps": scene.refrakt.motion_steps}
