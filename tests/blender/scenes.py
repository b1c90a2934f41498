"""Test scenes built with bpy, and Blender-side facts to compare refrakt's view against."""

import math

import bpy
from mathutils import Matrix, Vector

# Blender's Z-up world → glTF's Y-up world: (x, y, z) → (x, z, −y).
Z_UP_TO_Y_UP = Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))

FRAMES = (1, 3, 6)
SPOT_WATTS = 500.0
SUN_STRENGTH = 3.0
GLASS_IOR = 1.45
ABSORPTION_COLOR = (0.8, 0.9, 1.0)
ABSORPTION_DENSITY = 2.0
WORLD_COLOR = (0.1, 0.2, 0.3)
WORLD_STRENGTH = 2.0


def look_at(obj, target):
    direction = Vector(target) - obj.location
    obj.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()


def glass_material():
    m = bpy.data.materials.new("Glass")
    m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Transmission Weight"].default_value = 1.0
    bsdf.inputs["IOR"].default_value = GLASS_IOR
    bsdf.inputs["Roughness"].default_value = 0.0
    absorption = nodes.new("ShaderNodeVolumeAbsorption")
    absorption.inputs["Color"].default_value = (*ABSORPTION_COLOR, 1.0)
    absorption.inputs["Density"].default_value = ABSORPTION_DENSITY
    links.new(absorption.outputs["Volume"], nodes["Material Output"].inputs["Volume"])
    return m


def round_trip_scene():
    """Camera, spot and sun lights, a glass sphere (IOR 1.45, volume absorption), and an animated
    cube on a parent empty with non-uniform scale; 64×36 pixels, frames 1–6 at 24 fps."""
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 36, 100
    scene.render.fps, scene.render.fps_base = 24, 1.0
    scene.frame_start, scene.frame_end = 1, 6

    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 35.0
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = (4.0, -5.0, 3.0)
    look_at(cam, (0, 0, 0.5))
    scene.camera = cam

    spot_data = bpy.data.lights.new("Spot", "SPOT")
    spot_data.energy = SPOT_WATTS
    spot_data.spot_size = math.radians(40.0)
    spot_data.spot_blend = 0.15
    spot_data.color = (1.0, 0.9, 0.8)
    spot = bpy.data.objects.new("Spot", spot_data)
    scene.collection.objects.link(spot)
    spot.location = (1.0, -1.5, 4.0)
    look_at(spot, (0, 0, 0))

    sun_data = bpy.data.lights.new("Sun", "SUN")
    sun_data.energy = SUN_STRENGTH
    sun = bpy.data.objects.new("Sun", sun_data)
    scene.collection.objects.link(sun)
    sun.rotation_euler = (math.radians(30), math.radians(10), 0)

    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(-1.0, 0.0, 0.5), segments=24, ring_count=12)
    # Smooth, as a glass ball is modelled: the exporter writes its normals, and refrakt (like
    # Cycles) would refract a flat-shaded one facet by facet.
    bpy.ops.object.shade_smooth()
    ball = bpy.context.object
    ball.name = "Ball"
    ball.data.materials.append(glass_material())

    rig = bpy.data.objects.new("Rig", None)
    scene.collection.objects.link(rig)
    rig.location = (0.5, 0.5, 0.0)
    rig.rotation_euler = (0, 0, math.radians(30))
    rig.scale = (2.0, 1.0, 0.5)

    bpy.ops.mesh.primitive_cube_add(size=0.5)
    cube = bpy.context.object
    cube.name = "Cube"
    cube.parent = rig
    for frame, x, angle in ((1, 0.0, 0.0), (6, 0.6, 90.0)):
        cube.location = (x, 0.2, 0.4)
        cube.rotation_euler = (math.radians(angle / 3), 0, math.radians(angle))
        cube.keyframe_insert("location", frame=frame)
        cube.keyframe_insert("rotation_euler", frame=frame)

    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*WORLD_COLOR, 1.0)
    background.inputs["Strength"].default_value = WORLD_STRENGTH
    scene.world = world
    scene.frame_set(1)
    return scene


def gltf_world(obj):
    """Blender's world matrix of an object expressed in glTF's Y-up world."""
    return Z_UP_TO_Y_UP @ obj.matrix_world


def camera_fov_y(cam_obj, scene):
    """Blender's vertical field of view (radians) of a landscape frame with the sensor fit on
    Auto: the sensor width spans the image width, so tan(fov_y/2) = tan(fov_x/2)·h/w."""
    w, h = scene.render.resolution_x, scene.render.resolution_y
    cam = cam_obj.data
    assert w >= h and cam.sensor_fit == "AUTO"
    return 2.0 * math.atan(cam.sensor_width / (2.0 * cam.lens) * h / w)
