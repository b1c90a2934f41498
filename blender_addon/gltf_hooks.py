"""Hooks that Blender's glTF exporter calls for each scene, node, mesh and material while this add-on
is enabled (it looks for `glTF2ExportUserExtension` on every enabled add-on's module). So the
refrakt settings travel as extras whether the export comes from refrakt's operator or from
File > Export > glTF, and glass made with Blender's Glass BSDF and volume nodes reaches
KHR_materials_* with the meaning Cycles gives those nodes, and faces without a material look as
they do in Cycles."""

import functools
import math

import bpy

from . import extras

# Problems met by the hooks during the current export, for the export operator to report.
warnings = extras.Warnings()
# Exceptions raised in the hooks: the exporter would only log them and go on without our
# extras, so they are kept here and the export operator fails with them.
failures = []
# The name of the material given to faces that have none in Blender.
DEFAULT_SURFACE = "Blender default surface"


def _guarded(hook):
    @functools.wraps(hook)
    def run(self, gltf2_object, blender_object, *rest):
        try:
            hook(self, gltf2_object, blender_object, *rest)
        except Exception as e:  # noqa: BLE001 (reported to the user by the export operator)
            name = getattr(blender_object, "name", "?")
            failures.append(f"{hook.__name__} on '{name}': {type(e).__name__}: {e}")

    return run


def _set_refrakt_extras(target, value):
    # Replace only our key, keeping custom properties the user exports alongside.
    current = dict(target.extras) if isinstance(target.extras, dict) else {}
    current.pop("refrakt", None)
    if value is not None:
        current["refrakt"] = value
    target.extras = current or None


def _principled_base_shows(gltf2_material):
    """Whether an exported transmissive material's base colour colours more than its glass: a
    diffuse base (transmission below 1, or a transmission texture) or metal."""
    pbr = gltf2_material.pbr_metallic_roughness
    transmission = gltf2_material.extensions["KHR_materials_transmission"].extension
    partly = transmission.get("transmissionFactor", 0.0) < 1.0 or transmission.get("transmissionTexture") is not None
    metal = (pbr.metallic_factor if pbr.metallic_factor is not None else 1.0) > 0.0
    return partly or metal


def _has(ext, name):
    # The exporter leaves extensions it found nothing for as empty ones (dropped on writing).
    return name in ext and ext[name] is not None and bool(ext[name].extension)


class RefraktGltfExtension:
    def __init__(self):
        # The exporter makes one instance per export.
        from io_scene_gltf2.io.com.gltf2_io_extensions import Extension

        self.Extension = Extension
        self.default_surface = None
        warnings.clear()
        failures.clear()

    @_guarded
    def gather_scene_hook(self, gltf2_scene, blender_scene, export_settings):
        directory = export_settings["gltf_filedirectory"]
        _set_refrakt_extras(gltf2_scene, extras.scene_extras(blender_scene, directory, warnings))

    @_guarded
    def gather_node_hook(self, gltf2_node, blender_object, export_settings):
        if blender_object is not None:
            _set_refrakt_extras(gltf2_node, extras.node_extras(blender_object, bpy.context.scene, warnings))

    @_guarded
    def gather_camera_hook(self, gltf2_camera, blender_camera, export_settings):
        _set_refrakt_extras(gltf2_camera, extras.camera_extras(blender_camera, bpy.context.scene, warnings))

    @_guarded
    def gather_mesh_hook(self, gltf2_mesh, blender_mesh, blender_object, vertex_groups, modifiers, materials, export_settings):
        # A face without a material is shaded by Cycles with its default surface, a diffuse BSDF
        # of colour 0.8. glTF's default material (spec §3.9.6) is a rough metal instead, which
        # would take away the diffuse light and every caustic on it: write Cycles' surface.
        for primitive in gltf2_mesh.primitives:
            if primitive.material is None:
                primitive.material = self._default_surface()

    def _default_surface(self):
        """Cycles' default surface as a glTF material, one per export: base colour 0.8, not
        metallic, no specular lobe (KHR_materials_specular's factor 0), so purely Lambertian."""
        if self.default_surface is None:
            from io_scene_gltf2.io.com import gltf2_io

            pbr = gltf2_io.MaterialPBRMetallicRoughness(
                base_color_factor=[0.8, 0.8, 0.8, 1.0], base_color_texture=None, extensions=None, extras=None,
                metallic_factor=0.0, metallic_roughness_texture=None, roughness_factor=1.0)
            self.default_surface = gltf2_io.Material(
                alpha_cutoff=None, alpha_mode=None, double_sided=True, emissive_factor=None, emissive_texture=None,
                extensions={"KHR_materials_specular": self.Extension("KHR_materials_specular", {"specularFactor": 0.0}, False)},
                extras=None, name=DEFAULT_SURFACE, normal_texture=None, occlusion_texture=None, pbr_metallic_roughness=pbr)
        return self.default_surface

    @_guarded
    def gather_material_hook(self, gltf2_material, blender_material, export_settings):
        medium = extras.material_extras(blender_material, warnings)
        _set_refrakt_extras(gltf2_material, medium)
        ext = gltf2_material.extensions
        glass = extras.glass_surface(blender_material)
        if glass is not None and not _has(ext, "KHR_materials_transmission"):
            ior, color, roughness = glass
            self._add(ext, "KHR_materials_transmission", {"transmissionFactor": 1.0})
            self._add(ext, "KHR_materials_ior", {"ior": ior})
            pbr = gltf2_material.pbr_metallic_roughness
            if pbr is not None:
                pbr.base_color_factor = color + [1.0]
                pbr.metallic_factor = 0.0
                pbr.roughness_factor = roughness
        elif _has(ext, "KHR_materials_transmission"):
            self._principled_tint(gltf2_material, blender_material)
        if _has(ext, "KHR_materials_transmission") and not _has(ext, "KHR_materials_volume") \
                and blender_material.refrakt.surface != "THIN":
            # Transmission alone is thin-walled in glTF; Cycles' glass is a solid, so say so (the
            # thickness is a hint for rasterizers; refrakt traces the real geometry).
            self._add(ext, "KHR_materials_volume", {"thicknessFactor": 1.0})
        abbe = blender_material.refrakt.abbe
        if abbe > 0 and _has(ext, "KHR_materials_transmission"):
            self._add(ext, "KHR_materials_dispersion", {"dispersion": 20.0 / abbe})
        if medium and any(medium.get("absorption", ())) and _has(ext, "KHR_materials_transmission"):
            color, distance = extras.attenuation(medium["absorption"])
            # Thickness matters only to rasterizers that fake refraction; without one a viewer
            # takes the material as thin-walled and ignores the absorption.
            data = dict(ext["KHR_materials_volume"].extension) if _has(ext, "KHR_materials_volume") else {}
            data.setdefault("thicknessFactor", 1.0)
            data.update(attenuationColor=color, attenuationDistance=distance)
            self._add(ext, "KHR_materials_volume", data)

    @staticmethod
    def _principled_tint(gltf2_material, blender_material):
        """Cycles' Principled glass tints the light it passes by √(Base Color) at each surface, so
        light through a solid comes out tinted by the Base Color once (the Glass BSDF's Color
        tints at each surface in full); refrakt's tint, glTF's base colour, is the fraction passed
        at each surface. All glass: the exporter's factor becomes its square root. Where the Base
        Color also colours a diffuse base (Transmission below 1) or metal (Metallic above 0), in
        full, the factor stays and the root goes to `extras.refrakt.tint`, which refrakt reads as
        the tint alone (`Glass::base_color`). A Base Color texture cannot be so taken: it is
        warned of."""
        pbr = gltf2_material.pbr_metallic_roughness
        if pbr is None:
            return
        if pbr.base_color_texture is not None:
            warnings.add(f"Material '{blender_material.name}': a Base Color texture on Principled glass tints refrakt's "
                         "glass by the texture at each surface, where Cycles tints by its square root (a deeper colour)")
        factor = pbr.base_color_factor if pbr.base_color_factor is not None else [1.0, 1.0, 1.0, 1.0]
        root = [math.sqrt(max(c, 0.0)) for c in factor[:3]]
        if root == list(factor[:3]):
            return
        if _principled_base_shows(gltf2_material):
            refrakt = dict((gltf2_material.extras or {}).get("refrakt") or {})
            refrakt["tint"] = root
            _set_refrakt_extras(gltf2_material, refrakt)
        else:
            pbr.base_color_factor = root + list(factor[3:])

    def _add(self, ext, name, data):
        ext[name] = self.Extension(name, data, False)
