"""Operator splitting of several processes through the runner, forward then backward."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.hydro import outlet_mask, route
from unerode_cli.io.terrain import Terrain
from unerode_cli.processes import fluvial
from unerode_cli.run.boundaries import Boundaries
from unerode_cli.run.registry import REGISTRY
from unerode_cli.run.runner import run
from unerode_cli.synthetic import synthesize

VALUES = {"uplift": 0.0, "k": 2e-5, "k_d": 1.0, "precipitation": 1.0, "m": 0.4, "n": 1.0,
          "k_th": 4.0, "talus_angle": 30.0, "alpha": 1.0, "max_undeposition": 0.01}


def processes(terrain: Terrain, names: list[str]):
    return [REGISTRY[name].build(terrain, Boundaries("all"), VALUES, {}) for name in names]


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def test_fluvial_and_thermal_forward_then_backward_return_close_to_the_start():
    h0 = synthesize("mountain", (64, 64), 400.0, 7)
    terrain = Terrain(h0, 10.0, 10.0)
    eroded, report = run(h0, processes(terrain, ["fluvial", "thermal"]), 200.0, 40)
    assert report.steps == 40
    for budget in report.budgets.values():
        assert abs(budget.residual) <= 1e-9 * budget.eroded
    # the inverse of "fluvial then thermal" is "thermal then fluvial" run backward
    back, _ = run(eroded, processes(terrain, ["thermal", "fluvial"]), -200.0, 40)
    changed, returned = rmse(eroded, h0), rmse(back, h0)
    print(f"fluvial+thermal 40 × 200 y: RMSE eroded {changed:.2f} m, after unerosion {returned:.2f} m")
    assert changed > 2.0
    assert returned < 0.85 * changed  # thermal is the less reversible part (000 Fig. 6)


def test_substeps_follow_the_tightest_process():
    h0 = synthesize("mountain", (32, 32), 400.0, 1)
    terrain = Terrain(h0, 10.0, 10.0)
    procs = processes(terrain, ["fluvial", "thermal"])
    dt = 3.0 * procs[1].stable_dt(h0, 1.0)
    _, report = run(h0, procs, dt, 1)
    assert report.substeps["thermal"] >= 3
    assert report.substeps["fluvial"] == pytest.approx(1, abs=2)


def test_fluvial_step_kept_from_the_stability_check_is_the_step_asked_for():
    h0 = synthesize("mountain", (48, 40), 400.0, 3)
    terrain = Terrain(h0, 10.0, 10.0)
    (process,) = processes(terrain, ["fluvial"])
    grid = terrain.grid
    outlets = outlet_mask(grid, "all")
    routing = route(h0, grid, outlets)
    params = process.params
    expected_dt = fluvial.max_stable_dt(h0, grid, params, routing)
    assert process.stable_dt(h0, 500.0) == pytest.approx(expected_dt, rel=1e-12)
    for dt in (500.0, 250.0):  # the kept step, then a sub-step that must be computed anew
        got = process.advance(h0, dt)
        want = fluvial.step(h0, grid, outlets, params, dt, routing=routing)
        np.testing.assert_array_equal(got.dh, want.dh)
        assert got.eroded == pytest.approx(want.budget.eroded, rel=1e-12)
    moved = h0 + process.advance(h0, 250.0).dh  # a new elevation is stepped, not the kept one
    np.testing.assert_array_equal(
        process.advance(moved, 250.0).dh,
        fluvial.step(moved, grid, outlets, params, 250.0,
                     routing=route(moved, grid, outlets)).dh)


def test_a_dem_with_nodata_is_routed_and_stepped_once_per_step(monkeypatch: pytest.MonkeyPatch):
    """The routing and fluvial step kept between the stability check and the step itself also
    hold on a DEM with nodata (NaN cells): one fluvial step and one routing per time step, and
    the same result as the uncached step."""
    h0 = synthesize("mountain", (48, 48), 400.0, 3)
    h0[10:16, 20:30] = np.nan
    terrain = Terrain(h0, 10.0, 10.0)
    calls = {"step": 0, "route": 0}
    step = fluvial.step

    def counted_step(*args, **kwargs):
        calls["step"] += 1
        return step(*args, **kwargs)

    def counted_route(*args, **kwargs):
        calls["route"] += 1
        return route(*args, **kwargs)

    monkeypatch.setattr(fluvial, "step", counted_step)
    monkeypatch.setattr("unerode_cli.hydro.routing.route", counted_route)
    out, _ = run(h0, processes(terrain, ["fluvial"]), 100.0, 3)
    assert calls == {"step": 3, "route": 3}
    valid = np.isfinite(h0)
    expected = h0.copy()
    for _ in range(3):
        outlets = outlet_mask(terrain.grid, "all")
        params = fluvial.FluvialParams(**{k: VALUES[k] for k in
                                          ("uplift", "k", "k_d", "precipitation", "m", "n")})
        expected = expected + step(expected, terrain.grid, outlets, params, 100.0).dh
    np.testing.assert_array_equal(out[valid], expected[valid])
