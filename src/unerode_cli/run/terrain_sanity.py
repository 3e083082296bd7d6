"""Whether a heightfield can be the metres of a real terrain, checked before a run that erodes it.

A DEM in other units (centimetres, millimetres, a 0–1 normalised heightfield scaled by 1000) runs
to the end with absurd physics: slopes near 90° everywhere, processes removing kilometres a
step while their summary reports cubic metres. Real terrains stay between the deepest ocean
trench and the highest summit; a run whose DEM has an elevation outside −11 km … +9 km is
refused unless the user says ``--force``. Every real DEM of ``../shared/data`` lies within it,
and each of them in millimetres lies far outside it.
"""

from __future__ import annotations

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.terrain import Terrain

#: Elevations (m) no terrain of the Earth reaches: below the Challenger Deep, above Everest.
LOWEST_M, HIGHEST_M = -11_000.0, 9_000.0


def implausible(terrain: Terrain) -> str:
    """Why ``terrain`` cannot be metres of a real terrain ('' when it can)."""
    valid = terrain.elevation[np.isfinite(terrain.elevation)]
    if valid.size == 0:
        return ""
    low, high = float(valid.min()), float(valid.max())
    if low < LOWEST_M or high > HIGHEST_M:
        return (f"its elevations reach {low:.6g} … {high:.6g} m, beyond the Earth's "
                f"{LOWEST_M:.0f} … +{HIGHEST_M:.0f} m")
    return ""


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
