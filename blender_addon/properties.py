"""refrakt settings stored on Blender data: what glTF itself cannot carry. They travel to
refrakt as glTF `extras` (see `extras.py`), so a .blend keeps them and the exported .glb is
self-contained."""

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)


class RefraktSceneSettings(bpy.types.PropertyGroup):
    photons: IntProperty(
        name="Photons",
        description="Photons traced from the lights each frame; more gives smoother caustics",
        default=70000,
        min=1000,
        max=1 << 30,
        soft_max=10_000_000,
    )
    bounces: IntProperty(
        name="Bounces",
        description="Diffuse bounces of light between surfaces (as Cycles' Light Paths ▸ Diffuse); 0 for none",
        default=4,
        min=0,
        max=1024,
        soft_max=16,
    )
    samples: IntProperty(
        name="Samples",
        description="Camera rays per pixel (antialiasing)",
        default=4,
        min=1,
        max=256,
    )
    motion_steps: IntProperty(
        name="Motion Steps",
        description="With Render ▸ Motion Blur on: the instants across the shutter refrakt renders and "
        "averages, each with its share of the samples and photons (more for a long shutter or fast motion)",
        default=8,
        min=2,
        max=64,
    )
    volume_resolution: IntProperty(
        name="Resolution",
        description="Voxels along the longest side of the index volume; memory grows with its cube",
        default=128,
        min=8,
        max=2048,
        soft_max=512,
    )
    volume_margin: FloatProperty(
        name="Margin",
        description="Air kept around the refractive objects when the volume is fitted to them",
        default=0.05,
        min=0.0,
        soft_max=1.0,
        subtype="DISTANCE",
        unit="LENGTH",
    )
    volume_boundary: FloatProperty(
        name="Boundary",
        description="Width of the smooth step of index at object surfaces, in voxels",
        default=3.0,
        min=0.5,
        max=16.0,
    )
    volume_step: FloatProperty(
        name="Step",
        description="Ray-equation step of camera rays, in voxels",
        default=0.5,
        min=0.05,
        max=4.0,
    )
    volume_contact: FloatProperty(
        name="Contact",
        description="Surfaces of two glass or liquid objects closer than this are one interface between their "
        "media (water against its glass, with no air between), however they were modelled: touching, "
        "overlapping or a hair apart. 0: every surface on its own",
        default=0.00025,
        min=0.0,
        soft_max=0.005,
        subtype="DISTANCE",
        unit="LENGTH",
        precision=5,
    )
    volume_bounds: PointerProperty(
        name="Bounds",
        type=bpy.types.Object,
        description="Fix the volume to this object's bounding box (the object itself is not rendered); "
        "empty: fitted to the refractive objects each frame",
    )

    show_environment: BoolProperty(
        name="World in Frames",
        description="Show the World where refrakt's frames see no object when they are laid over "
        "another engine's render. Off: those pixels are transparent, so the frames composite exactly "
        "over Blender's own render. (With refrakt as the render engine, Film ▸ Transparent decides.)",
        default=False,
    )

    fog: EnumProperty(
        name="Fog",
        description="A scattering medium filling the volume, so light shafts show",
        items=(
            ("NONE", "None", "No fog"),
            ("WORLD", "World Volume", "Read the World's Volume Scatter / Principled Volume / Volume Absorption nodes"),
            ("CUSTOM", "Custom", "Set density, color and anisotropy here"),
        ),
        default="NONE",
    )
    fog_density: FloatProperty(
        name="Density",
        description="Scattering coefficient per metre (as Blender's Volume Scatter density)",
        default=0.05,
        min=0.0,
        soft_max=2.0,
    )
    fog_color: FloatVectorProperty(
        name="Color",
        description="Scattering color (multiplies the density per channel)",
        subtype="COLOR",
        size=3,
        default=(1.0, 1.0, 1.0),
        min=0.0,
        max=1.0,
    )
    fog_absorption: FloatProperty(
        name="Absorption",
        description="Absorption coefficient per metre",
        default=0.0,
        min=0.0,
        soft_max=2.0,
    )
    fog_anisotropy: FloatProperty(
        name="Anisotropy",
        description="Henyey-Greenstein g: > 0 scatters forward, < 0 backward",
        default=0.0,
        min=-0.99,
        max=0.99,
    )

    directory: StringProperty(
        name="Folder",
        description="Where the exported scene (.glb, .lua) and the frames go; // is the .blend's folder",
        default="//refrakt/",
        subtype="DIR_PATH",
    )
    basename: StringProperty(
        name="Name",
        description="Base name of the exported scene and of the frames (empty: the scene's name)",
        default="",
    )
    source: EnumProperty(
        name="Render",
        description="What refrakt renders",
        items=(
            ("GLB", "glTF", "The exported .glb as it is"),
            ("LUA", "Lua Wrapper", "The Lua script next to the .glb, which you may have extended by hand"),
        ),
        default="GLB",
    )
    skip_existing: BoolProperty(
        name="Resume",
        description="Skip frames whose files already exist (continue an interrupted render)",
        default=False,
    )
    cluster_address: StringProperty(
        name="Ray Address",
        description="The Ray cluster for Render on Cluster: ray://HEAD:10001, or auto on a cluster node; "
        "empty: a Ray started on this machine",
        default="",
    )
    cluster_chunk: IntProperty(
        name="Chunk",
        description="Frames each cluster task renders (one refrakt render per chunk)",
        default=24,
        min=1,
        soft_max=240,
    )
    apply_modifiers: BoolProperty(
        name="Apply Modifiers",
        description="Export meshes with their modifiers applied (subdivision, booleans…)",
        default=True,
    )

    pass_caustic: BoolProperty(name="Caustics", description="Add refrakt's caustic light over the render", default=True)
    pass_volume: BoolProperty(name="Volume", description="Add refrakt's in-scattered light (beams in fog)", default=True)
    pass_beauty: BoolProperty(
        name="Refractive Objects",
        description="Lay refrakt's beauty (glass, water, lenses; alpha = their coverage) over the render",
        default=True,
    )

    viewport_scale: IntProperty(
        name="Viewport Resolution",
        description="Pixels refrakt renders in the viewport's Rendered mode, as a percentage of the viewport's",
        default=50,
        min=5,
        max=100,
        subtype="PERCENTAGE",
    )

    live_debounce: FloatProperty(
        name="Delay",
        description="Seconds without changes before live mode re-exports the scene",
        default=0.4,
        min=0.05,
        max=5.0,
        subtype="TIME_ABSOLUTE",
        unit="TIME_ABSOLUTE",
    )


class RefraktObjectSettings(bpy.types.PropertyGroup):
    role: EnumProperty(
        name="refrakt",
        description="How refrakt treats this object",
        items=(
            ("AUTO", "From Material", "Glass or receiver, as its material says"),
            ("FIELD", "Index Field", "An analytic gradient-index field placed by this object's transform"),
            ("IGNORE", "Ignore", "Exported for Blender's sake, not rendered by refrakt"),
        ),
        default="AUTO",
    )
    field: EnumProperty(
        name="Field",
        items=(
            ("LUNEBURG", "Luneburg Lens", "n = sqrt(2 - (r/R)^2): parallel light focuses on the far pole"),
            ("SLAB", "Gradient Slab", "n = IOR + gradient * z along the object's local Z"),
            ("SPHERE", "Sphere", "A ball of constant index"),
            ("BOX", "Box", "A box of constant index"),
        ),
        default="LUNEBURG",
    )
    use_bounds: BoolProperty(
        name="Size from Object",
        description="Take the radius or size from the object's own bounding box (or empty display size)",
        default=True,
    )
    radius: FloatProperty(name="Radius", default=0.5, min=1e-4, soft_max=10.0, subtype="DISTANCE", unit="LENGTH")
    size: FloatVectorProperty(
        name="Size", size=3, default=(1.0, 1.0, 1.0), min=1e-4, subtype="XYZ_LENGTH", unit="LENGTH"
    )
    ior: FloatProperty(name="IOR", description="Index of refraction", default=1.5, min=1.0, max=4.0)
    gradient: FloatProperty(
        name="Gradient",
        description="Change of index per metre along the object's local Z",
        default=0.2,
        soft_min=-2.0,
        soft_max=2.0,
    )
    boundary: FloatProperty(
        name="Boundary",
        description="Smooth boundary width in voxels (0: the scene's)",
        default=0.0,
        min=0.0,
        max=16.0,
    )


class RefraktMaterialSettings(bpy.types.PropertyGroup):
    medium: EnumProperty(
        name="Medium",
        description="Absorption and scattering inside the material",
        items=(
            ("NODES", "From Volume Nodes", "Read the Volume Absorption / Volume Scatter / Principled Volume "
             "nodes connected to the Material Output (Cycles' meaning of their settings)"),
            ("CUSTOM", "Custom", "Set absorption and scattering here"),
        ),
        default="NODES",
    )
    absorption: FloatVectorProperty(
        name="Absorption", description="Absorption coefficient per metre, per channel",
        size=3, default=(0.0, 0.0, 0.0), min=0.0, soft_max=10.0,
    )
    scattering: FloatVectorProperty(
        name="Scattering", description="Scattering coefficient per metre, per channel",
        size=3, default=(0.0, 0.0, 0.0), min=0.0, soft_max=10.0,
    )
    anisotropy: FloatProperty(name="Anisotropy", default=0.0, min=-0.99, max=0.99)
    boundary: FloatProperty(
        name="Boundary",
        description="Smooth boundary width in voxels (0: the scene's)",
        default=0.0,
        min=0.0,
        max=16.0,
    )
    surface: EnumProperty(
        name="Glass",
        description="Whether glass with this material is a solid or a thin sheet",
        items=(
            ("AUTO", "From the Mesh", "Closed meshes are solids (as Cycles renders glass), flat ones thin sheets; "
             "refrakt warns where it guesses"),
            ("SOLID", "Solid", "The solid the mesh encloses: it refracts as it enters and leaves"),
            ("THIN", "Thin Sheet", "A window pane or a bubble: a thin slab's reflection, light passes undeviated"),
        ),
        default="AUTO",
    )
    priority: IntProperty(
        name="Priority",
        description="Where glass and liquid objects overlap (water modelled into its glass's wall, ice in water), "
        "the medium of higher priority holds there; at equal priority, the smaller object's",
        default=0,
        min=-1000,
        max=1000,
    )
    # Neither Blender 4.x nor 5.0 has a dispersion setting on its glass BSDFs (checked with bpy
    # 4.5.15 and 5.0.1), so it lives here and goes out as KHR_materials_dispersion.
    abbe: FloatProperty(
        name="Abbe Number",
        description="Dispersion of the glass as its Abbe number V_d (crown glass 59, flint 36, diamond 55, "
        "lower disperses more); 0: none. Exported as KHR_materials_dispersion (20 / V_d)",
        default=0.0,
        min=0.0,
        soft_min=5.0,
        soft_max=100.0,
    )


class RefraktViewLayerSettings(bpy.types.PropertyGroup):
    """refrakt's passes in the Render Result (View Layer Properties ▸ refrakt Passes). Blender
    asks the engine for them again when the compositor updates its Render Layers node and
    before each render. (An `update` callback calling ViewLayer.update_render_passes at once
    makes the bpy module of Blender 4.2 crash on exit.)"""

    use_pass_caustic: BoolProperty(
        name="Caustic", description="Light that reached a receiver through glass", default=True
    )
    use_pass_direct: BoolProperty(
        name="Direct", description="Light that reached a receiver straight from the lights", default=True
    )
    use_pass_indirect: BoolProperty(
        name="Indirect", description="Light that reached a receiver after bouncing off other surfaces", default=True
    )
    use_pass_volume: BoolProperty(
        name="Volume", description="Light scattered toward the camera by fog and media", default=True
    )


class RefraktJobState(bpy.types.PropertyGroup):
    """What the running render or live session shows in the panel (not saved in the .blend)."""

    running: BoolProperty(default=False)
    progress: FloatProperty(default=0.0, min=0.0, max=100.0, subtype="PERCENTAGE")
    status: StringProperty(default="")
    error: StringProperty(default="")
    live: BoolProperty(default=False)
    live_status: StringProperty(default="")


classes = (
    RefraktSceneSettings,
    RefraktObjectSettings,
    RefraktMaterialSettings,
    RefraktViewLayerSettings,
    RefraktJobState,
)

# (owner type, attribute, property group)
attachments = (
    (bpy.types.Scene, "refrakt", RefraktSceneSettings),
    (bpy.types.Object, "refrakt", RefraktObjectSettings),
    (bpy.types.Material, "refrakt", RefraktMaterialSettings),
    (bpy.types.ViewLayer, "refrakt", RefraktViewLayerSettings),
    (bpy.types.WindowManager, "refrakt", RefraktJobState),
)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()
    for owner, attr, group in attachments:
        setattr(owner, attr, PointerProperty(type=group))


def unregister():
    for owner, attr, _ in reversed(attachments):
        delattr(owner, attr)
    _unregister_classes()
