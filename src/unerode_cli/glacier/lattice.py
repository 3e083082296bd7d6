"""The terrain-following lattice of the Blatter–Pattyn ice flow (001 §4.2, Fig. 4).

Nodes: the DEM's pixels horizontally (the basal grid "aligns exactly ... with the bedrock
elevation and ice thickness maps"), N + 1 levels vertically from the bed b (level 0) to the
surface s = b + H (level N), so N layers of lattice cells. Layers are evenly spaced (H/N)
where H ≥ N·dz_min; in thinner ice the layers keep the minimum spacing dz_min from the bed up
and the upper ones collapse to zero thickness (001 §4.2):

    ζ_k = b + k·H/N                 if H ≥ N·dz_min
    ζ_k = b + min(k·dz_min, H)      otherwise.

Velocities on the collapsed levels of a column equal the velocity of the highest level that
is not collapsed (001: "we set the velocities stored at the endpoints of the vertical edge to
be equal"); this is done by giving them the same degree of freedom (``dof_map``).

The elevations and the degrees of freedom are built by numba kernels (``lattice_kernels``,
imported when first used), one pass over the nodes each.
"""

from __future__ import annotations

import numpy as np


def layer_elevations(bed: np.ndarray, thickness: np.ndarray, n_layers: int, dz_min: float) -> np.ndarray:
    """Elevations ζ of the lattice nodes (m), float64[N + 1, ny, nx] (001 §4.2).

    Args:
        bed: float[ny, nx] bed elevation b (m).
        thickness: float[ny, nx] ice thickness H ≥ 0 (m).
        n_layers: N ≥ 1, the number of layers of cells.
        dz_min: minimum layer spacing (m) > 0; thinner ice (H < N·dz_min) gets layers of
            dz_min from the bed up, the upper ones collapsed.

    Returns:
        ζ with ζ[0] = b and ζ[N] = b + H.
    """
    if n_layers < 1 or not dz_min > 0:
        raise ValueError(f"need n_layers ≥ 1 and dz_min > 0 m, got {n_layers} and {dz_min}")
    b = np.asarray(bed, dtype=np.float64)
    h = np.asarray(thickness, dtype=np.float64)
    if np.any(h < 0):
        raise ValueError("the ice thickness must be ≥ 0")
    if b.shape != h.shape or b.ndim != 2:
        raise ValueError(f"bed and thickness must be 2-D of one shape, got {b.shape} and {h.shape}")
    from unerode_cli.glacier import lattice_kernels

    # contiguous: the strided samples of the multigrid's coarse levels take the same compiled kernel
    return lattice_kernels.layer_elevations(np.ascontiguousarray(b), np.ascontiguousarray(h),
                                            int(n_layers), float(dz_min))


def ice_columns_with_halo(thickness: np.ndarray, periodic: bool) -> np.ndarray:
    """bool[ny, nx]: columns with ice (H > 0) and their 8 neighbours (wrapping if periodic).

    These are exactly the columns whose nodes are corners of at least one lattice cell of
    positive volume: the unknowns of the flow problem.
    """
    ice = np.asarray(thickness) > 0
    if periodic:
        out = ice.copy()
        for dj in (-1, 0, 1):
            for di in (-1, 0, 1):
                out |= np.roll(ice, (dj, di), axis=(0, 1))
        return out
    padded = np.pad(ice, 1)
    ny, nx = ice.shape
    out = np.zeros_like(ice)
    for dj in (0, 1, 2):
        for di in (0, 1, 2):
            out |= padded[dj:dj + ny, di:di + nx]
    return out


def dof_map(zeta: np.ndarray, active: np.ndarray, frozen: np.ndarray) -> tuple[np.ndarray, int]:
    """Index of the degree of freedom of every lattice node, −1 for a node held at zero.

    Args:
        zeta: float[N + 1, ny, nx] node elevations (``layer_elevations``).
        active: bool[ny, nx] columns that carry unknowns (``ice_columns_with_halo``).
        frozen: bool[ny, nx] frozen bed (C = ∞): the basal node is held at zero velocity.

    Returns:
        (dof int64[N + 1, ny, nx], number of degrees of freedom). Nodes above the last
        non-collapsed level m of a column share the degree of freedom of level m.
    """
    from unerode_cli.glacier import lattice_kernels

    dof, count = lattice_kernels.dof_map(np.ascontiguousarray(zeta, dtype=np.float64),
                                         np.asarray(active, dtype=np.bool_),
                                         np.asarray(frozen, dtype=np.bool_))
    return dof, int(count)
