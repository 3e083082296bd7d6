"""Multi-scale transport in steps shorter than the coupled step (``CoupledParams.multiscale_dt``).

A multi-scale step takes in only min(f^i·δt_i, dt)/dt of the tendency where the ice moves fast
(``multiscale``), so a glacier grown in long steps lags one grown in short steps (001 Fig. 11).
Transport steps of 10 y inside steps of 50 y, with the velocities solved once per step, follow
the 10-year run.
"""

from __future__ import annotations

import numpy as np
import pytest
from tests.glacier.test_fig14_coupling import DX, _valley

from unerode_cli.glacier import coupled
from unerode_cli.grid import Grid


def _grown_volumes(dt: float, multiscale_dt: float | None, years: tuple[float, ...]) -> np.ndarray:
    """Ice volumes (km³) at ``years`` of a glacier grown from no ice as the ELA falls from 3400 m
    to 2900 m over 3000 years (erosion off)."""
    bed = _valley((30, 45))  # the V-shaped valley of the Fig. 14 tests, 100 m cells
    grid = Grid.full(bed.shape, DX)
    ela = coupled.ElaTable(np.array([0.0, 3000.0]), np.array([3400.0, 2900.0]))
    params = coupled.CoupledParams(erosion=False, multiscale_dt=multiscale_dt)
    result = coupled.run(coupled.GlacierState(bed, np.zeros_like(bed)), grid, params, ela,
                         coupled.step_times(max(years), dt))
    return np.interp(years, result.times, result.volumes) / 1e9


@pytest.mark.slow
def test_transport_steps_of_10_y_follow_a_glacier_grown_in_10_year_steps():
    """Measured (45 s): 0.684 and 0.774 km³ at 2 and 3 ky in 10-year steps; −20 % and −14 % in
    50-year steps; −0.2 % and −1.2 % in 50-year steps of five 10-year transport steps."""
    years = (2000.0, 3000.0)
    reference = _grown_volumes(10.0, None, years)
    long_steps = _grown_volumes(50.0, None, years)
    transport_steps = _grown_volumes(50.0, 10.0, years)
    assert reference == pytest.approx([0.684, 0.774], rel=0.03)
    assert np.all(long_steps < 0.9 * reference)
    assert transport_steps == pytest.approx(reference, rel=0.02)


def test_a_transport_step_as_long_as_the_step_changes_no_bit():
    bed = _valley((16, 24))
    grid = Grid.full(bed.shape, DX)
    h = np.where(bed > 3300.0, 60.0, 0.0)
    state = coupled.GlacierState(bed, h)
    runs = {}
    for multiscale_dt in (None, 40.0, 15.0):
        params = coupled.CoupledParams(multiscale_dt=multiscale_dt)
        runs[multiscale_dt] = coupled.step(state, grid, params, 3000.0, 40.0)
    np.testing.assert_array_equal(runs[None][0].thickness, runs[40.0][0].thickness)
    assert runs[None][1].substeps == runs[40.0][1].substeps == 1
    assert runs[15.0][1].substeps == 3  # ⌈40 / 15⌉ steps of 13.3 y
    assert not np.array_equal(runs[15.0][0].thickness, runs[None][0].thickness)
    np.testing.assert_array_equal(runs[15.0][0].bed, runs[None][0].bed)  # erosion: the step's velocities


@pytest.mark.parametrize("multiscale_dt", [0.0, -5.0, float("inf")])
def test_a_transport_step_not_finite_and_positive_is_refused(multiscale_dt):
    with pytest.raises(ValueError, match="multi-scale transport step"):
        coupled.CoupledParams(multiscale_dt=multiscale_dt).validate((8, 8))
