"""The surface mesh of a rock of particles: their density (:mod:`~unerode_cli.volume.density`)
meshed at the volume fraction ½ (:mod:`~unerode_cli.volume.mesh`), coloured by material."""

from __future__ import annotations

import numpy as np

from unerode_cli.volume.density import SIGMA, particle_density
from unerode_cli.volume.mesh import Mesh, surface_mesh

#: The rock's boundary: half the volume is rock (a flat face's boundary, see density).
LEVEL = 0.5
#: Taubin iterations by default.
SMOOTHING = 5


def particle_mesh(positions: np.ndarray, materials: np.ndarray, particle_volume: float, h: float,
                  smoothing: int = SMOOTHING, ground: float | None = None, sigma: float = SIGMA) -> Mesh:
    """The closed surface of particles at ``positions`` (N, 3) (m), each ``particle_volume`` m³
    of material ``materials`` (N,) (≥ 0), on a grid of node spacing ``h`` (m; the particle
    spacing is a good choice), with ``smoothing`` Taubin iterations, standing on the ``ground``
    plane (m) when given; an empty mesh without particles."""
    if len(positions) == 0:
        return Mesh.empty()
    density = particle_density(positions, materials, particle_volume, h, sigma, ground)
    return surface_mesh(density.values, density.origin, density.h, LEVEL, density.materials, smoothing,
                        density.ground)
