"""Taubin's λ|μ smoothing of a triangle mesh (Taubin 1995, "A signal processing approach to fair
surface design"): a Laplacian step of weight λ > 0, which smooths and shrinks, then one of weight
μ < −λ, which inflates back, so that the mesh loses the staircase of marching cubes without the
shrinking of plain Laplacian smoothing. The Laplacian is the umbrella operator (the mean of a
vertex's neighbours minus the vertex) from a sparse adjacency matrix of the mesh's edges.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse

#: Taubin's weights: pass band k_PB = 1/λ + 1/μ ≈ 0.11 (Taubin 1995 recommends 0.01–0.1 … 0.2).
LAMBDA = 0.5
MU = -0.53


def umbrella_operator(faces: np.ndarray, count: int) -> sparse.csr_matrix:
    """The sparse (count, count) matrix that averages each vertex's edge neighbours (its rows sum
    to 1; a vertex in no face averages to 0)."""
    pairs = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]).astype(np.int64)
    rows = np.concatenate([pairs[:, 0], pairs[:, 1]])
    cols = np.concatenate([pairs[:, 1], pairs[:, 0]])
    adjacency = sparse.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(count, count))
    adjacency.data[:] = 1.0  # an edge of two faces was counted twice
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    return sparse.diags(np.divide(1.0, degree, out=np.zeros(count), where=degree > 0)) @ adjacency


def taubin_smooth(vertices: np.ndarray, faces: np.ndarray, iterations: int,
                  fixed_z: np.ndarray | None = None) -> np.ndarray:
    """``vertices`` (n, 3) (m) after ``iterations`` λ|μ passes; the vertices where ``fixed_z``
    (bool, n) is True keep their z (they slide on a horizontal plane, e.g. the ground)."""
    average = umbrella_operator(faces, len(vertices))
    v = np.array(vertices, dtype=np.float64)
    held = None if fixed_z is None else v[fixed_z, 2].copy()
    for _ in range(iterations):
        for weight in (LAMBDA, MU):
            v += weight * (average @ v - v)
            if held is not None:
                v[fixed_z, 2] = held
    return v
