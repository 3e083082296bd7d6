"""Particles as binary PLY point clouds (x y z, nx ny nz and named per-particle properties),
the format Houdini and Blender read: little-endian, one ``vertex`` element, float32 and int32
and uint8 properties. Positions are written relative to an origin (float32 keeps ~1e-7 of a
coordinate: centimetres at a UTM easting would be lost), which the header's comments give."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.paths import atomic_path

_PLY_TYPES = {np.dtype("<f4"): "float", np.dtype("<i4"): "int", np.dtype("u1"): "uchar"}
_NUMPY_TYPES = {"float": "<f4", "float32": "<f4", "double": "<f8", "int": "<i4", "int32": "<i4",
                "uchar": "u1", "uint8": "u1"}
ORIGIN_COMMENT = "origin"


def write_particle_ply(path: Path, positions: np.ndarray, normals: np.ndarray,
                       properties: dict[str, np.ndarray],
                       origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
                       comments: tuple[str, ...] = ()) -> None:
    """Write particles atomically: x y z (m, minus ``origin``) and nx ny nz as float32, then each
    of ``properties`` (float arrays as float32, integer arrays as int32, booleans as uchar)."""
    columns: dict[str, np.ndarray] = {}
    for a, name in enumerate("xyz"):
        columns[name] = (positions[:, a] - origin[a]).astype("<f4")
    for a, name in enumerate(("nx", "ny", "nz")):
        columns[name] = normals[:, a].astype("<f4")
    for name, values in properties.items():
        values = np.asarray(values)
        kind = "u1" if values.dtype == bool else "<i4" if np.issubdtype(values.dtype, np.integer) else "<f4"
        columns[name] = values.astype(kind)
    table = np.empty(len(positions), dtype=[(name, values.dtype) for name, values in columns.items()])
    for name, values in columns.items():
        table[name] = values
    header = ["ply", "format binary_little_endian 1.0",
              f"comment {ORIGIN_COMMENT} {origin[0]!r} {origin[1]!r} {origin[2]!r}",
              *(f"comment {c}" for c in comments), f"element vertex {len(table)}",
              *(f"property {_PLY_TYPES[values.dtype]} {name}" for name,
                values in columns.items()), "end_header"]
    with atomic_path(path) as tmp, open(tmp, "wb") as handle:
        handle.write(("\n".join(header) + "\n").encode("ascii"))
        handle.write(table.tobytes())


def read_particle_ply(path: Path) -> tuple[dict[str, np.ndarray], tuple[float, float, float]]:
    """The vertex properties of a binary little-endian PLY by name, and the origin its header
    gives (0, 0, 0 when none); positions are returned as written (relative to the origin)."""
    data = Path(path).read_bytes()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply") or end < 0:
        raise InputError(f"{path} is not a PLY file.")
    lines = data[:end].decode("ascii").splitlines()
    if "format binary_little_endian 1.0" not in lines:
        raise InputError(f"{path} is not a binary little-endian PLY file.")
    count, fields, origin = 0, [], (0.0, 0.0, 0.0)
    for line in lines:
        words = line.split()
        if words[:2] == ["element", "vertex"]:
            count = int(words[2])
        elif words[:1] == ["property"]:
            fields.append((words[2], _NUMPY_TYPES[words[1]]))
        elif words[:2] == ["comment", ORIGIN_COMMENT]:
            origin = (float(words[2]), float(words[3]), float(words[4]))
    table = np.frombuffer(data, dtype=fields, count=count, offset=end + len(b"end_header\n"))
    return {name: table[name].copy() for name, _ in fields}, origin
