"""Render a `sandstone --mesh` file as Blender imports it, headless (Blender ≥ 3.4):

    blender -b --factory-startup --python pipelines/blender_render.py -- MESH.glb|MESH.obj OUT.png [AZIMUTH]

The mesh is imported with Blender's own importer and its defaults (glTF 2.0, or OBJ with its
.mtl), so the picture shows what an artist gets: the materials the file carries, its up axis.
A sun from the north-west, a camera from the azimuth AZIMUTH (degrees clockwise from north;
200, south-south-west, by default) and 25° above, framing the bounding box, a grey ground plane at the mesh's base; Cycles on the CPU (no display needed). It prints
one JSON line: the materials imported, the world bounding box (m, Blender is Z-up) and the
vertex count.
"""

import json
import math
import sys

import bpy
from mathutils import Vector


def numpy_shim() -> None:
    """Give NumPy back ``numpy.bool`` (removed in NumPy 1.24), which the glTF importer of
    Debian's Blender 3.4 uses on the system's newer NumPy (Blender's own builds need none)."""
    try:
        import numpy
    except ImportError:
        return
    if "bool" not in numpy.__dict__:
        numpy.bool = bool


def import_mesh(path: str) -> list:
    """Import ``path`` with Blender's importer for its format; the imported mesh objects."""
    before = set(bpy.data.objects)
    if path.lower().endswith((".glb", ".gltf")):
        bpy.ops.import_scene.gltf(filepath=path)
    elif path.lower().endswith(".obj"):
        if hasattr(bpy.ops.wm, "obj_import"):
            bpy.ops.wm.obj_import(filepath=path)
        else:
            bpy.ops.import_scene.obj(filepath=path)
    else:
        bpy.ops.import_mesh.ply(filepath=path)
    return [o for o in bpy.data.objects if o not in before and o.type == "MESH"]


def bounds(objects: list) -> tuple[Vector, Vector]:
    """The world-space bounding box of ``objects``."""
    corners = [o.matrix_world @ Vector(c) for o in objects for c in o.bound_box]
    low = Vector([min(c[i] for c in corners) for i in range(3)])
    high = Vector([max(c[i] for c in corners) for i in range(3)])
    return low, high


def stage(low: Vector, high: Vector, out: str, azimuth_deg: float = 200.0) -> None:
    """Ground, sun, camera (from ``azimuth_deg``, clockwise from north) and Cycles settings for a
    view of the box [low, high]."""
    centre, size = (low + high) / 2, (high - low).length
    bpy.ops.mesh.primitive_plane_add(size=size * 4, location=(centre.x, centre.y, low.z - 0.01 * size))
    ground = bpy.context.active_object
    grey = bpy.data.materials.new("ground")
    grey.diffuse_color = (0.55, 0.55, 0.52, 1.0)
    grey.use_nodes = True
    grey.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.55, 0.55, 0.52, 1.0)
    ground.data.materials.append(grey)
    bpy.ops.object.light_add(type="SUN", rotation=(math.radians(40), 0.0, math.radians(135)))
    bpy.context.active_object.data.energy = 4.0
    azimuth, elevation = math.radians(azimuth_deg), math.radians(25.0)
    direction = Vector((math.sin(azimuth) * math.cos(elevation), math.cos(azimuth) * math.cos(elevation),
                        math.sin(elevation)))
    bpy.ops.object.camera_add(location=centre + direction * size * 1.7)
    camera = bpy.context.active_object
    camera.data.clip_start, camera.data.clip_end = size * 1e-3, size * 10.0   # metres to kilometres
    camera.rotation_euler = (centre - camera.location).to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.camera = camera
    world = bpy.context.scene.world or bpy.data.worlds.new("world")
    bpy.context.scene.world = world
    world.color = (0.8, 0.85, 0.95)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 32
    scene.cycles.use_denoising = False
    tall = (high.z - low.z) > max(high.x - low.x, high.y - low.y)    # a column: a portrait frame
    scene.render.resolution_x, scene.render.resolution_y = (640, 960) if tall else (960, 640)
    scene.render.filepath = out


def main() -> None:
    arguments = sys.argv[sys.argv.index("--") + 1:]
    mesh_path, out = arguments[:2]
    azimuth = float(arguments[2]) if len(arguments) > 2 else 200.0
    bpy.ops.wm.read_factory_settings(use_empty=True)
    numpy_shim()
    objects = import_mesh(mesh_path)
    low, high = bounds(objects)
    materials = sorted({slot.material.name for o in objects for slot in o.material_slots if slot.material})
    stage(low, high, out, azimuth)
    bpy.ops.render.render(write_still=True)
    print(json.dumps({"materials": materials, "low": list(low), "high": list(high),
                      "vertices": sum(len(o.data.vertices) for o in objects)}))


main()
