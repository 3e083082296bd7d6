"""glTF 2.0 binary (.glb) surface meshes, written and read by trimesh (the ``mesh`` extra,
imported only here and only when a .glb is written or read).

A file holds one glTF mesh (one node, named after the file) with one primitive per material:
its triangles, the vertices they use (a vertex on the border of two materials is in both
primitives), POSITION, NORMAL, TEXCOORD_0 (glTF's v downwards: 1 − v of the OBJ/PLY
convention, as trimesh writes it) and the custom per-vertex attributes (float32 SCALAR accessors
whose names start with an underscore, e.g. ``_STRESS``), and a PBR material (baseColorFactor
the material's colour in linear RGB, metallic 0, roughness :data:`ROUGHNESS`, named after it).
No COLOR_0: glTF multiplies it into the base colour, so carrying the layer's colour there too
would square it; a primitive's vertices all have its material's colour. What the file's axes
and origin mean goes to the scene's ``extras`` (see :mod:`unerode_cli.io.mesh_files`). Blender
imports such a file as one object with one material slot per primitive.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.volume.mesh import INSTALL_HINT, MeshExtraMissing

#: The roughness of the materials (rock: a matte, non-metallic surface).
ROUGHNESS = 0.9
#: The key of the scene's extras that holds this package's description of the file.
EXTRAS_KEY = "unerode_cli"


class GltfExtraMissing(MeshExtraMissing):
    """trimesh, which .glb meshes need, is not installed."""

    def __init__(self) -> None:
        ImportError.__init__(self, f"glTF meshes (.glb) need trimesh, which is not installed: {INSTALL_HINT}")


@dataclass(frozen=True)
class Primitive:
    """One primitive of a glTF mesh in the file's frame: ``vertices`` (k, 3) m, ``faces``
    int (j, 3) into them (counter-clockwise seen from outside), unit ``normals`` (k, 3), ``uv``
    (k, 2) (v upwards, as in OBJ), ``attributes`` glTF name → float (k,), and its material's
    ``name`` and ``colour`` (linear RGB in [0, 1], (3,))."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    uv: np.ndarray
    attributes: dict[str, np.ndarray]
    name: str
    colour: np.ndarray


def check_gltf() -> None:
    """:class:`GltfExtraMissing` unless trimesh can be imported (without importing it)."""
    if importlib.util.find_spec("trimesh") is None:
        raise GltfExtraMissing()


def _trimesh():
    try:
        import trimesh
        import trimesh.exchange.gltf
    except ImportError:
        raise GltfExtraMissing() from None
    return trimesh


def glb_bytes(primitives: list[Primitive], name: str, extras: dict[str, Any]) -> bytes:
    """The bytes of a .glb holding ``primitives`` as one mesh and node called ``name``, with
    ``extras`` (JSON-compatible) as the scene's ``extras[EXTRAS_KEY]``."""
    trimesh = _trimesh()
    from trimesh.visual.material import PBRMaterial
    from trimesh.visual.texture import TextureVisuals

    scene = trimesh.Scene()
    scene.metadata[EXTRAS_KEY] = extras
    for i, part in enumerate(primitives):
        material = PBRMaterial(name=part.name, baseColorFactor=[*map(float, part.colour), 1.0],
                               metallicFactor=0.0, roughnessFactor=ROUGHNESS)
        visual = TextureVisuals(uv=np.asarray(part.uv, dtype=np.float64), material=material)
        geometry = trimesh.Trimesh(part.vertices, part.faces, vertex_normals=part.normals, visual=visual,
                                   process=False, validate=False,
                                   vertex_attributes={k: np.asarray(v, dtype=np.float32)
                                                      for k, v in part.attributes.items()})
        scene.add_geometry(geometry, geom_name=f"{name}_{i}", node_name=f"{name}_{i}")
    return trimesh.exchange.gltf.export_glb(scene, include_normals=True,
                                            tree_postprocessor=lambda tree: _one_mesh(tree, name))


def _one_mesh(tree: dict[str, Any], name: str) -> None:
    """Gather the primitives of trimesh's meshes (one per geometry) into one mesh of one node."""
    primitives = [p for mesh in tree.get("meshes", []) for p in mesh["primitives"]]
    if not primitives:
        return
    tree["meshes"] = [{"name": name, "primitives": primitives}]
    tree["nodes"] = [{"name": name, "mesh": 0}]
    tree["scenes"][0]["nodes"] = [0]


def read_glb(path: Path) -> tuple[list[Primitive], dict[str, Any]]:
    """The primitives of a .glb in the file's frame, each node's transform applied (UVs back to
    v upwards; attributes: those whose names start with an underscore) and the scene's
    ``extras[EXTRAS_KEY]`` ({} when none)."""
    trimesh = _trimesh()
    scene = trimesh.load_scene(str(path), file_type="glb")
    extras = scene.metadata.get(EXTRAS_KEY, {})
    primitives = []
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        geometry = scene.geometry[name]
        if isinstance(geometry, trimesh.Trimesh):
            primitives.append(_primitive(geometry, np.asarray(transform, dtype=np.float64)))
    return primitives, extras if isinstance(extras, dict) else {}


def _primitive(geometry, transform: np.ndarray) -> Primitive:
    """A trimesh geometry of a glTF primitive as a :class:`Primitive`, moved by ``transform``
    (4, 4): the positions by it, the normals by its inverse transpose."""
    n = len(geometry.vertices)
    vertices = np.asarray(geometry.vertices, dtype=np.float64) @ transform[:3, :3].T + transform[:3, 3]
    normals = np.asarray(geometry.vertex_normals, dtype=np.float64) @ np.linalg.inv(transform[:3, :3])
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
    visual = geometry.visual
    uv = getattr(visual, "uv", None)
    material = getattr(visual, "material", None)
    colour = getattr(material, "baseColorFactor", None)
    return Primitive(
        vertices, np.asarray(geometry.faces, dtype=np.int64), normals,
        np.zeros((n, 2)) if uv is None else np.asarray(uv),
        {k: np.asarray(v).reshape(n, -1)[:, 0] for k, v in geometry.vertex_attributes.items()
         if k.startswith("_")},
        str(getattr(material, "name", "") or ""),
        np.zeros(3) if colour is None else np.asarray(colour, dtype=np.float64)[:3] / 255.0)
