"""Voxel volumes as ``.npz`` files (NumPy's zip of arrays), read and written for
``particle-erode --voxels`` / ``--volume-out``.

Format (arrays indexed [i, j, k] along x east, y north, z up; voxel (i, j, k) spans
``origin + voxel_size·(i, j, k)`` to ``origin + voxel_size·(i + 1, j + 1, k + 1)``):

- ``origin``: float[3], the south-west bottom corner of the volume (x, y, z; m, in the CRS
  when ``crs`` is given: a projected CRS in metres). Required.
- ``voxel_size``: float, or float[3] (dx, dy, dz), in m. Required.
- either ``density``: float[nx, ny, nz] in [−1, 1] (003 §4.4 density voxels: 1 full, −1 empty,
  the ground surface at 0), or ``solid``: bool[nx, ny, nz] (binary voxels) with optional
  ``hits``: int[nx, ny, nz] (the hit counts of 003 Eq. 14; 0 when absent).
- optional ``material``: int[nx, ny, nz] ≥ 0, a material index per voxel, and
  ``material_names``: str[n], the name of each index (matched to ``--materials`` by name).
- optional ``valid``: bool[nx, ny], the columns inside the domain (all when absent).
- optional ``crs``: str, the CRS as WKT.

Anything else in the file is an error (a misspelt array would otherwise be ignored).

3D material layers (``--materials`` as YAML): the materials, with the columns of the CSV
materials table (``io.material_files``) as keys, horizontal horizons by elevation, and the
material rules of voxel terrains::

    materials:                       # K_ε (Pa^-a) and τ_c (Pa) of 003 Eq. 2
      limestone: {erodibility: 5.0, critical_stress: 0}
      marl: {erodibility: 0.5, critical_stress: 2}
      sand: {erodibility: 8.0}       # critical_stress 0 when absent
    horizons:                        # bottom first: a material up to the elevation `top` (m)
      - {material: marl, top: 120}
      - {material: limestone}        # the last one goes on up
    deposit: sand                    # optional: what deposits become (default: the top horizon's)
    eroded: {marl: sand}             # optional: what a material becomes when eroded (003 §7)

``horizons`` is needed to build a block from a DEM; a voxel file brings its own material index
(matched to the materials by ``material_names``, else by their order).
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.paths import atomic_path
from unerode_cli.io.yaml_files import read_yaml_mapping
from unerode_cli.particles.terrain import Material
from unerode_cli.volume.voxels import BinaryVoxels, DensityVoxels, VoxelGeometry, grid_to_xyz, xyz_to_grid

VOXEL_SUFFIX = ".npz"
_ARRAYS = {"origin", "voxel_size", "density", "solid", "hits", "material", "material_names", "valid", "crs"}


@dataclass(frozen=True)
class VoxelFile:
    """A volume read from a file: the grid (``volume.voxels`` layout), the CRS WKT ("" when
    none) and the material names (empty when none)."""

    voxels: DensityVoxels | BinaryVoxels
    crs_wkt: str
    material_names: tuple[str, ...]

    @property
    def representation(self) -> str:
        return "density" if isinstance(self.voxels, DensityVoxels) else "binary"


def _members(path: Path) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Shape and dtype of each array of an ``.npz`` file, read from the headers only."""
    try:
        with zipfile.ZipFile(path) as archive:
            found = {}
            for info in archive.infolist():
                if not info.filename.endswith(".npy"):
                    raise InputError(f"the voxel file {path} holds '{info.filename}', which is not a "
                                     "NumPy array.")
                with archive.open(info) as handle:
                    version = np.lib.format.read_magic(handle)
                    read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                                   else np.lib.format.read_array_header_2_0)
                    shape, _, dtype = read_header(handle)
                found[info.filename[:-4]] = (tuple(shape), dtype)
            return found
    except (zipfile.BadZipFile, ValueError, OSError) as exc:
        if isinstance(exc, FileNotFoundError):
            raise InputError(f"the voxel file {path} does not exist.") from None
        raise InputError(f"the voxel file {path} is not a NumPy .npz archive.") from None


def voxel_file_layout(path: Path) -> tuple[tuple[int, int, int], str, bool]:
    """(shape (nx, ny, nz), "density" or "binary", has a material index) of a voxel file, from
    its headers (nothing is loaded): what a memory estimate needs before reading it.

    Raises:
        InputError: not an .npz file, an unknown array, no origin or voxel size, neither or
            both of density and solid, or arrays of different shapes.
    """
    members = _members(path)
    unknown = sorted(set(members) - _ARRAYS)
    if unknown:
        raise InputError(f"the voxel file {path} has unknown array(s) {', '.join(unknown)}; "
                         f"known: {', '.join(sorted(_ARRAYS))}.")
    missing = [name for name in ("origin", "voxel_size") if name not in members]
    if missing:
        raise InputError(f"the voxel file {path} has no {' and no '.join(missing)}: it needs the origin "
                         "(x, y, z of its south-west bottom corner, m) and the voxel size (m).")
    kinds = [name for name in ("density", "solid") if name in members]
    if len(kinds) != 1:
        raise InputError(f"the voxel file {path} needs exactly one of 'density' (density voxels) and "
                         "'solid' (binary voxels).")
    shape = members[kinds[0]][0]
    if len(shape) != 3 or min(shape) < 1:
        raise InputError(f"the voxel file {path} has a {kinds[0]} array of shape {shape}; it needs 3 axes "
                         "(x, y, z) of at least one voxel.")
    for name in ("hits", "material"):
        if name in members and members[name][0] != shape:
            raise InputError(f"the voxel file {path} has '{name}' of shape {members[name][0]}, "
                             f"'{kinds[0]}' of shape {shape}.")
    if "valid" in members and members["valid"][0] != shape[:2]:
        raise InputError(f"the voxel file {path} has 'valid' of shape {members['valid'][0]}, "
                         f"it needs {shape[:2]} (x, y).")
    return shape, "density" if kinds[0] == "density" else "binary", "material" in members


def _vector(values: np.ndarray, count: tuple[int, ...], what: str, path: Path) -> tuple[float, ...]:
    arr = np.asarray(values, dtype=np.float64).reshape(-1)
    if arr.size not in count or not np.isfinite(arr).all():
        raise InputError(f"the voxel file {path} has a bad {what}: it needs {' or '.join(map(str, count))} "
                         "finite number(s).")
    return tuple(float(v) for v in arr)


def read_voxels(path: Path) -> VoxelFile:
    """The volume of a voxel file (module docstring).

    Raises:
        InputError: one sentence for a file that does not follow the format.
    """
    (nx, ny, nz), kind, _ = voxel_file_layout(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except (ValueError, OSError) as exc:
        raise InputError(f"cannot read the voxel file {path}: {exc}.") from None
    origin = _vector(arrays["origin"], (3,), "origin (x, y, z of its south-west bottom corner)", path)
    size = _vector(arrays["voxel_size"], (1, 3), "voxel size", path)
    size = size * 3 if len(size) == 1 else size
    crs = str(arrays["crs"]) if "crs" in arrays else ""
    names = tuple(str(n) for n in arrays.get("material_names", np.array([], dtype=str)).reshape(-1))
    try:
        geometry = VoxelGeometry((origin[0], origin[1] + ny * size[1], origin[2]), size, (ny, nx, nz))
        material = xyz_to_grid(arrays["material"]) if "material" in arrays else None
        valid = xyz_to_grid(arrays["valid"].astype(bool)) if "valid" in arrays else None
        if kind == "density":
            voxels: DensityVoxels | BinaryVoxels = DensityVoxels(geometry, xyz_to_grid(arrays["density"]),
                                                                 material, valid)
        else:
            hits = xyz_to_grid(arrays["hits"]) if "hits" in arrays else None
            voxels = BinaryVoxels(geometry, xyz_to_grid(arrays["solid"].astype(bool)), hits, material, valid)
    except ValueError as exc:
        raise InputError(f"the voxel file {path} is invalid: {str(exc).rstrip('.')}.") from None
    if names and voxels.material is not None and int(voxels.material.max()) >= len(names):
        raise InputError(f"the voxel file {path} names {len(names)} material(s) but uses index "
                         f"{int(voxels.material.max())}.")
    return VoxelFile(voxels, crs, names)


def write_voxels(path: Path, volume: VoxelFile) -> None:
    """Write a volume atomically in the format of the module docstring (float32 densities)."""
    voxels = volume.voxels
    geometry = voxels.geometry
    x0, y_north, z0 = geometry.origin
    arrays: dict[str, np.ndarray] = {
        "origin": np.array([x0, y_north - geometry.shape[0] * geometry.size[1], z0]),
        "voxel_size": np.array(geometry.size),
        "valid": grid_to_xyz(voxels.valid),
    }
    if isinstance(voxels, DensityVoxels):
        arrays["density"] = grid_to_xyz(voxels.density).astype(np.float32)
    else:
        arrays["solid"] = grid_to_xyz(voxels.solid)
        arrays["hits"] = grid_to_xyz(voxels.hits)
    if voxels.material is not None:
        arrays["material"] = grid_to_xyz(voxels.material)
    if volume.material_names:
        arrays["material_names"] = np.array(volume.material_names)
    if volume.crs_wkt:
        arrays["crs"] = np.array(volume.crs_wkt)
    with atomic_path(path) as tmp, open(tmp, "wb") as handle:
        np.savez_compressed(handle, **arrays)


@dataclass(frozen=True)
class MaterialLayers:
    """3D material layers of a YAML file: ``materials`` in file order, the horizons' ``tops``
    (m, increasing, the last inf) and material ``horizon_materials`` (indices), the
    ``deposit`` material index (None: not given) and the ``eroded`` rules (index → index)."""

    materials: tuple[Material, ...]
    tops: tuple[float, ...]
    horizon_materials: tuple[int, ...]
    deposit: int | None
    eroded: dict[int, int]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.materials)


def _number(value: object, what: str, path: Path) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
        raise InputError(f"the materials file {path}: {what} must be a finite number, got {value!r}.")
    return float(value)


def read_material_layers(path: Path) -> MaterialLayers:
    """The 3D material layers of a YAML file (module docstring).

    Raises:
        InputError: one sentence naming the file for an unreadable file, an unknown key, a
            material without erodibility or with a negative value, a horizon naming an unknown
            material, tops that do not increase, or a rule naming an unknown material.
    """
    doc = read_yaml_mapping(path, "the materials file", "a mapping (materials, horizons, deposit, eroded)",
                            allow_empty=False)
    unknown = sorted(set(doc) - {"materials", "horizons", "deposit", "eroded"})
    if unknown:
        raise InputError(f"the materials file {path} has unknown key(s) {', '.join(map(str, unknown))}; "
                         "known: materials, horizons, deposit, eroded.")
    table = doc.get("materials")
    if not isinstance(table, dict) or not table:
        raise InputError(f"the materials file {path} needs 'materials': a mapping of names to "
                         "{erodibility, critical_stress}.")
    materials = []
    for name, entry in table.items():
        if not isinstance(entry, dict) or "erodibility" not in entry or set(entry) - {"erodibility",
                                                                                    "critical_stress",
                                                                                    "description"}:
            raise InputError(f"the materials file {path}: material '{name}' needs 'erodibility' (and "
                             "optionally 'critical_stress', 'description').")
        k_eps = _number(entry["erodibility"], f"the erodibility of '{name}'", path)
        tau_c = _number(entry.get("critical_stress", 0.0), f"the critical stress of '{name}'", path)
        try:
            materials.append(Material(str(name), k_eps, tau_c))
        except ValueError as exc:
            raise InputError(f"the materials file {path}: {str(exc).rstrip('.')}.") from None
    names = [m.name for m in materials]

    def index(name: object, what: str) -> int:
        if str(name) not in names:
            raise InputError(f"the materials file {path}: {what} names '{name}', which is not one of its "
                             f"materials ({', '.join(names)}).")
        return names.index(str(name))

    horizons = doc.get("horizons", [])
    if not isinstance(horizons, list) or not all(isinstance(h, dict) and "material" in h for h in horizons):
        raise InputError(f"the materials file {path}: 'horizons' must be a list of {{material, top}}, "
                         "bottom first.")
    tops = []
    for i, horizon in enumerate(horizons):
        last = i == len(horizons) - 1
        if set(horizon) - {"material", "top"} or ("top" not in horizon and not last):
            raise InputError(f"the materials file {path}: horizon {i + 1} needs 'material' and 'top' "
                             "(only the last may leave out its top).")
        tops.append(_number(horizon["top"], f"the top of horizon {i + 1}", path) if "top" in horizon
                    else float("inf"))
    if any(b <= a for a, b in zip(tops, tops[1:], strict=False)):
        raise InputError(f"the materials file {path}: the horizons' tops must increase upwards "
                         "(bottom first).")
    if tops:
        tops[-1] = float("inf")
    eroded = doc.get("eroded", {})
    if not isinstance(eroded, dict):
        raise InputError(f"the materials file {path}: 'eroded' must map material names to material names.")
    return MaterialLayers(
        tuple(materials), tuple(tops), tuple(index(h["material"], "a horizon") for h in horizons),
        None if doc.get("deposit") is None else index(doc["deposit"], "'deposit'"),
        {index(a, "'eroded'"): index(b, "'eroded'") for a, b in eroded.items()},
    )
