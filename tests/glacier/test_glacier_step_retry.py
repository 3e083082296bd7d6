"""Rejected multi-scale steps: a step that raises the ice surface above what the ice within reach
could feed (``coupled.surface_overshoot``) is taken again at half its length."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from unerode_cli.glacier import blatter, coupled, multiscale
from unerode_cli.grid import Grid

SIA = coupled.CoupledParams(flow=blatter.FlowParams(sliding_c=1e5), iceflow="sia")


def _cap(shape: tuple[int, int] = (40, 40), dx: float = 200.0) -> tuple[coupled.GlacierState, Grid]:
    """A parabolic ice cap of 300 m on a flat bed at 1000 m."""
    y, x = np.mgrid[0:shape[0], 0:shape[1]]
    r2 = ((x - 19.5) ** 2 + (y - 19.5) ** 2) / 12.0**2
    thickness = np.where(r2 < 1.0, 300.0 * np.sqrt(np.clip(1.0 - r2, 0.0, 1.0)), 0.0)
    return coupled.GlacierState(np.full(shape, 1000.0), thickness), Grid.full(shape, dx)


def test_overshoot_is_the_rise_above_the_highest_surface_within_reach():
    state, grid = _cap()
    reach = 2 ** multiscale.level_count(grid.shape)
    assert reach == 8
    top = float((state.bed + state.thickness).max())  # the dome's top, 1300 m less rounding
    near, far = state.thickness.copy(), state.thickness.copy()
    near[19, 27] = 500.0  # 1500 m, 8 cells from the dome's top: within reach
    far[2, 2] = 500.0  # more than 8 cells from any ice: the flat bed is all there is to feed it
    for thickness, highest in ((near, top), (far, 1000.0)):
        after = replace(state, thickness=thickness)
        # less p_max·dt = 100 m of accumulation
        assert coupled.surface_overshoot(state, after, grid, SIA, 50.0) == pytest.approx(
            1500.0 - highest - 100.0, abs=1e-9)
    # accumulation on the dome alone (p_max·dt) is within the bound
    fed = replace(state, thickness=state.thickness + np.where(state.thickness > 0, 100.0, 0.0))
    assert coupled.surface_overshoot(state, fed, grid, SIA, 50.0) <= 1e-9


def test_run_takes_an_overshooting_step_again_at_half_its_length(monkeypatch):
    """A step that creates a spike whenever it is longer than 13 y is refused and taken again
    at 25, then 12.5 y; the steps then grow back by RAMP_FACTOR, and the run reaches its end."""
    state, grid = _cap()
    true_step = coupled.step
    lengths = []

    def spiky(state, grid, params, ela, dt):
        new, report = true_step(state, grid, params, ela, dt)
        lengths.append(dt)
        if dt > 13.0:
            h = new.thickness.copy()
            h[0, 0] = 5000.0
            new = replace(new, thickness=h)
        return new, report

    monkeypatch.setattr(coupled, "step", spiky)
    result = coupled.run(state, grid, SIA, 1100.0, [50.0])
    assert lengths[:3] == [50.0, 25.0, 12.5]
    assert result.retries == sum(1 for dt in lengths if dt > 13.0) >= 3
    assert result.state.time == pytest.approx(50.0)
    assert result.state.thickness.max() < 400.0  # no refused spike entered the state
    assert result.times[1] == pytest.approx(12.5)
