"""The elevation an erode/unerode run steps, and the start it keeps, in as few bytes as hold it.

A run needs the DEM it started from for its whole length: the divergence guard measures each
step's elevation against it, and the change map and the statistics written at the end are the
final elevation less it. Kept as the float64 grid it was read into, it costs 8 bytes a cell
beside the 8 of the elevation being stepped. Every float32 or integer DEM up to 2^24 in
magnitude reads into float64 values that float32 holds exactly: the start is then kept in
float32 (4 bytes a cell, its values unchanged), and the float64 grid read becomes the run's
elevation itself, not a copy. A DEM whose values float32 does not hold (float64 files) keeps
its float64 start and the run steps a copy.
"""

from __future__ import annotations

import numba
import numpy as np

from unerode_cli.io.terrain import Terrain
from unerode_cli.run.divergence import DivergenceGuard


def take_elevation(terrain: Terrain, guard: DivergenceGuard) -> np.ndarray:
    """The float64[ny, nx] elevation (m) a run steps in place, made from ``terrain``'s.

    Where float32 holds every value of ``terrain.elevation`` exactly (NaN on nodata included),
    the terrain and ``guard`` are left holding that float32 start (the same values: the
    change final − start and the guard's measure are those of the float64 start to the bit)
    and the float64 grid read is handed to the run; else the run gets a float64 copy and the
    terrain keeps its grid. ``guard`` (made on ``terrain.elevation``) reads the domain from
    ``terrain.grid.valid``, the mask it equals, rather than its own."""
    start = terrain.elevation
    with np.errstate(over="ignore"):  # values beyond float32 become ±inf and are not held
        compact = start.astype(np.float32)
    if not (start.dtype == np.float64 and start.flags.c_contiguous and _held(compact.ravel(), start.ravel())):
        guard.share(guard.reference, terrain.grid.valid)
        return np.array(start, dtype=np.float64, copy=True)
    terrain.elevation = compact
    guard.share(compact, terrain.grid.valid)
    return start


@numba.njit(cache=True)
def _held(narrow, wide):
    """Whether every value of ``wide`` (float64) equals its float32 ``narrow`` (NaN: NaN)."""
    for i in range(wide.size):
        value = wide[i]
        if np.float64(narrow[i]) != value and not (np.isnan(value) and np.isnan(narrow[i])):
            return False
    return True
