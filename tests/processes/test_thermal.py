"""Thermal erosion, deposition and unerosion (000 §4) and the cellular automaton (000 Fig. 3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask
from unerode_cli.processes import thermal, thermal_ca
from unerode_cli.processes.fluvial_kernels import DOWNSTREAM, slope_magnitude
from unerode_cli.synthetic import synthesize

DX = 10.0
TAN30 = math.tan(math.radians(30.0))


def cone(n: int = 48, slope: float = 1.5, top: float = 300.0) -> np.ndarray:
    y, x = np.mgrid[0:n, 0:n]
    r = np.hypot(x - n / 2 + 0.3, y - n / 2 + 0.1) * DX
    return np.maximum(0.0, top - slope * r)


def setup(h: np.ndarray):
    grid = Grid.full(h.shape, DX)
    return grid, outlet_mask(grid, "all")


def down_slope(h: np.ndarray, grid: Grid) -> np.ndarray:
    return slope_magnitude(h, grid.valid, grid.dx, grid.dy, DOWNSTREAM).reshape(h.shape)


def run(h, grid, outlets, params, dt, steps, **kw):
    """h after ``steps`` steps, and the summed budget (eroded, deposited, outflux)."""
    z = h.copy()
    total = np.zeros(3)
    for _ in range(steps):
        change = thermal.step(z, grid, outlets, params, dt, **kw)
        z += change.dh
        b = change.budget
        total += (b.eroded, b.deposited, b.outflux)
    return z, total


def single_cell_pits(z: np.ndarray) -> np.ndarray:
    """Depth (m) by which each interior cell lies below all 8 neighbours (0 if it does not)."""
    ny, nx = z.shape
    pad = np.pad(z, 1, constant_values=np.inf)
    lowest = np.min([pad[1 + a : 1 + a + ny, 1 + b : 1 + b + nx]
                     for a in (-1, 0, 1) for b in (-1, 0, 1) if (a, b) != (0, 0)], axis=0)
    depth = np.maximum(lowest - z, 0.0)
    depth[0, :] = depth[-1, :] = depth[:, 0] = depth[:, -1] = 0.0
    return depth


def test_forward_converges_to_the_talus_slope_and_conserves_mass():
    h = cone()
    grid, outlets = setup(h)
    params = thermal.ThermalParams(k_th=10.0, talus_angle=30.0)
    z, (eroded, deposited, outflux) = run(h, grid, outlets, params, 500.0, 300)
    interior = down_slope(z, grid)[1:-1, 1:-1]
    assert interior.max() <= TAN30 * 1.01
    assert down_slope(h, grid)[1:-1, 1:-1].max() > 2 * TAN30  # it did have to converge
    assert deposited > 0.1 * eroded  # rock was deposited below the talus slope, not only lost
    assert abs(eroded - deposited - outflux) <= 1e-9 * eroded


@pytest.mark.parametrize("dt", [400.0, -400.0])
@pytest.mark.parametrize("constraints", [thermal.CONSTRAINTS, ()])
def test_every_step_closes_its_mass_budget(dt, constraints):
    h = synthesize("mountain", (40, 40), 250.0, 2)
    grid, outlets = setup(h)
    change = thermal.step(h, grid, outlets, thermal.ThermalParams(k_th=4.0), dt,
                          constraints=constraints)
    b = change.budget
    assert b.eroded > 0 and b.deposited > 0
    assert abs(b.residual) <= 1e-9 * max(b.eroded, b.deposited)
    assert np.all(change.rock_flux >= 0.0)
    assert np.all(change.dh[outlets] == 0.0)


def test_nothing_happens_below_the_talus_slope():
    y, x = np.mgrid[0:30, 0:30]
    h = 0.4 * DX * (30 - y) + 0.1 * DX * x  # |∇h| ≈ 0.41 < tan 30°
    grid, outlets = setup(h.astype(float))
    for dt in (1000.0, -1000.0):
        change = thermal.step(h.astype(float), grid, outlets, thermal.ThermalParams(), dt)
        assert np.abs(change.dh).max() == 0.0


def test_nodata_cells_are_untouched():
    h = cone(32)
    valid = np.ones(h.shape, bool)
    valid[10:14, 10:14] = False
    grid = Grid(DX, DX, valid)
    outlets = outlet_mask(grid, "all")
    change = thermal.step(np.where(valid, h, np.nan), grid, outlets,
                          thermal.ThermalParams(k_th=10.0), 300.0)
    assert np.all(change.dh[~valid] == 0.0)
    assert abs(change.budget.residual) <= 1e-9 * change.budget.eroded


def test_stable_time_step_is_the_cfl_bound():
    h = cone()
    grid, outlets = setup(h)
    params = thermal.ThermalParams(k_th=8.0)
    assert thermal.max_stable_dt(h, grid, params, outlets) == pytest.approx(
        DX / (0.008 * math.sqrt(2.0)), rel=1e-12)
    flat = np.zeros_like(h)
    assert thermal.max_stable_dt(flat, grid, params, outlets) == math.inf


def curvature_correlation(a: np.ndarray, b: np.ndarray) -> float:
    def laplacian(z):
        return z[2:, 1:-1] + z[:-2, 1:-1] + z[1:-1, 2:] + z[1:-1, :-2] - 4 * z[1:-1, 1:-1]

    return float(np.corrcoef(laplacian(a).ravel(), laplacian(b).ravel())[0, 1])


def automaton_until(h, grid, outlets, params, volume):
    """Run the automaton until it has removed ``volume`` m³ (the last step shortened)."""
    z, removed = h.copy(), 0.0
    dt = 0.5 * thermal_ca.max_stable_dt(grid, params)
    while removed < volume * (1 - 1e-3):
        change = thermal_ca.step(z, grid, outlets, params, dt)
        if removed + change.budget.eroded > volume:
            short = dt * (volume - removed) / change.budget.eroded
            change = thermal_ca.step(z, grid, outlets, params, short)
        z += change.dh
        removed += change.budget.eroded
    return z, removed


def test_flow_following_model_keeps_features_better_than_the_automaton():
    """000 Fig. 3: equal removed volume, the new model's curvature stays closer to the input's."""
    h = synthesize("mountain", (96, 96), 300.0, 5)
    grid, outlets = setup(h)
    z_new, (removed, _, _) = run(h, grid, outlets, thermal.ThermalParams(k_th=2.0), 500.0, 4)
    z_ca, removed_ca = automaton_until(h, grid, outlets,
                                       thermal_ca.ThermalCAParams(k_th=2.0), removed)
    assert removed_ca == pytest.approx(removed, rel=1e-2)
    new, ca = curvature_correlation(h, z_new), curvature_correlation(h, z_ca)
    print(f"curvature correlation with the input: thermal {new:.3f}, automaton {ca:.3f}")
    assert new > ca + 0.1


def test_unerode_then_erode_returns_towards_the_input():
    """000 Fig. 4c–d: 50 backward then 50 forward steps of 200 years."""
    h = synthesize("mountain", (64, 64), 200.0, 3)
    grid, outlets = setup(h)
    params = thermal.ThermalParams(k_th=2.0)
    past, _ = run(h, grid, outlets, params, -200.0, 50)
    back, _ = run(past, grid, outlets, params, 200.0, 50)
    rmse_past = float(np.sqrt(np.mean((past - h) ** 2)))
    rmse_back = float(np.sqrt(np.mean((back - h) ** 2)))
    print(f"thermal unerode→erode: RMSE past {rmse_past:.2f} m, after erosion back {rmse_back:.2f} m")
    assert rmse_past > 5.0
    assert rmse_back < 0.9 * rmse_past
    assert rmse_back < 0.08 * 200.0


def test_undeposition_constraints_prevent_single_cell_pits():
    """000 Fig. 10: with Eq. 16–17 and the rate limit no new pit is deeper than α·Δx·S_d;
    without them un-deposition digs deep single-cell pits."""
    n = 64
    y, x = np.mgrid[0:n, 0:n]
    h = np.maximum(0.0, 400 - 1.2 * np.hypot(x - n / 2, y - n / 2) * DX)
    h += 20 * np.sin(x / 3.0) * np.cos(y / 4.0)
    grid, outlets = setup(h)
    params = thermal.ThermalParams(k_th=10.0, alpha=1.0)
    before = single_cell_pits(h) > 0
    bound = params.alpha * DX * down_slope(h, grid)
    for constraints, expect_deep in ((thermal.CONSTRAINTS, False), ((), True)):
        z = h + thermal.step(h, grid, outlets, params, -500.0, constraints=constraints).dh
        depth = single_cell_pits(z)
        deep = (depth > bound + 1e-9) & ~before
        assert bool(deep.any()) == expect_deep, constraints
        if expect_deep:
            assert depth.max() > 10 * DX * TAN30


def test_automaton_conserves_mass_and_refuses_what_it_cannot_do():
    h = cone(32)
    grid, outlets = setup(h)
    params = thermal_ca.ThermalCAParams(k_th=10.0)
    limit = thermal_ca.max_stable_dt(grid, params)
    assert limit == pytest.approx(0.5 * DX / 0.01)
    change = thermal_ca.step(h, grid, outlets, params, limit)
    b = change.budget
    assert b.eroded > 0
    assert abs(b.residual) <= 1e-9 * b.eroded
    assert np.all(change.dh[outlets] == 0.0)
    with pytest.raises(ValueError, match="stable"):
        thermal_ca.step(h, grid, outlets, params, 2 * limit)
    with pytest.raises(ValueError, match="no backward form"):
        thermal_ca.step(h, grid, outlets, params, -limit)


def test_parameters_are_checked():
    grid, outlets = setup(cone(16))
    with pytest.raises(ValueError, match="k_th"):
        thermal.step(cone(16), grid, outlets, thermal.ThermalParams(k_th=-1.0), 100.0)
    with pytest.raises(ValueError, match="constraint"):
        thermal.step(cone(16), grid, outlets, thermal.ThermalParams(), -100.0,
                     constraints=("walls",))
