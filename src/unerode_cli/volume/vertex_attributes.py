"""Particle properties carried onto the vertices of their surface mesh: each vertex takes the
values of its nearest particle (Euclidean distance, ties to the lower particle index), so a
mesh can be shaded by stress or viability in a DCC as the particles are."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def nearest_particle(vertices: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """The index (int64, (n,)) of the particle at ``positions`` (N, 3) (m) nearest to each of
    ``vertices`` (n, 3) (m); empty when there are no vertices. Needs at least one particle."""
    if len(vertices) == 0:
        return np.zeros(0, dtype=np.int64)
    if len(positions) == 0:
        raise ValueError("there is no particle to take vertex values from")
    _, index = cKDTree(np.asarray(positions, dtype=np.float64)).query(np.asarray(vertices, dtype=np.float64))
    return np.asarray(index, dtype=np.int64)


def vertex_values(vertices: np.ndarray, positions: np.ndarray,
                  values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Each of ``values`` (name → (N,) per particle) at the ``vertices`` (n, 3): the value of the
    nearest particle, as float32 (n,)."""
    index = nearest_particle(vertices, positions)
    return {name: np.asarray(array)[index].astype(np.float32) for name, array in values.items()}
