"""refrakt for Blender: export the scene as animated glTF, render it with refrakt (caustics,
light shafts, gradient-index lenses), and bring the EXR frames back into the image editor and
the compositor. See docs/blender.md."""

from . import engine, gltf_hooks, operators, preferences, properties, ui

# Blender's glTF exporter looks for this name on every enabled add-on and calls its hooks.
glTF2ExportUserExtension = gltf_hooks.RefraktGltfExtension

_modules = (properties, preferences, operators, ui, engine)


def register():
    for module in _modules:
        module.register()


def unregister():
    for module in reversed(_modules):
        module.unregister()
