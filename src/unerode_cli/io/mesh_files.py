"""Surface meshes as files, the format chosen by the extension: binary little-endian PLY
(vertex x y z float32, red green blue uchar, material int; faces as lists of uchar count and int
indices) or Wavefront OBJ (``v x y z r g b``, the vertex-colour extension MeshLab, Blender and
Houdini read, colours in [0, 1]; ``f a b c``, 1-based). Both carry a header of comments: the
units (m), the origin — the coordinates (m, in the CRS when there is one) of the file's
(0, 0, 0), to add to the vertices — and the CRS's WKT when known. OBJ does not carry the
per-vertex material (read back as -1). Written atomically (a temporary file beside the output,
renamed onto it); an existing file is kept unless ``overwrite``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.particle_ply import ORIGIN_COMMENT
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.volume.mesh import Mesh

MESH_FORMATS = (".ply", ".obj")
UNITS_COMMENT = "units: metres (x east, y north, z up), relative to the origin"
CRS_COMMENT = "crs"
#: What a material index reads as when the file does not carry it (OBJ).
UNKNOWN_MATERIAL = -1
_VERTEX = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("red", "u1"), ("green", "u1"),
                    ("blue", "u1"), ("material", "<i4")])
_FACE = np.dtype([("count", "u1"), ("indices", "<i4", (3,))])
_PLY_PROPERTIES = ("float x", "float y", "float z", "uchar red", "uchar green", "uchar blue", "int material")


def mesh_format(path: Path) -> str:
    """The format of a mesh file from its extension ('.ply' or '.obj'); a ValueError otherwise."""
    suffix = Path(path).suffix.lower()
    if suffix not in MESH_FORMATS:
        raise ValueError(f"a mesh is written as .ply or .obj, not '{Path(path).name}'")
    return suffix


def write_mesh(path: Path, mesh: Mesh, overwrite: bool = False,
               origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
               crs_wkt: str | None = None, comments: tuple[str, ...] = ()) -> None:
    """Write ``mesh`` to ``path`` (.ply or .obj) atomically; ``origin`` (m) and ``crs_wkt`` go to
    the header (the vertices are written as they are), with the ``comments`` (one line each)."""
    suffix = mesh_format(path)
    check_output(path, overwrite, again=True)   # a job has cleared it in its plan already
    header = [f"{ORIGIN_COMMENT} {origin[0]!r} {origin[1]!r} {origin[2]!r}", UNITS_COMMENT,
              *([f"{CRS_COMMENT} {' '.join(crs_wkt.split())}"] if crs_wkt else []), *comments]
    with atomic_path(path) as tmp, open(tmp, "wb") as handle:
        if suffix == ".ply":
            _write_ply(handle, mesh, header)
        else:
            _write_obj(handle, mesh, header)


def _write_ply(handle, mesh: Mesh, header: list[str]) -> None:
    vertices = np.empty(len(mesh.vertices), dtype=_VERTEX)
    for a, name in enumerate("xyz"):
        vertices[name] = mesh.vertices[:, a]
    for a, name in enumerate(("red", "green", "blue")):
        vertices[name] = mesh.colours[:, a]
    vertices["material"] = mesh.materials
    faces = np.empty(len(mesh.faces), dtype=_FACE)
    faces["count"] = 3
    faces["indices"] = mesh.faces
    lines = ["ply", "format binary_little_endian 1.0", *(f"comment {c}" for c in header),
             f"element vertex {len(vertices)}", *(f"property {p}" for p in _PLY_PROPERTIES),
             f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    handle.write(("\n".join(lines) + "\n").encode("ascii"))
    handle.write(vertices.tobytes())
    handle.write(faces.tobytes())


def _write_obj(handle, mesh: Mesh, header: list[str]) -> None:
    handle.write(("# unerode-cli surface mesh\n" + "".join(f"# {c}\n" for c in header)).encode("utf-8"))
    np.savetxt(handle, np.column_stack([mesh.vertices, mesh.colours / 255.0]),
               fmt="v %.6f %.6f %.6f %.6g %.6g %.6g")
    np.savetxt(handle, mesh.faces.astype(np.int64) + 1, fmt="f %d %d %d")


def read_mesh(path: Path) -> tuple[Mesh, tuple[float, float, float]]:
    """A mesh written by :func:`write_mesh` and the origin its header gives ((0, 0, 0) when none);
    the vertices as written (float32 in PLY, micrometres in OBJ)."""
    suffix = mesh_format(path)
    data = Path(path).read_bytes()
    return _read_ply(path, data) if suffix == ".ply" else _read_obj(data.decode("utf-8"))


def _origin(comments: list[str]) -> tuple[float, float, float]:
    for comment in comments:
        words = comment.split()
        if words[:1] == [ORIGIN_COMMENT]:
            return float(words[1]), float(words[2]), float(words[3])
    return 0.0, 0.0, 0.0


def _read_ply(path: Path, data: bytes) -> tuple[Mesh, tuple[float, float, float]]:
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply") or end < 0:
        raise InputError(f"{path} is not a PLY file.")
    lines = data[:end].decode("ascii").splitlines()
    counts = {words[1]: int(words[2]) for words in map(str.split, lines) if words[:1] == ["element"]}
    properties = tuple(" ".join(line.split()[1:]) for line in lines if line.startswith("property")
                       and " list " not in line)
    if "format binary_little_endian 1.0" not in lines or properties != _PLY_PROPERTIES:
        raise InputError(f"{path} is not a surface mesh written by unerode-cli.")
    offset = end + len(b"end_header\n")
    vertices = np.frombuffer(data, dtype=_VERTEX, count=counts["vertex"], offset=offset)
    faces = np.frombuffer(data, dtype=_FACE, count=counts["face"], offset=offset + vertices.nbytes)
    if np.any(faces["count"] != 3):
        raise InputError(f"{path} has faces that are not triangles.")
    mesh = Mesh(np.column_stack([vertices[a].astype(np.float64) for a in "xyz"]),
                faces["indices"].astype(np.int32),
                vertices["material"].astype(np.int16),
                np.column_stack([vertices[c] for c in ("red", "green", "blue")]))
    return mesh, _origin([line[len("comment "):] for line in lines if line.startswith("comment ")])


def _read_obj(text: str) -> tuple[Mesh, tuple[float, float, float]]:
    lines = text.splitlines()
    vertices = _numbers([line[2:] for line in lines if line.startswith("v ")], 6, np.float64)
    faces = _numbers([line[2:] for line in lines if line.startswith("f ")], 3, np.int64) - 1
    mesh = Mesh(vertices[:, :3], faces.astype(np.int32),
                np.full(len(vertices), UNKNOWN_MATERIAL, dtype=np.int16),
                np.rint(vertices[:, 3:] * 255.0).astype(np.uint8))
    return mesh, _origin([line[1:].strip() for line in lines if line.startswith("#")])


def _numbers(rows: list[str], columns: int, dtype) -> np.ndarray:
    """The numbers of text rows as a (len(rows), columns) array."""
    if not rows:
        return np.zeros((0, columns), dtype=dtype)
    return np.loadtxt(rows, dtype=dtype, ndmin=2)
