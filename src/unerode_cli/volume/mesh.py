"""Surface meshes of voxel densities: marching cubes (Lewiner et al. 2003, by scikit-image) at a
density level, optional Taubin smoothing, per-vertex materials and colours, and the enclosed
volume by the divergence theorem. 002 (§3, Alg. 1) ends by meshing its particles for rendering;
:mod:`~unerode_cli.volume.density` says how particles become the density meshed here.

A mesh from a grid whose outer nodes are below the level is closed (watertight): each edge is
shared by exactly two faces, which are ordered counter-clockwise seen from outside. With a
``ground`` altitude, the grid's node layer below the ground is empty and the vertices between it
and the ground are moved onto the ground plane: the ground closes the mesh with flat faces, as
the rock stands on it. scikit-image is an optional dependency (the ``mesh`` extra), imported
only here and only when a mesh is made.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.volume.smoothing import taubin_smooth

#: One colour per material (layer) index, cycling: matplotlib's ``tab10``, the colours of the
#: layers in the particle previews (uint8 RGB).
PALETTE = np.array([[31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189],
                    [140, 86, 75], [227, 119, 194], [127, 127, 127], [188, 189, 34], [23, 190, 207]],
                   dtype=np.uint8)
INSTALL_HINT = "pip install 'unerode-cli[mesh]'"


class MeshExtraMissing(ImportError):
    """scikit-image, which surface meshes need, is not installed."""

    def __init__(self) -> None:
        super().__init__(f"surface meshes need scikit-image, which is not installed: {INSTALL_HINT}")


def marching_cubes_function():
    """scikit-image's ``marching_cubes``, or :class:`MeshExtraMissing` when it is absent."""
    try:
        from skimage.measure import marching_cubes
    except ImportError:
        raise MeshExtraMissing() from None
    return marching_cubes


@dataclass(frozen=True)
class Mesh:
    """A triangle mesh: ``vertices`` float64 (n, 3) in m, ``faces`` int32 (m, 3) vertex indices
    counter-clockwise seen from outside, per-vertex ``materials`` int16 (n,) and ``colours``
    uint8 (n, 3) RGB."""

    vertices: np.ndarray
    faces: np.ndarray
    materials: np.ndarray
    colours: np.ndarray

    @classmethod
    def empty(cls) -> Mesh:
        return cls(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int32), np.zeros(0, dtype=np.int16),
                   np.zeros((0, 3), dtype=np.uint8))


def linear_colours(colours: np.ndarray) -> np.ndarray:
    """sRGB colours uint8 (..., 3) as the linear RGB in [0, 1] that material colours are given in
    (glTF's baseColorFactor, an MTL's Kd as Blender reads it): the sRGB transfer function inverted
    (IEC 61966-2-1), float64."""
    c = np.asarray(colours, dtype=np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def material_colours(materials: np.ndarray) -> np.ndarray:
    """The :data:`PALETTE` colour (uint8 RGB) of each material index (≥ 0)."""
    return PALETTE[np.asarray(materials) % len(PALETTE)]


def surface_mesh(density: np.ndarray, origin: tuple[float, float, float], h: float, level: float = 0.5,
                 materials: np.ndarray | None = None, smoothing: int = 0,
                 ground: float | None = None) -> Mesh:
    """The surface where ``density`` (nx, ny, nz), sampled at the nodes ``origin + h·(i, j, k)``
    (m), crosses ``level``, enclosing the values above it; an empty mesh when none does.

    ``materials`` (nx, ny, nz) gives each vertex the material of its nearest node (0 without);
    ``smoothing`` Taubin iterations (:func:`~unerode_cli.volume.smoothing.taubin_smooth`);
    ``ground`` (m, a node layer of the grid, with the layer below it empty): the vertices below
    it are moved onto it and stay on it while smoothing (see the module's text)."""
    marching_cubes = marching_cubes_function()
    if density.size == 0 or not density.max() > level:
        return Mesh.empty()
    index, faces, _, _ = marching_cubes(density, level)
    index = index.astype(np.float64)
    faces = np.ascontiguousarray(faces[:, ::-1], dtype=np.int32)  # outward: values above level inside
    if materials is None:
        vertex_materials = np.zeros(len(index), dtype=np.int16)
    else:
        nearest = np.clip(np.rint(index).astype(np.int64), 0, np.asarray(density.shape) - 1)
        vertex_materials = materials[nearest[:, 0], nearest[:, 1], nearest[:, 2]].astype(np.int16)
    on_ground = None
    if ground is not None:
        ground_index = round((ground - origin[2]) / h)
        on_ground = index[:, 2] <= ground_index
        index[on_ground, 2] = ground_index
    vertices = np.asarray(origin, dtype=np.float64) + h * index
    if ground is not None:
        vertices[on_ground, 2] = ground
    if smoothing:
        vertices = taubin_smooth(vertices, faces, smoothing, on_ground)
    return Mesh(vertices, faces, vertex_materials, material_colours(vertex_materials))


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit outward normals float64 (n, 3) of a mesh's ``vertices`` (n, 3): the sum of the
    normals of the ``faces`` (m, 3, counter-clockwise seen from outside) around each vertex,
    weighted by their areas (the cross product of two edges is twice the area along the
    normal); 0 for a vertex of no face or whose faces cancel."""
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    summed = np.zeros((len(vertices), 3))
    if len(faces):
        a, b, c = (vertices[faces[:, i]] for i in range(3))
        face = np.cross(b - a, c - a)
        index = faces.ravel()
        for axis in range(3):
            summed[:, axis] = np.bincount(index, np.repeat(face[:, axis], 3), minlength=len(vertices))
    length = np.linalg.norm(summed, axis=1, keepdims=True)
    return np.divide(summed, length, out=np.zeros_like(summed), where=length > 0)


def enclosed_volume(mesh: Mesh) -> float:
    """The volume (m³) a closed mesh encloses, by the divergence theorem: the sum over faces of
    the signed tetrahedra (v₀ · (v₁ × v₂))/6, with the vertices taken from their centroid (for
    precision far from the origin). Positive when the faces turn counter-clockwise outside."""
    if len(mesh.faces) == 0:
        return 0.0
    v = mesh.vertices - mesh.vertices.mean(axis=0)
    a, b, c = v[mesh.faces[:, 0]], v[mesh.faces[:, 1]], v[mesh.faces[:, 2]]
    return float(np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0)
