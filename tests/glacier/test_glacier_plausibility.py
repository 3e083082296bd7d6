"""Plausibility of the default glacier physics on a real alpine DEM.

A 64 × 64 window (2.9 km square, 46 m cells) of the Grindelwald DEM (../shared/data), the upper
basin of a glacier in the Wetterhorn–Schreckhorn area, under an ELA of 2900 m (about today's)
for 2000 years with the default parameters (Blatter–Pattyn, C = 2e4 Pa·(y/m)^½, 001 Table 1
mass balance and erosion), steps of 50 y (001 §5: 10–100 y). Measured glaciers (Cuffey &
Paterson 2010) and glacial erosion (Hallet et al. 1996; Herman et al. 2015) bound it:

- median surface speed of the ice thicker than 20 m in 5–200 m/y, 99th percentile < 1000 m/y;
- bed erosion averaged over the ice-covered cells in 0.05–10 mm/y, no cell faster than 0.1 m/y;
- the ice stays in the valleys: ≥ 90 % of the ice thicker than 50 m on bed slopes below 30°.

Measured (70 s): 74 % of the window under ice, median 17 m/y, 99th percentile 47 m/y, erosion
0.46 mm/y on average and 1.2 mm/y at most, 97 % of the thick ice on slopes below 30°. With
the former default C = 1000 the ice slid at km/y within 20 years and the bed lost metres of
rock per year. Slow: ``pytest -m slow``.
"""

from __future__ import annotations

import numpy as np
import pytest
from tests.conftest import SHARED_DATA

from unerode_cli.glacier import coupled
from unerode_cli.io.rasters import read_terrain

GRINDELWALD = SHARED_DATA / "dem" / "alps_grindelwald" / "dem.tif"
WINDOW = (slice(200, 264), slice(250, 314))


def plausibility(bed0: np.ndarray, state: coupled.GlacierState, flow: coupled.FlowField, dx: float,
                 years: float) -> dict[str, float]:
    """The figures of the module docstring for a final state and its velocities."""
    h = state.thickness
    speed = np.hypot(*flow.surface)
    gy, gx = np.gradient(state.bed, dx)
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    rate = (bed0 - state.bed) / years  # m/y
    ice = h > 0
    thick = h > 50.0
    return {
        "median_speed": float(np.median(speed[h > 20.0])),
        "p99_speed": float(np.percentile(speed[h > 20.0], 99)),
        "mean_erosion_mm": float(rate[ice].mean() * 1e3),
        "max_erosion": float(rate.max()),
        "valley_fraction": float(h[thick & (slope < 30.0)].sum() / h[thick].sum()),
        "ice_fraction": float(ice.mean()),
    }


def grindelwald_run(window: tuple[slice, slice], params_for) -> tuple:
    """2000 y of glaciers (ELA 2900 m, 50-year steps, from no ice) on the ``window`` crop of the
    Grindelwald DEM, with the parameters ``params_for(grid)`` (``coupled.CoupledParams``):
    (terrain, initial bed, grid, parameters, ``coupled.run``'s result)."""
    terrain = read_terrain(GRINDELWALD)
    bed0 = terrain.elevation[window].copy()
    grid = type(terrain.grid).full(bed0.shape, terrain.dx, terrain.dy)
    params = params_for(grid)
    result = coupled.run(coupled.GlacierState(bed0, np.zeros_like(bed0)), grid, params, 2900.0,
                         coupled.step_times(2000.0, 50.0))
    return terrain, bed0, grid, params, result


@pytest.mark.slow
@pytest.mark.skipif(not GRINDELWALD.exists(), reason="needs ../shared/data/dem/alps_grindelwald")
def test_grindelwald_glaciers_move_and_erode_at_measured_rates():
    terrain, bed0, grid, params, result = grindelwald_run(WINDOW, lambda grid: coupled.CoupledParams())
    final = result.state
    flow = coupled.flow_field(final.bed, final.thickness, grid, params, warm=final.lattice)
    got = plausibility(bed0, final, flow, terrain.dx, final.time)
    assert 0.2 < got["ice_fraction"] < 0.95  # a glacier, not bare rock nor an ice cap over it all
    assert 5.0 < got["median_speed"] < 200.0, got
    assert got["p99_speed"] < 1000.0, got
    assert 0.05 < got["mean_erosion_mm"] < 10.0, got
    assert got["max_erosion"] < 0.1, got
    assert got["valley_fraction"] >= 0.9, got
    assert result.unconverged <= result.steps // 10
