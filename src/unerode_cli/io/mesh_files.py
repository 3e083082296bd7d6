"""Surface meshes as files for Blender, Houdini, Unreal and Godot, the format chosen by the
extension (:data:`MESH_FORMATS`): binary little-endian PLY, Wavefront OBJ with its MTL, or glTF
2.0 binary (.glb, written by trimesh: :mod:`unerode_cli.io.gltf_mesh`).

Every file carries the vertex normals (area-weighted, outward), box-projected texture
coordinates (:func:`~unerode_cli.volume.uv_projection.box_uv`, ``uv_scale`` m per repeat, so
that a tiling rock texture applies), the vertex colours (the layer's :data:`PALETTE` colour)
and, in its header (PLY, OBJ: comments; glTF: the scene's ``extras["unerode_cli"]``), the
units (m), the origin — the coordinates (m, east, north, up; in the CRS when there is one) of
the mesh's (0, 0, 0), to add to the vertices once they are back in that frame — the CRS's WKT
when known, and the axes.

Axes. The mesh is made with x east, y north, z up. ``up="y"`` writes it Y-up, as OBJ and glTF
importers (Blender, Houdini, Unreal, Godot; glTF by its specification) expect: the proper
rotation file (X, Y, Z) = (x, z, −y), i.e. X east, Y up, Z south, so the file stays
right-handed and the faces keep turning counter-clockwise seen from outside. Blender's importers
turn such a file back to x east, y north, z up. ``up="z"`` writes x, y, z as they are. PLY is
always written Z-up, whatever ``up`` says: Blender's, MeshLab's and CloudCompare's PLY
importers take the file's axes as they are, with Z up (Houdini, which is Y-up, shows a PLY
lying on its back).

Materials: a face's material is the one at least two of its vertices share, else its first
vertex's (:func:`face_materials`); each material present gets a name (``material_names[i]``
for layer i, sanitised to ``[A-Za-z0-9_-]``, else ``layer_<i>``) and its :data:`PALETTE` colour.

- PLY: per vertex ``x y z nx ny nz s t`` float32, ``red green blue`` uchar, ``material`` int
  (the layer index) and one float32 property per ``attributes`` entry; faces as lists of a
  uchar count and int indices. Blender reads the positions, colours and UVs (``s t``).
- OBJ: ``mtllib``, ``v x y z r g b`` (the vertex-colour extension MeshLab, Blender and Houdini
  read, colours in [0, 1]), ``vt``, ``vn``, then the faces (``f v/vt/vn``, 1-based, one index
  for all three) grouped by material under ``usemtl``. The sibling ``STEM.mtl`` holds one
  ``newmtl`` per material (``Kd`` its colour in linear RGB, ``Ka 0 0 0`` — Blender reads Ka as
  metalness —, ``Ks 0 0 0``, ``Ns 10`` — roughness 0.9 in Blender —, ``d 1``, ``illum 1``).
  OBJ carries neither the per-vertex materials (read back as -1) nor ``attributes``.
- glTF: see :mod:`unerode_cli.io.gltf_mesh`; ``attributes`` become the custom attributes
  ``_NAME`` (upper case), and the per-vertex material the attribute ``_MATERIAL``.

Written atomically (a temporary file beside each output, renamed onto it; an OBJ's MTL first);
existing files are kept unless ``overwrite`` (all the files are checked before any is written).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.gltf_mesh import Primitive, check_gltf, glb_bytes, read_glb
from unerode_cli.io.particle_ply import ORIGIN_COMMENT, PLY_TO_NUMPY, ply_type
from unerode_cli.io.paths import active_plan, atomic_path, check_output
from unerode_cli.volume.mesh import Mesh, linear_colours, material_colours, vertex_normals
from unerode_cli.volume.uv_projection import UV_SCALE, box_uv

MESH_FORMATS = (".ply", ".obj", ".glb")
UP_AXES = ("y", "z")
UNITS_COMMENT = "units: metres (x east, y north, z up), relative to the origin"
UP_COMMENT = "up:"
CRS_COMMENT = "crs"
#: How the file's axes follow from x east, y north, z up, for each ``up``.
AXES = {"y": "file X = east (x), Y = up (z), Z = south (-y); right-handed",
        "z": "file X = east (x), Y = north (y), Z = up (z)"}
#: What a material index reads as when the file does not carry it (OBJ).
UNKNOWN_MATERIAL = -1
#: The glTF attribute of the per-vertex material (layer) index.
MATERIAL_ATTRIBUTE = "_MATERIAL"
_PLY_BASE = (("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4"),
             ("s", "<f4"), ("t", "<f4"), ("red", "u1"), ("green", "u1"), ("blue", "u1"), ("material", "<i4"))
_FACE = np.dtype([("count", "u1"), ("indices", "<i4", (3,))])
_ATTRIBUTE_NAME = re.compile(r"[a-z][a-z0-9_]*")


@dataclass(frozen=True)
class MeshFile:
    """What :func:`read_mesh_file` reads: the ``mesh`` (x east, y north, z up, m, relative to
    the ``origin``), the ``origin`` (m), the CRS's WKT ('' when none), the per-vertex
    ``attributes`` (name → float (n,)) and the ``up`` axis the file was written with."""

    mesh: Mesh
    origin: tuple[float, float, float]
    crs_wkt: str = ""
    attributes: dict[str, np.ndarray] = field(default_factory=dict)
    up: str = "z"


def mesh_format(path: Path) -> str:
    """The format of a mesh file from its extension ('.ply', '.obj' or '.glb'): a ValueError for
    another, :class:`~unerode_cli.io.gltf_mesh.GltfExtraMissing` (an ImportError naming the
    extra to install) for .glb without trimesh."""
    suffix = Path(path).suffix.lower()
    if suffix not in MESH_FORMATS:
        raise ValueError(f"a mesh is written as .ply, .obj or .glb, not '{Path(path).name}'")
    if suffix == ".glb":
        check_gltf()
    return suffix


def mesh_sidecars(path: Path) -> tuple[Path, ...]:
    """The files :func:`write_mesh` writes beside ``path``: an OBJ's MTL (same stem, .mtl)."""
    path = Path(path)
    return (path.with_suffix(".mtl"),) if path.suffix.lower() == ".obj" else ()


def face_materials(faces: np.ndarray, materials: np.ndarray) -> np.ndarray:
    """The material (m,) of each face (m, 3): the one at least two of its vertices share, else
    its first vertex's (``materials``: per vertex)."""
    a, b, c = (np.asarray(materials)[np.asarray(faces)[:, i]] for i in range(3))
    return np.where(b == c, b, a)


def layer_material_names(layers: np.ndarray, names: tuple[str, ...] | list[str] | None) -> list[str]:
    """The names of the materials ``layers``: ``names[i]`` for layer i where given, with the
    characters outside ``[A-Za-z0-9_-]`` turned to '_', else ``layer_<i>``; made unique by
    appending ``_<i>``."""
    out: list[str] = []
    for layer in map(int, layers):
        given = names[layer] if names is not None and 0 <= layer < len(names) else ""
        name = re.sub(r"[^A-Za-z0-9_-]", "_", str(given).strip()) or f"layer_{layer}"
        out.append(f"{name}_{layer}" if name in out else name)
    return out


def to_file_axes(xyz: np.ndarray, up: str) -> np.ndarray:
    """Points or vectors (n, 3) in x east, y north, z up in the file's axes for ``up``: Y-up
    (x, z, −y), a rotation; Z-up as they are."""
    xyz = np.asarray(xyz)
    return np.column_stack([xyz[:, 0], xyz[:, 2], -xyz[:, 1]]) if up == "y" else xyz


def from_file_axes(points: np.ndarray, up: str) -> np.ndarray:
    """The inverse of :func:`to_file_axes`: (X, −Z, Y) of a Y-up file."""
    points = np.asarray(points)
    return np.column_stack([points[:, 0], -points[:, 2], points[:, 1]]) if up == "y" else points


def write_mesh(path: Path, mesh: Mesh, overwrite: bool = False,
               origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
               crs_wkt: str | None = None, comments: tuple[str, ...] = (), up: str = "y",
               material_names: tuple[str, ...] | list[str] | None = None,
               attributes: dict[str, np.ndarray] | None = None, uv_scale: float = UV_SCALE) -> None:
    """Write ``mesh`` to ``path`` (.ply, .obj with its .mtl, or .glb) atomically; see the
    module's text for the formats. ``origin`` (m) and ``crs_wkt`` go to the header with the
    ``comments`` (one line each); ``up`` ('y' or 'z') the axes of OBJ and glTF (PLY: Z-up);
    ``material_names`` (one per layer index) names the materials; ``attributes``: name
    (letters, digits, '_'; stored lower case in PLY, ``_UPPER`` in glTF) → per-vertex float
    (n,), written to PLY and glTF; ``uv_scale``: m per texture repeat. Existing files are
    refused (InputError) unless ``overwrite``, all of them before any is written."""
    suffix = mesh_format(path)
    if up not in UP_AXES:
        raise ValueError(f"up is 'y' or 'z', not {up!r}")
    extra = _attributes(attributes, len(mesh.vertices))
    normals = vertex_normals(mesh.vertices, mesh.faces)
    uv = box_uv(mesh.vertices, normals, uv_scale)
    path = Path(path)
    _check_outputs((path, *mesh_sidecars(path)), overwrite)
    file_up = "z" if suffix == ".ply" else up
    header = [f"{ORIGIN_COMMENT} {origin[0]!r} {origin[1]!r} {origin[2]!r}", UNITS_COMMENT,
              f"{UP_COMMENT} {file_up} ({AXES[file_up]})",
              *([f"{CRS_COMMENT} {' '.join(crs_wkt.split())}"] if crs_wkt else []), *comments]
    if suffix == ".ply":
        with atomic_path(path) as tmp, open(tmp, "wb") as handle:
            _write_ply(handle, mesh, normals, uv, extra, header)
        return
    materials = face_materials(mesh.faces, mesh.materials)
    layers = np.unique(materials)
    names = _material_names(layers, material_names)
    if suffix == ".obj":
        mtl = mesh_sidecars(path)[0]
        with atomic_path(mtl) as tmp:
            tmp.write_text(_mtl_text(layers, names, path.name, header), encoding="utf-8")
        with atomic_path(path) as tmp, open(tmp, "wb") as handle:
            _write_obj(handle, mesh, normals, uv, materials, names, header, mtl.name, up)
        return
    extras = {"units": "m", "up": up, "axes": AXES[up], "origin": [float(o) for o in origin],
              "origin_axes": "east, north, up (m; in the CRS when there is one)", "crs_wkt": crs_wkt or "",
              "uv_scale_m": float(uv_scale), "comments": list(comments),
              "materials": {names[int(layer)]: int(layer) for layer in layers},
              "attributes": {_gltf_name(k): k for k in extra}}
    primitives = _primitives(mesh, normals, uv, materials, names, extra, up)
    data = glb_bytes(primitives, re.sub(r"[^A-Za-z0-9_-]", "_", path.stem) or "mesh", extras)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def _check_outputs(outputs: tuple[Path, ...], overwrite: bool) -> None:
    """Clear ``outputs`` in the active plan (a job has cleared the mesh in its plan already),
    all of them refused first, before any is cleared, when one exists that the plan may not
    replace and not ``overwrite``."""
    plan = active_plan()
    for output in outputs:
        if not overwrite and output.exists() and not plan.may_replace(output):
            raise InputError(f"output {output} already exists; pass --overwrite to replace it.")
    for output in outputs:
        check_output(output, overwrite, again=True)


def _material_names(layers: np.ndarray, names) -> dict[int, str]:
    return dict(zip(map(int, layers), layer_material_names(layers, names), strict=True))


def _attributes(attributes: dict[str, np.ndarray] | None, n: int) -> dict[str, np.ndarray]:
    """``attributes`` with lower-case names checked and float32 (n,) values; a ValueError for a
    bad name (or one of the PLY's own properties) or shape."""
    out: dict[str, np.ndarray] = {}
    reserved = {name for name, _ in _PLY_BASE}
    for name, values in (attributes or {}).items():
        key = str(name).lower()
        if not _ATTRIBUTE_NAME.fullmatch(key) or key in reserved or key in out:
            raise ValueError(f"a mesh attribute is named with a letter then letters, digits or '_', "
                             f"other than {', '.join(sorted(reserved))} and each once, not {name!r}")
        array = np.asarray(values, dtype=np.float32)
        if array.shape != (n,):
            raise ValueError(f"the mesh attribute {name!r} has shape {array.shape}, not ({n},)")
        out[key] = array
    return out


def _gltf_name(name: str) -> str:
    return "_" + name.upper()


def _write_ply(handle, mesh: Mesh, normals: np.ndarray, uv: np.ndarray,
               attributes: dict[str, np.ndarray], header: list[str]) -> None:
    dtype = np.dtype([*_PLY_BASE, *((name, "<f4") for name in attributes)])
    vertices = np.empty(len(mesh.vertices), dtype=dtype)
    for a, name in enumerate("xyz"):
        vertices[name] = mesh.vertices[:, a]
        vertices[f"n{name}"] = normals[:, a]
    vertices["s"], vertices["t"] = uv[:, 0], uv[:, 1]
    for a, name in enumerate(("red", "green", "blue")):
        vertices[name] = mesh.colours[:, a]
    vertices["material"] = mesh.materials
    for name, values in attributes.items():
        vertices[name] = values
    faces = np.empty(len(mesh.faces), dtype=_FACE)
    faces["count"] = 3
    faces["indices"] = mesh.faces
    properties = [f"property {ply_type(dtype[name])} {name}" for name in dtype.names]
    lines = ["ply", "format binary_little_endian 1.0", *(f"comment {c}" for c in header),
             f"element vertex {len(vertices)}", *properties,
             f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    handle.write(("\n".join(lines) + "\n").encode("ascii"))
    handle.write(vertices.tobytes())
    handle.write(faces.tobytes())


def _mtl_text(layers: np.ndarray, names: dict[int, str], obj_name: str, header: list[str]) -> str:
    lines = [f"# unerode-cli materials of {obj_name}: one per layer, Kd the layer's colour",
             *(f"# {c}" for c in header)]
    for layer, colour in zip(layers, linear_colours(material_colours(np.maximum(layers, 0))), strict=True):
        r, g, b = colour
        lines += ["", f"newmtl {names[int(layer)]}", "Ka 0 0 0", f"Kd {r:.6f} {g:.6f} {b:.6f}", "Ks 0 0 0",
                  "Ns 10", "d 1", "illum 1"]
    return "\n".join(lines) + "\n"


def _write_obj(handle, mesh: Mesh, normals: np.ndarray, uv: np.ndarray, materials: np.ndarray,
               names: dict[int, str], header: list[str], mtl_name: str, up: str) -> None:
    handle.write(("# unerode-cli surface mesh\n" + "".join(f"# {c}\n" for c in header)
                  + f"mtllib {mtl_name}\n").encode("utf-8"))
    np.savetxt(handle, np.column_stack([to_file_axes(mesh.vertices, up), mesh.colours / 255.0]),
               fmt="v %.6f %.6f %.6f %.6g %.6g %.6g")
    np.savetxt(handle, uv.astype(np.float64), fmt="vt %.6f %.6f")
    np.savetxt(handle, to_file_axes(normals, up), fmt="vn %.5f %.5f %.5f")
    order = np.argsort(materials, kind="stable")
    faces = mesh.faces[order].astype(np.int64) + 1
    starts = np.flatnonzero(np.r_[True, np.diff(materials[order]) != 0]) if len(order) else np.zeros(0, int)
    for start, stop in zip(starts, [*starts[1:], len(order)][:len(starts)], strict=True):
        handle.write(f"usemtl {names[int(materials[order[start]])]}\n".encode())
        np.savetxt(handle, np.repeat(faces[start:stop], 3, axis=1), fmt="f %d/%d/%d %d/%d/%d %d/%d/%d")


def _primitives(mesh: Mesh, normals: np.ndarray, uv: np.ndarray, materials: np.ndarray,
                names: dict[int, str], attributes: dict[str, np.ndarray], up: str) -> list[Primitive]:
    """One glTF primitive per material: its faces and the vertices they use, in the file's axes."""
    vertices, file_normals = to_file_axes(mesh.vertices, up), to_file_axes(normals, up)
    out = []
    layers = np.array(list(names), dtype=np.int64)
    for layer, colour in zip(names, linear_colours(material_colours(np.maximum(layers, 0))), strict=True):
        faces = mesh.faces[materials == layer]
        used = np.unique(faces)
        extra = {MATERIAL_ATTRIBUTE: mesh.materials[used].astype(np.float32),
                 **{_gltf_name(k): v[used] for k, v in attributes.items()}}
        out.append(Primitive(vertices[used], np.searchsorted(used, faces), file_normals[used], uv[used],
                             extra, names[layer], colour))
    return out


def read_mesh(path: Path) -> tuple[Mesh, tuple[float, float, float]]:
    """A mesh written by :func:`write_mesh` (x east, y north, z up, whatever the file's axes)
    and the origin its header gives ((0, 0, 0) when none); see :func:`read_mesh_file`."""
    read = read_mesh_file(path)
    return read.mesh, read.origin


def read_mesh_file(path: Path) -> MeshFile:
    """A mesh file written by :func:`write_mesh`, or a binary little-endian PLY of triangles
    (``x y z`` and any of the other properties; ``material`` -1 without it), or an OBJ without
    normals, UVs or materials: the vertices as written (float32 in PLY and glTF, micrometres in
    OBJ), turned back to x east, y north, z up. The per-vertex materials of an OBJ read as
    :data:`UNKNOWN_MATERIAL`, its faces in the file's order (grouped by material). A glTF's
    primitives are joined, the vertices that two of them share (same position) merged, in the
    order they first appear."""
    suffix = mesh_format(path)
    if suffix == ".glb":
        return _read_glb(Path(path))
    data = Path(path).read_bytes()
    return _read_ply(path, data) if suffix == ".ply" else _read_obj(data.decode("utf-8"))


def _header_fields(comments: list[str]) -> tuple[tuple[float, float, float], str, str]:
    """The origin, CRS WKT ('' when none) and up axis ('z' when not said) of a header."""
    origin, crs, up = (0.0, 0.0, 0.0), "", "z"
    for comment in comments:
        words = comment.split()
        if words[:1] == [ORIGIN_COMMENT]:
            origin = float(words[1]), float(words[2]), float(words[3])
        elif words[:1] == [CRS_COMMENT]:
            crs = comment.split(None, 1)[1] if len(words) > 1 else ""
        elif words[:1] == [UP_COMMENT] and len(words) > 1 and words[1] in UP_AXES:
            up = words[1]
    return origin, crs, up


def _read_ply(path: Path, data: bytes) -> MeshFile:
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply") or end < 0:
        raise InputError(f"{path} is not a PLY file.")
    lines = data[:end].decode("ascii").splitlines()
    counts = {words[1]: int(words[2]) for words in map(str.split, lines) if words[:1] == ["element"]}
    vertex_lines = lines[next((i for i, line in enumerate(lines) if line.startswith("element vertex")),
                              len(lines)):]
    properties = []
    for line in vertex_lines[1:]:
        words = line.split()
        if words[:1] != ["property"]:
            break
        properties.append((words[-1], PLY_TO_NUMPY.get(words[1], "")) if words[1] != "list" else ("", ""))
    names = [name for name, _ in properties]
    if ("format binary_little_endian 1.0" not in lines or not {"x", "y", "z"} <= set(names)
            or any(not t for _, t in properties) or "property list uchar int vertex_indices" not in lines):
        raise InputError(f"{path} is not a surface mesh written by unerode-cli.")
    dtype = np.dtype(properties)
    offset = end + len(b"end_header\n")
    vertices = np.frombuffer(data, dtype=dtype, count=counts["vertex"], offset=offset)
    faces = np.frombuffer(data, dtype=_FACE, count=counts.get("face", 0), offset=offset + vertices.nbytes)
    if np.any(faces["count"] != 3):
        raise InputError(f"{path} has faces that are not triangles.")
    n = len(vertices)
    colours = (np.column_stack([vertices[c] for c in ("red", "green", "blue")])
               if {"red", "green", "blue"} <= set(names) else np.zeros((n, 3), dtype=np.uint8))
    materials = vertices["material"] if "material" in names else np.full(n, UNKNOWN_MATERIAL)
    mesh = Mesh(np.column_stack([vertices[a].astype(np.float64) for a in "xyz"]),
                faces["indices"].astype(np.int32), materials.astype(np.int16), colours.astype(np.uint8))
    base = {name for name, _ in _PLY_BASE}
    attributes = {name: vertices[name].astype(np.float32) for name in names
                  if name not in base and dtype[name].kind == "f"}
    origin, crs, _ = _header_fields([line[len("comment "):] for line in lines if line.startswith("comment ")])
    return MeshFile(mesh, origin, crs, attributes, "z")


def _read_obj(text: str) -> MeshFile:
    lines = text.splitlines()
    origin, crs, up = _header_fields([line[1:].strip() for line in lines if line.startswith("#")])
    vertices = _numbers([line[2:] for line in lines if line.startswith("v ")], 6, np.float64)
    if vertices.shape[1] < 6:
        vertices = np.column_stack([vertices[:, :3], np.zeros((len(vertices), 3))])
    faces = _numbers([re.sub(r"/\S*", "", line[2:]) for line in lines if line.startswith("f ")], 3,
                     np.int64) - 1
    mesh = Mesh(from_file_axes(vertices[:, :3], up).astype(np.float64), faces.astype(np.int32),
                np.full(len(vertices), UNKNOWN_MATERIAL, dtype=np.int16),
                np.rint(vertices[:, 3:6] * 255.0).astype(np.uint8))
    return MeshFile(mesh, origin, crs, {}, up)


def _numbers(rows: list[str], columns: int, dtype) -> np.ndarray:
    """The numbers of text rows as a (len(rows), columns) array."""
    if not rows:
        return np.zeros((0, columns), dtype=dtype)
    return np.loadtxt(rows, dtype=dtype, ndmin=2)


def _read_glb(path: Path) -> MeshFile:
    primitives, extras = read_glb(path)
    up = extras.get("up", "y") if extras.get("up") in UP_AXES else "y"
    if not primitives:
        return MeshFile(Mesh.empty(), _origin_of(extras), str(extras.get("crs_wkt") or ""), {}, up)
    layers: dict[str, Any] = extras.get("materials", {}) if isinstance(extras.get("materials"), dict) else {}
    vertices = from_file_axes(np.concatenate([p.vertices for p in primitives]), up)
    _, first, inverse = np.unique(vertices, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    keep = first[order]
    offsets = np.cumsum([0, *(len(p.vertices) for p in primitives)])
    faces = np.concatenate([p.faces + o for p, o in zip(primitives, offsets, strict=False)])
    faces = rank[inverse.ravel()][faces]
    if all(MATERIAL_ATTRIBUTE in p.attributes for p in primitives):
        materials = np.concatenate([p.attributes[MATERIAL_ATTRIBUTE] for p in primitives])
    else:
        materials = np.concatenate([np.full(len(p.vertices), int(layers.get(p.name, UNKNOWN_MATERIAL)))
                                    for p in primitives])
    names = extras.get("attributes", {}) if isinstance(extras.get("attributes"), dict) else {}
    shared = set.intersection(*(set(p.attributes) for p in primitives)) - {MATERIAL_ATTRIBUTE}
    attributes = {str(names.get(k, k[1:].lower())):
                  np.concatenate([p.attributes[k] for p in primitives])[keep].astype(np.float32)
                  for k in sorted(shared)}
    materials = np.rint(materials[keep]).astype(np.int16)
    mesh = Mesh(vertices[keep], faces.astype(np.int32), materials, material_colours(np.maximum(materials, 0)))
    return MeshFile(mesh, _origin_of(extras), str(extras.get("crs_wkt") or ""), attributes, up)


def _origin_of(extras: dict[str, Any]) -> tuple[float, float, float]:
    origin = extras.get("origin")
    if isinstance(origin, list) and len(origin) == 3:
        return float(origin[0]), float(origin[1]), float(origin[2])
    return 0.0, 0.0, 0.0

