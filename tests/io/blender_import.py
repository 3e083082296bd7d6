"""What Blender reads of mesh files: run inside Blender,

    blender -b --factory-startup --python tests/io/blender_import.py -- rock.obj rock.glb rock.ply

imports each file into an empty scene with each of Blender's importers for its extension (OBJ:
the C++ ``wm.obj_import`` and, in Blender 3.x, the legacy ``import_scene.obj``; glTF:
``import_scene.gltf``; PLY: ``wm.ply_import`` in Blender 4, ``import_mesh.ply`` in 3.x), with
their default settings, and prints one line ``BLENDER_JSON {...}``: Blender's version and, per
file and importer, the mesh objects with their world-space bounds (m, Blender is Z-up), vertex
and face counts, material slots (name, base colour, metallic, roughness; where the base colour
is linked, the node types feeding it and the colour of that node's unlinked colour input, e.g.
glTF's factor in a multiply with the colour attribute), attributes (name, domain, type), UV
layers, colour attributes, whether custom normals came in, and the volume the object's faces
enclose (divergence theorem, world space; positive when they face outwards).
Used by tests/io/test_mesh_blender.py.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import bpy  # Blender's own module: this script runs only inside Blender

IMPORTERS = {".obj": (("wm", "obj_import"), ("import_scene", "obj")),
             ".glb": (("import_scene", "gltf"),), ".gltf": (("import_scene", "gltf"),),
             ".ply": (("wm", "ply_import"), ("import_mesh", "ply"))}


def _numpy_shim() -> bool:
    """Give NumPy back ``numpy.bool`` (removed in NumPy 1.24) where Blender runs on a newer NumPy
    than it was released with (Debian's Blender 3.4 on the system's NumPy 1.24: its glTF importer
    uses ``np.bool``; Blender's own builds bundle a NumPy that has it). Whether it was needed."""
    try:
        import numpy
    except ImportError:
        return False
    if "bool" in numpy.__dict__:
        return False
    numpy.bool = bool
    return True


def _operator(group: str, name: str):
    """The operator ``bpy.ops.group.name`` if this Blender has it, else None."""
    module = getattr(bpy.ops, group)
    return getattr(module, name) if name in dir(module) else None


def _material(material) -> dict:
    out = {"name": material.name if material else None}
    if material is not None and material.use_nodes:
        bsdf = next((n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
        if bsdf is not None:
            base = bsdf.inputs["Base Color"]
            out.update(base_color=list(base.default_value)[:3],
                       metallic=bsdf.inputs["Metallic"].default_value,
                       roughness=bsdf.inputs["Roughness"].default_value)
            if base.is_linked:  # e.g. glTF: a Mix (multiply) of the colour attribute and the factor
                node = base.links[0].from_node
                out["base_color_from"] = [node.type, *(link.from_node.type for i in node.inputs
                                                       for link in i.links)]
                factor = [i for i in node.inputs if i.type == "RGBA" and not i.is_linked]
                if factor:
                    out["base_color"] = list(factor[-1].default_value)[:3]
    return out


def _object(obj) -> dict:
    mesh = obj.data
    world = [obj.matrix_world @ v.co for v in mesh.vertices]
    low = [min(p[a] for p in world) for a in range(3)] if world else [0.0] * 3
    high = [max(p[a] for p in world) for a in range(3)] if world else [0.0] * 3
    volume = 0.0
    for polygon in mesh.polygons:
        corners = [world[i] for i in polygon.vertices]
        for k in range(1, len(corners) - 1):
            volume += corners[0].dot(corners[k].cross(corners[k + 1])) / 6.0
    return {"name": obj.name, "min": low, "max": high, "vertices": len(mesh.vertices),
            "faces": len(mesh.polygons), "volume": volume,
            "materials": [_material(slot.material) for slot in obj.material_slots],
            "attributes": [{"name": a.name, "domain": a.domain, "type": a.data_type}
                           for a in mesh.attributes],
            "uv_layers": [uv.name for uv in mesh.uv_layers],
            "color_attributes": [c.name for c in getattr(mesh, "color_attributes", [])],
            "custom_normals": bool(mesh.has_custom_normals)}


def import_file(path: Path) -> list[dict]:
    """One record per importer of this Blender for ``path``'s extension."""
    records = []
    for group, name in IMPORTERS.get(path.suffix.lower(), ()):
        operator = _operator(group, name)
        if operator is None:
            continue
        bpy.ops.wm.read_factory_settings(use_empty=True)
        record = {"file": str(path), "importer": f"{group}.{name}"}
        try:
            record["result"] = list(operator(filepath=str(path)))
        except RuntimeError as exc:  # an importer's failure, reported rather than raised
            record["error"] = str(exc)
        objects = [obj for obj in bpy.context.scene.objects if obj.type == "MESH"]
        record["objects"] = [_object(obj) for obj in objects]
        records.append(record)
    return records


def main() -> None:
    paths = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    shim = _numpy_shim()
    records = [r for p in paths for r in import_file(Path(p))]
    print("BLENDER_JSON " + json.dumps({"blender": bpy.app.version_string, "numpy_bool_shim": shim,
                                        "imports": records}))


main()
