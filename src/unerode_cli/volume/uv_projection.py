"""Texture coordinates and normals of surface meshes for rendering: area-weighted vertex normals
and a box (triplanar-style) UV projection, so that a tiling rock texture applies to a mesh that
has no parametrisation of its own.

Box projection: each vertex is projected onto the coordinate plane of its normal's dominant axis
(the largest of |nx|, |ny|, |nz|) and its UV is the two remaining coordinates over ``scale``
(m per texture repeat). The signs are chosen so that each face reads the texture unmirrored seen
from outside, with v upwards on the sides (x east, y north, z up):

========  ==========  ======
dominant  u           v
========  ==========  ======
+x        y           z
−x        −y          z
+y        −x          z
−y        x           z
+z        x           y
−z        −x          y
========  ==========  ======

(all over ``scale``). The UVs jump where the dominant axis changes, as any box projection's do.
"""

from __future__ import annotations

import numpy as np

#: Metres per texture repeat of :func:`box_uv` unless told (a rock texture of a 10 m patch).
UV_SCALE = 10.0

# For each dominant axis (0 x, 1 y, 2 z) and sign (0 negative, 1 positive): the coordinate axis of
# u and its sign, the coordinate axis of v (always positive), as in the module's table.
_U_AXIS = np.array([[1, 1], [0, 0], [0, 0]])
_U_SIGN = np.array([[-1.0, 1.0], [1.0, -1.0], [-1.0, 1.0]])
_V_AXIS = np.array([[2, 2], [2, 2], [1, 1]])


def box_uv(vertices: np.ndarray, normals: np.ndarray, scale: float = UV_SCALE) -> np.ndarray:
    """Box-projected texture coordinates float32 (n, 2) of ``vertices`` (n, 3, m) with unit
    ``normals`` (n, 3): the vertex's coordinates in the plane of its normal's dominant axis over
    ``scale`` (m per repeat, > 0), oriented as in the module's table (a vertex of zero normal
    takes +z). Ties of the dominant axis go to the later axis (z before y before x)."""
    if not scale > 0:
        raise ValueError(f"the UV scale is metres per texture repeat, > 0, not {scale}")
    vertices = np.asarray(vertices, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    magnitude = np.abs(normals)
    dominant = 2 - np.argmax(magnitude[:, ::-1], axis=1)   # the last of equal maxima
    positive = (normals[np.arange(len(normals)), dominant] >= 0).astype(np.int64)
    rows = np.arange(len(vertices))
    u = _U_SIGN[dominant, positive] * vertices[rows, _U_AXIS[dominant, positive]]
    v = vertices[rows, _V_AXIS[dominant, positive]]
    return (np.column_stack([u, v]) / scale).astype(np.float32)
