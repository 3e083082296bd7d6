"""Whether a heightfield can be the metres of a real terrain, checked before a run that erodes it.

A DEM in other units (centimetres, millimetres, a 0–1 normalised heightfield scaled by 1000) runs
to the end with absurd physics: slopes near 90° everywhere, processes removing kilometres a
step while their summary reports cubic metres. Real terrains stay between the deepest ocean
trench and the highest summit, and few of their cells are cliffs: a run whose DEM has an
elevation outside −11 km … +9 km, or more than a quarter of its cells steeper than 70°, is
refused unless the user says ``--force``. Every real DEM of ``../shared/data`` passes both
(at most 0.85 % of cells steeper than 70°, Patagonia), and each of them in millimetres fails
both (98–100 % of cells steeper than 70°).
"""

from __future__ import annotations

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.terrain import Terrain

#: Elevations (m) no terrain of the Earth reaches: below the Challenger Deep, above Everest.
LOWEST_M, HIGHEST_M = -11_000.0, 9_000.0
#: A cell steeper than this (degrees) is a cliff ...
CLIFF_DEG = 70.0
#: ... and a terrain with more than this share of its cells cliffs is not in metres.
MOST_CLIFFS = 0.25
#: Rows of the heightfield whose slopes are taken at once (bounds the memory of the check).
ROWS_AT_ONCE = 512


def implausible(terrain: Terrain) -> str:
    """Why ``terrain`` cannot be metres of a real terrain ('' when it can): an elevation beyond
    the Earth's, or more than ``MOST_CLIFFS`` of the cells steeper than ``CLIFF_DEG``."""
    finite = np.isfinite(terrain.elevation)
    if not finite.any():
        return ""
    low = float(np.min(terrain.elevation, where=finite, initial=np.inf))
    high = float(np.max(terrain.elevation, where=finite, initial=-np.inf))
    del finite
    if low < LOWEST_M or high > HIGHEST_M:
        return (f"its elevations reach {low:.6g} … {high:.6g} m, beyond the Earth's "
                f"{LOWEST_M:.0f} … +{HIGHEST_M:.0f} m")
    share = cliff_share(terrain.elevation, terrain.dx, terrain.dy)
    if share > MOST_CLIFFS:
        return (f"{100.0 * share:.0f} % of its cells are steeper than {CLIFF_DEG:.0f}° (over its "
                f"{terrain.dx:.4g} × {terrain.dy:.4g} m cells), where real DEMs have under 1 % "
                "so steep")
    return ""


def cliff_share(z: np.ndarray, dx: float, dy: float) -> float:
    """The share of the cells of ``z`` (m, NaN: nodata) whose slope is steeper than
    ``CLIFF_DEG``, over the cells whose slope is defined: the central-difference gradient
    (one-sided at the grid's edges) on cells of ``dx`` × ``dy`` metres, where the cell and the
    neighbours it takes are valid. 0 when no slope is defined (a grid one cell wide)."""
    ny, nx = z.shape
    if ny < 2 or nx < 2:
        return 0.0
    limit = np.tan(np.radians(CLIFF_DEG)) ** 2
    cliffs = defined = 0
    for top in range(0, ny, ROWS_AT_ONCE):
        first, last = max(top - 1, 0), min(top + ROWS_AT_ONCE + 1, ny)
        block = z[first:last].astype(np.float64)      # ≥ 2 rows: the block's own and a halo
        gy, gx = np.gradient(block, dy, dx)
        rows = slice(top - first, top - first + min(ROWS_AT_ONCE, ny - top))
        squared = gx[rows] ** 2 + gy[rows] ** 2
        finite = np.isfinite(squared) & np.isfinite(block[rows])
        defined += int(finite.sum())
        cliffs += int((squared[finite] > limit).sum())
    return cliffs / defined if defined else 0.0


def check_metres(terrain: Terrain, source: object, force: bool) -> None:
    """Refuse (InputError) a terrain that :func:`implausible` finds is not in metres, naming
    ``convert --z-scale``, unless ``force``."""
    if force:
        return
    why = implausible(terrain)
    if why:
        raise InputError(f"{source} does not look like elevations in metres: {why}; rescale it with "
                         f"'unerode-cli convert {source} OUT.tif --z-scale FACTOR' (e.g. 0.001 for "
                         "millimetres), or pass --force to run it as it is.")
