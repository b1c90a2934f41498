"""refrakt's reading of a material, for the Material panel: what of the Principled BSDF (or a
Glass/Refraction BSDF) reaches refrakt through the glTF export and what it does with it, and
what it ignores. It follows refrakt's glTF importer (docs/gltf.md, Materials): a material that
transmits light (KHR_materials_transmission) or holds a medium is glass, with KHR_materials_ior's
index and the base colour as the tint (a Glass BSDF's Color at each surface; a Principled
BSDF's Base Color once through a solid, as Cycles tints it: √ at each surface, and its metal
part); any other is a receiver of glTF's metallic-roughness model whose albedo is the base colour.
"""

from dataclasses import dataclass, field

from . import extras

# Principled BSDF inputs beyond the colour and roughness, with the value at which they do
# nothing: those the glTF export carries and refrakt reads, per kind, show as rows with what
# refrakt does with them (docs/gltf.md, Materials); the rest are listed as ignored when set.
OTHER_INPUTS = (
    ("Metallic", 0.0),
    ("Specular IOR Level", 0.5),
    ("Anisotropic", 0.0),
    ("Subsurface Weight", 0.0),
    ("Coat Weight", 0.0),
    ("Sheen Weight", 0.0),
    ("Thin Film Thickness", 0.0),
    ("Dispersion", 0.0),  # Blender 4.4 and later
    ("Alpha", 1.0),
)
READ = {
    "glass": {
        "Metallic": "the metal part of its surface: reflects Base Color, passes nothing",
        "Specular IOR Level": "reflection strength, × Specular Tint (KHR_materials_specular)",
        "Alpha": "a thin sheet's coverage (a solid ignores it)",
    },
    "receiver": {
        "Metallic": "metallic: reflects Base Color",
        "Specular IOR Level": "specular weight (KHR_materials_specular)",
        "Coat Weight": "a clear coat (KHR_materials_clearcoat)",
        "Sheen Weight": "sheen (KHR_materials_sheen)",
        "Alpha": "coverage: cut out or see-through",
    },
}


@dataclass
class Reading:
    kind: str  # "glass", "receiver" or "unknown"
    rows: list = field(default_factory=list)  # (label, value text, what refrakt does with it)
    ignored: list = field(default_factory=list)  # texts
    medium: object = None  # extras.Medium


def _color(c):
    return " ".join(f"{x:.3g}" for x in list(c)[:3])


def _surface(material):
    out = extras._output_node(material)
    if out is None or not out.inputs["Surface"].is_linked:
        return None
    return out.inputs["Surface"].links[0].from_node


def _linked(node, name):
    return name in node.inputs and node.inputs[name].is_linked


def read(material):
    """How refrakt reads `material`."""
    warnings = extras.Warnings()
    medium = extras.node_medium(material, warnings) if material.refrakt.medium == "NODES" else extras.Medium(
        material.refrakt.absorption, material.refrakt.scattering, material.refrakt.anisotropy
    )
    node = _surface(material)
    if node is None:
        return Reading("receiver", [("Base Color", _color(material.diffuse_color), "albedo (no surface nodes)")], [], medium)
    if node.bl_idname in ("ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction"):
        ior, color, roughness = extras.glass_surface(material)
        rows = [
            ("IOR", f"{ior:.4g}", "index of refraction"),
            ("Color", _color(color), "tint at each surface"),
            ("Roughness", f"{roughness:.3g}", "GGX roughness: frosted glass" if roughness > 0 else "polished"),
            _surface_row(material),
        ]
        return Reading("glass", rows, [], medium)
    if node.bl_idname != "ShaderNodeBsdfPrincipled":
        return Reading("unknown", [], [f"'{node.bl_label}': the glTF export reads only a Principled BSDF"], medium)
    reading = _principled(node, medium)
    if reading.kind == "glass":
        reading.rows.append(_surface_row(material))
    return reading


def _surface_row(material):
    choice = material.refrakt.surface
    what = {"AUTO": "closed meshes solid, flat ones thin sheets", "SOLID": "a solid", "THIN": "a thin sheet"}[choice]
    return ("Glass", choice.title(), what)


def _principled(node, medium):
    value = lambda name: node.inputs[name].default_value  # noqa: E731
    transmission = value("Transmission Weight")
    glass = transmission > 0.0 or not medium.is_empty()
    rows, ignored = [], []
    if glass:
        clear = "clear glass" if transmission >= 1.0 else "passes; the rest a diffuse base of Base Color"
        rows.append(("Transmission", f"{transmission:.3g}", clear if transmission > 0 else "0: a medium without surface"))
        rows.append(("IOR", f"{value('IOR'):.4g}", "index of refraction"))
        tint = "a texture: not used, the plain value is" if _linked(node, "Base Color") else "tint, once through a solid (as Cycles)"
        rows.append(("Base Color", _color(value("Base Color")), tint))
    else:
        albedo = "albedo from the texture" if _linked(node, "Base Color") else "albedo"
        rows.append(("Base Color", _color(value("Base Color")), albedo))
    if glass:
        rows.append(("Roughness", f"{value('Roughness'):.3g}", "GGX roughness: frosted glass" if value("Roughness") > 0 else "polished"))
    else:
        rows.append(("Roughness", f"{value('Roughness'):.3g}", "GGX roughness of its reflection"))
    emitting = value("Emission Strength") > 0.0 and max(list(value("Emission Color"))[:3]) > 0.0
    if emitting and glass:
        ignored.append(f"Emission Strength {value('Emission Strength'):.3g} (glass does not glow)")
    elif emitting:
        rows.append(("Emission", f"{_color(value('Emission Color'))} × {value('Emission Strength'):.3g}",
                     "glows, and lights the scene from both sides"))
    read = READ["glass" if glass else "receiver"]
    for name, neutral in OTHER_INPUTS:
        if name in node.inputs and abs(value(name) - neutral) > 1e-6:
            if name in read:
                rows.append((name, f"{value(name):.3g}", read[name]))
            else:
                ignored.append(f"{name} {value(name):.3g}")
    for name in ("IOR", "Transmission Weight", "Roughness"):
        if _linked(node, name):
            ignored.append(f"the nodes driving {name} (its plain value is exported)")
    if _linked(node, "Normal"):
        rows.append(("Normal", "linked", "a normal map (an Image Texture through a Normal Map node) bends the surface"))
    return Reading("glass" if glass else "receiver", rows, ignored, medium)
