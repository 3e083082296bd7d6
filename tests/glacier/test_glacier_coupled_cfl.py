"""The CFL number of the multi-scale step with Blatter–Pattyn velocities (``CoupledParams.multiscale_cfl``).

A one-cell groove, 100 m deep, across an 800 m slab of ice on a 0.5° slope (250 m cells, periodic):
the converged Blatter–Pattyn velocities (up to 97 m/y) fill it at 183 m/y, far faster than the ice
crosses a cell, so velocities held over a step overfill it. The multi-scale step (001 §5) then
leaves a wave train beside the groove whose amplitude grows with c: 0.05 halves the one of 001's
0.1, the default (the evidence from the 001 Fig. 6 ice sheet is in ``coupled._multiscale_cfl``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from unerode_cli.glacier import coupled, multiscale, transport
from unerode_cli.grid import Grid

N, DX, SLAB_M, GROOVE_M = 32, 250.0, 800.0, 100.0


@pytest.fixture(scope="module")
def grooved_slab():
    """(thickness, column-mean velocities, grid) of the grooved slab, velocities converged."""
    grid = Grid.full((N, N), DX)
    thickness = np.full((N, N), SLAB_M)
    thickness[:, N // 2] -= GROOVE_M
    params = coupled.CoupledParams(boundary="periodic", background_slope=math.radians(0.5))
    flow = coupled.flow_field(np.zeros((N, N)), thickness, grid, params, rtol=1e-4, energy_rtol=0.0)
    return thickness, flow, grid


def _wave_train(new: np.ndarray) -> tuple[float, float]:
    """(highest rise above the slab, deepest cell other than the groove) of the new surface, m."""
    change = new - SLAB_M
    beside = np.delete(change, N // 2, axis=1)
    return float(change.max()), float(beside.min())


def test_held_velocities_overfill_a_groove_within_a_year(grooved_slab):
    thickness, flow, grid = grooved_slab
    rate = -transport.flux_divergence(thickness, *flow.mean, grid, "periodic")
    assert rate[:, N // 2].mean() == pytest.approx(183.0, rel=0.05)  # m/y into the groove
    h = thickness
    for _ in range(100):  # 1 y in explicit steps of 0.01 y, far below the CFL step
        h = transport.step(h, *flow.mean, 0.0, grid, 0.01, "periodic")
    assert h[:, N // 2].mean() - SLAB_M == pytest.approx(80.0, abs=8.0)  # 100 m deep → 80 m high


def test_half_of_001s_cfl_number_halves_the_wave_train(grooved_slab):
    thickness, flow, grid = grooved_slab
    assert coupled._multiscale_cfl(flow, grid, coupled.CoupledParams().multiscale_cfl) == transport.CFL == 0.1
    c = coupled._multiscale_cfl(flow, grid, 0.05)
    rise_001, dip_001 = _wave_train(multiscale.step(thickness, *flow.mean, 0.0, grid, 50.0, "periodic",
                                                    c=transport.CFL))
    rise, dip = _wave_train(multiscale.step(thickness, *flow.mean, 0.0, grid, 50.0, "periodic", c=c))
    assert rise_001 == pytest.approx(130.0, abs=10.0) and dip_001 == pytest.approx(-130.0, abs=10.0)
    assert rise == pytest.approx(65.0, abs=6.0) and dip == pytest.approx(-65.0, abs=6.0)


@pytest.mark.parametrize("c", [0.0, 1.5])
def test_a_cfl_number_outside_0_1_is_refused(c):
    with pytest.raises(ValueError, match="multi-scale CFL number"):
        coupled.CoupledParams(multiscale_cfl=c).validate((8, 8))
