"""The prognostic velocity solves end at a tolerance whose error is measured.

A 64 × 64 window (46 m cells) of the Grindelwald DEM, the upper basin of the plausibility test,
under an ELA of 2900 m for 300 years in steps of 50 y with the default parameters: every solve of
the run must meet ``coupled.FLOW_RTOL``, and at the state reached, the velocities solved as the
next step solves them (warm-started from the previous step's, to ``FLOW_RTOL``, no energy rule)
must lie within 0.5 % (relative L2 of the velocity vectors over the cells
with more than 1 m of ice) of a solve to 1e-5 (``glaciate --diagnostic``'s tolerance; the solve
goes to 7.7e-6 here), at the surface and at the bed. Measured: 0.003 % at the surface and at the
bed (21 iterations to 1e-3, 26 more to 1e-5); 54 s on one thread. ``bench/glacier_convergence.py``
measures the same on larger crops of Grindelwald, Ötztal and a plateau. Slow: ``pytest -m slow``.
"""

from __future__ import annotations

import numpy as np
import pytest
from tests.conftest import SHARED_DATA

from unerode_cli.glacier import coupled
from unerode_cli.grid import Grid
from unerode_cli.io.rasters import read_terrain

GRINDELWALD = SHARED_DATA / "dem" / "alps_grindelwald" / "dem.tif"
WINDOW = (slice(200, 264), slice(250, 314))


def _relative_l2(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
                 where: np.ndarray) -> float:
    """‖a − b‖₂ / ‖b‖₂ of velocity vectors (u, v) over the cells ``where``."""
    error = np.hypot(a[0] - b[0], a[1] - b[1])[where]
    return float(np.linalg.norm(error) / np.linalg.norm(np.hypot(*b)[where]))


def test_the_default_rule_asks_the_residual_alone() -> None:
    params = coupled.CoupledParams()
    assert params.flow_energy_rtol == 0.0 and params.flow_rtol == coupled.FLOW_RTOL <= 0.01


@pytest.mark.slow
@pytest.mark.skipif(not GRINDELWALD.exists(), reason="needs ../shared/data/dem/alps_grindelwald")
def test_prognostic_velocities_lie_within_two_percent_of_converged_ones() -> None:
    terrain = read_terrain(GRINDELWALD)
    bed = terrain.elevation[WINDOW].astype(np.float64)
    grid = Grid.full(bed.shape, terrain.dx, terrain.dy)
    params = coupled.CoupledParams()
    result = coupled.run(coupled.GlacierState(bed, np.zeros_like(bed)), grid, params, 2900.0,
                         coupled.step_times(300.0, 50.0))
    state = result.state
    assert result.solves == result.steps and result.unconverged == 0, result.max_residual
    assert result.max_residual <= coupled.FLOW_RTOL
    flow = coupled.flow_field(state.bed, state.thickness, grid, params, warm=state.lattice)
    reference = coupled.flow_field(state.bed, state.thickness, grid, params, warm=flow.lattice, rtol=1e-5,
                                   max_iter=20000, energy_rtol=0.0)
    assert flow.converged and reference.converged
    ice = state.thickness > 1.0
    assert ice.sum() > 500
    assert _relative_l2(flow.surface, reference.surface, ice) <= 0.005
    assert _relative_l2(flow.basal, reference.basal, ice) <= 0.005
