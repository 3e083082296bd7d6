"""The surface mesh of a rock of particles: their field (:mod:`~unerode_cli.volume.density`:
the blurred volume fraction, with the presence in thin features) meshed at the level ½
(:mod:`~unerode_cli.volume.mesh`) on a grid of any cell, coloured by material."""

from __future__ import annotations

import numpy as np

from unerode_cli.volume.density import MAX_BYTES, SIGMA, particle_density
from unerode_cli.volume.mesh import Mesh, surface_mesh

#: The rock's boundary: half the volume is rock (a flat face's boundary, see density).
LEVEL = 0.5
#: Taubin iterations by default.
SMOOTHING = 5


def particle_mesh(positions: np.ndarray, materials: np.ndarray, particle_volume: float,
                  cell: float | None = None, smoothing: int = SMOOTHING, ground: float | None = None,
                  sigma: float = SIGMA, max_bytes: float = MAX_BYTES, spacing: float | None = None) -> Mesh:
    """The closed surface of particles at ``positions`` (N, 3) (m), each ``particle_volume`` m³
    (a lattice cell of spacing s: ``spacing``, or particle_volume^(1/3) when None) of material
    ``materials`` (N,) (≥ 0), on a grid of node spacing ``cell`` (m; None: s), blurred by
    ``sigma`` particle spacings, with ``smoothing`` Taubin iterations, standing on the ``ground``
    plane (m) when given; an empty mesh without particles. A finer cell samples the same
    surface more finely (about (s/cell)² times the vertices); sheets and rods one particle thick
    keep about that thickness at cells up to s, features one cell thick survive at any cell.
    Raises ValueError when the field would need more than ``max_bytes`` bytes
    (:func:`~unerode_cli.volume.density.density_bytes`)."""
    if len(positions) == 0:
        return Mesh.empty()
    density = particle_density(positions, materials, particle_volume, cell, sigma, ground, max_bytes,
                               spacing)
    return surface_mesh(density.values, density.origin, density.h, LEVEL, density.materials, smoothing,
                        density.ground)
