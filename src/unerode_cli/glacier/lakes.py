"""Lakes: water in the depressions of the ice-and-bed surface that ice does not fill (001 §7).

Glaciers over-deepen their beds (001 §7.1, Fig. 7: lakes at the bottom of the main valleys and
perched lakes below the ridges); when the ice is gone, or where it leaves a hollow free, the
hollows hold water up to their spill level. The surface that water sees is s = bed + ice; it
is filled with the exact priority-flood of :mod:`unerode_cli.hydro.depressions` from the
outlets, and the lake depth is filled − s on the cells free of ice. Ice can dam a lake (its
surface is part of the rim), and a depression under the ice holds no lake water (subglacial
water is not modelled).

Units: metres; areas m², volumes m³. Pure functions on arrays, no file I/O.
"""

from __future__ import annotations

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.hydro.depressions import MIN_LAKE_DEPTH, LakeStats, lake_stats, water_depth

__all__ = ["ICE_FREE_BELOW", "MIN_LAKE_DEPTH", "LakeStats", "lake_depth", "lake_stats"]

#: Ice thickness (m) below which a cell counts as free of ice and may hold lake water: thinner
#: ice is a patch of snow or firn, or lake ice, not a glacier that fills the hollow.
ICE_FREE_BELOW = 1.0


def lake_depth(
    bed: np.ndarray,
    ice_thickness: np.ndarray,
    grid: Grid,
    outlets: np.ndarray,
    ice_free_below: float = ICE_FREE_BELOW,
) -> np.ndarray:
    """Depth of the lake water (m) on every cell: float64[ny, nx], 0 where there is no lake.

    The surface s = bed + ice is filled to its spill levels towards ``outlets`` (exact
    priority-flood, Barnes et al. 2014); depth = filled − s where the ice is thinner than
    ``ice_free_below`` (m), 0 under thicker ice and outside ``grid.valid``.

    Args:
        bed: float[ny, nx] bed elevation (m).
        ice_thickness: float[ny, nx] ice thickness (m, ≥ 0); may be non-finite on nodata.
        grid: the grid (its ``valid`` mask excludes nodata).
        outlets: bool[ny, nx] cells where water leaves the domain
            (:func:`unerode_cli.hydro.outlet_mask`: map edges, nodata borders, ...).
        ice_free_below: ice thickness (m) below which a cell may hold water.

    Raises:
        ValueError: shape mismatch, negative or non-finite ice in the domain, no outlet, or
            valid cells that cannot reach an outlet.
    """
    if ice_thickness.shape != grid.shape:
        raise ValueError(f"ice thickness has shape {ice_thickness.shape}, the grid has {grid.shape}")
    ice = np.where(grid.valid, ice_thickness, 0.0).astype(np.float64)
    if not np.isfinite(ice).all():
        raise ValueError("the ice thickness has non-finite values inside the domain (not nodata)")
    if (ice < 0.0).any():
        raise ValueError(f"ice thickness must be ≥ 0 m, got {ice.min():g} m")
    water = water_depth(np.asarray(bed, dtype=np.float64) + ice, grid, outlets)
    return np.where(ice < ice_free_below, water, 0.0)
