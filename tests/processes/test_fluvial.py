"""Fluvial erosion, deposition and unerosion (000 §3) against independent computations."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.hydro import accumulate, outlet_mask, route
from unerode_cli.processes.fluvial import (
    PARAMETERS,
    FluvialParams,
    max_stable_dt,
    step,
)
from unerode_cli.processes.fluvial_kernels import DOWNSTREAM, slope_magnitude

NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def axis_neighbours(h: np.ndarray, valid: np.ndarray):
    """East, west, south, north neighbours of every cell; the cell itself off the grid or
    on nodata."""
    ny, nx = h.shape
    padded = np.pad(np.where(valid, h, np.nan), 1, constant_values=np.nan)

    def shifted(dr: int, dc: int) -> np.ndarray:
        values = padded[1 + dr : 1 + dr + ny, 1 + dc : 1 + dc + nx]
        return np.where(np.isnan(values), h, values)

    return shifted(0, 1), shifted(0, -1), shifted(1, 0), shifted(-1, 0)


def downstream_slope(h: np.ndarray, valid: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """000 Eq. 9 in NumPy."""
    east, west, south, north = axis_neighbours(h, valid)
    sx = np.maximum.reduce([np.zeros_like(h), h - east, h - west]) / dx
    sy = np.maximum.reduce([np.zeros_like(h), h - south, h - north]) / dy
    return np.hypot(sx, sy)


def backward_slope(h: np.ndarray, valid: np.ndarray, dx: float, dy: float, scheme: str):
    """000 Eq. 10 (upwind) or Eq. 12 (minmod-limited blend with Eq. 11) in NumPy."""
    east, west, south, north = axis_neighbours(h, valid)

    def axis(a: np.ndarray, b: np.ndarray, d: float) -> np.ndarray:
        zero = np.zeros_like(h)
        up = np.maximum.reduce([zero, a - h, b - h]) / d
        if scheme == "upwind":
            return up
        down = np.maximum.reduce([zero, h - a, h - b]) / d
        centred = np.abs(a - b) / (2 * d)
        with np.errstate(divide="ignore", invalid="ignore"):
            phi = np.clip(np.where(up > 0, down / up, 0.0), 0.0, 1.0)
        return up - phi * (up - centred)

    return np.hypot(axis(east, west, dx), axis(south, north, dy))


def hills(shape: tuple[int, int], dx: float) -> np.ndarray:
    """A smooth mountain with ridges and valleys, > 0 m."""
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]] * dx
    ly, lx = shape[0] * dx, shape[1] * dx
    mountain = 800.0 * np.exp(-((cols - lx / 2) ** 2 + (rows - ly / 2) ** 2) / (2 * (lx / 4) ** 2))
    ridges = 60.0 * np.sin(2 * np.pi * cols / (lx / 3)) * np.sin(2 * np.pi * rows / (ly / 2.5))
    h = mountain + ridges
    return h - h.min() + 1.0


def incoming_flux(routing, flux: np.ndarray) -> np.ndarray:
    """Σ_donors α·flux: what arrives at each cell (000 Eq. 7, Q̃s)."""
    fractions = routing.fractions()
    ny, nx = flux.shape
    arriving = np.zeros((ny + 2, nx + 2))
    for k, (dr, dc) in enumerate(NEIGHBOURS):
        arriving[1 + dr : 1 + dr + ny, 1 + dc : 1 + dc + nx] += fractions[:, :, k] * flux
    return arriving[1:-1, 1:-1]


def test_parameters_are_declared_and_validated() -> None:
    names = [spec.name for spec in PARAMETERS]
    assert names == ["uplift", "k", "k_d", "precipitation", "m", "n"]
    assert [spec.symbol for spec in PARAMETERS][:4] == ["U", "K", "K_d", "p"]  # 000 notation
    defaults = FluvialParams()
    assert defaults.m == 0.4 and defaults.n == 1.0  # 000 Table 2
    assert all(spec.unit and spec.help for spec in PARAMETERS)
    grid = Grid.full((8, 8), 10.0)
    h = hills(grid.shape, 10.0)
    outlets = outlet_mask(grid, "all")
    with pytest.raises(ValueError, match="parameter k must be ≥ 0"):
        step(h, grid, outlets, FluvialParams(k=-1e-5), 10.0)
    with pytest.raises(ValueError, match="parameter k_d must be ≥ 0"):
        FluvialParams(k_d=np.full((8, 8), -1.0)).validate(grid)
    with pytest.raises(ValueError, match="shape"):
        FluvialParams(precipitation=np.ones((4, 4))).validate(grid)
    with pytest.raises(ValueError, match="scalar"):
        FluvialParams(m=np.full((8, 8), 0.4)).validate(grid)
    with pytest.raises(ValueError, match="parameter n must be ≥ 0.5"):
        FluvialParams(n=0.0).validate(grid)
    valid = np.ones((8, 8), dtype=bool)
    valid[0, 0] = False
    rain = np.ones((8, 8))
    rain[0, 0] = np.nan  # a parameter map may hold nodata where the DEM does
    FluvialParams(precipitation=rain).validate(Grid(10.0, 10.0, valid))
    with pytest.raises(ValueError, match="finite"):
        FluvialParams(precipitation=rain).validate(grid)
    with pytest.raises(ValueError, match="scheme"):
        step(h, grid, outlets, FluvialParams(), -10.0, scheme="centred")


@pytest.mark.parametrize("method", ["mfd", "d8"])
def test_without_deposition_it_is_the_stream_power_law(method: str) -> None:
    grid = Grid.full((40, 36), 50.0, 70.0)
    h = hills(grid.shape, 60.0)
    outlets = outlet_mask(grid, "all")
    rng = np.random.default_rng(2)
    uplift = rng.uniform(0.0, 1e-3, grid.shape)
    k = rng.uniform(1e-6, 2e-5, grid.shape)
    params = FluvialParams(uplift=uplift, k=k, k_d=0.0, precipitation=0.7, m=0.45, n=1.2)
    routing = route(h, grid, outlets, method)
    discharge = accumulate(routing, 0.7)
    free = ~outlets
    for dt, scheme in ((250.0, "limiter"), (-250.0, "limiter"), (-250.0, "upwind")):
        change = step(h, grid, outlets, params, dt, routing=routing, scheme=scheme)
        if dt > 0:
            slope = downstream_slope(h, grid.valid, 50.0, 70.0)
        else:
            slope = backward_slope(h, grid.valid, 50.0, 70.0, scheme)
        expected = dt * (uplift - k * discharge**0.45 * slope**1.2)
        np.testing.assert_allclose(change.dh[free], expected[free], rtol=1e-10, atol=1e-14)
        assert (change.dh[outlets] == 0.0).all()
        np.testing.assert_allclose(change.discharge, discharge, rtol=1e-12)
    assert np.abs(change.dh).max() > 0.01  # the steps do something


@pytest.mark.parametrize("dt", [300.0, -300.0])
def test_deposition_follows_eq_8_and_mass_is_conserved(dt: float) -> None:
    valid = np.ones((48, 40), dtype=bool)
    valid[30:36, 5:12] = False  # a nodata hole: its shore is an outlet
    grid = Grid(40.0, 40.0, valid)
    h = hills(grid.shape, 40.0)
    h[~valid] = np.nan  # nodata as a raster reader gives it
    before = h.copy()
    outlets = outlet_mask(grid, "S,W")
    rng = np.random.default_rng(7)
    uplift = rng.uniform(0.0, 5e-4, grid.shape)
    precipitation = rng.uniform(0.3, 1.5, grid.shape)
    params = FluvialParams(uplift=uplift, k=3e-5, k_d=0.8, precipitation=precipitation)
    routing = route(h, grid, outlets, "mfd")
    change = step(h, grid, outlets, params, dt, routing=routing)
    np.testing.assert_array_equal(h, before)  # the input is not modified
    assert (change.dh[~valid] == 0.0).all() and (change.dh[outlets] == 0.0).all()
    assert (change.discharge[~valid] == 0.0).all()

    area = grid.cell_area
    free = valid & ~outlets
    q = accumulate(routing, precipitation)
    qs = change.sediment_flux
    arriving = incoming_flux(routing, qs)
    if dt > 0:
        slope = downstream_slope(h, valid, 40.0, 40.0)
    else:
        slope = backward_slope(h, valid, 40.0, 40.0, "limiter")
    erosion = 3e-5 * q**0.4 * slope
    with np.errstate(divide="ignore", invalid="ignore"):  # Q = 0 on nodata only
        deposition = np.minimum(0.8 * arriving / q, arriving / area)
    expected = dt * (uplift - erosion + deposition)  # 000 Eq. 8
    np.testing.assert_allclose(change.dh[free], expected[free], rtol=1e-9, atol=1e-12)
    # 000 Eq. 7: what leaves = uplift − change, over the cell, plus what arrives
    leaving = (uplift - change.dh / dt) * area + arriving
    np.testing.assert_allclose(qs[free], leaving[free], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(qs[outlets], arriving[outlets], rtol=1e-12)
    assert deposition[free].max() > 0.1 * erosion[free].max()  # deposition matters here

    e = np.where(free, change.dh - uplift * dt, 0.0)
    eroded = np.maximum(0.0, -e).sum() * area
    deposited = np.maximum(0.0, e).sum() * area
    outflux = dt * qs[outlets].sum()
    budget = change.budget
    assert budget.eroded == pytest.approx(eroded, rel=1e-9)
    assert budget.deposited == pytest.approx(deposited, rel=1e-9)
    assert budget.outflux == pytest.approx(outflux, rel=1e-9)
    assert deposited > 0.01 * eroded
    assert abs(eroded - deposited - outflux) <= 1e-9 * eroded
    assert abs(budget.residual) <= 1e-9 * budget.eroded


def test_sediment_flux_never_negative_and_deposition_capped() -> None:
    # K_d·A > Q near the ridges: there K_d·Q̃s/Q would deposit more than arrives (Q̃s/A) and
    # make the flux leaving negative; the deposition is capped at what arrives.
    grid = Grid.full((32, 32), 30.0)
    h = hills(grid.shape, 30.0)
    outlets = outlet_mask(grid, "all")
    params = FluvialParams(uplift=0.0, k=2e-5, k_d=10.0, precipitation=0.1)
    routing = route(h, grid, outlets)
    dt, area = 500.0, grid.cell_area
    change = step(h, grid, outlets, params, dt, routing=routing)
    qs, q = change.sediment_flux, change.discharge
    assert qs.min() >= 0.0
    arriving = incoming_flux(routing, qs)
    erosion = 2e-5 * q**0.4 * downstream_slope(h, grid.valid, 30.0, 30.0)
    binding = ~outlets & (arriving > 0) & (10.0 * area > q)
    assert binding.sum() > 50
    uncapped_flux = (erosion - 10.0 * arriving / q) * area + arriving
    assert (uncapped_flux[binding] < 0).sum() > 10
    capped_dh = dt * (arriving / area - erosion)
    np.testing.assert_allclose(change.dh[binding], capped_dh[binding], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(qs[binding], (erosion * area)[binding], rtol=1e-9, atol=1e-12)
    assert abs(change.budget.residual) <= 1e-9 * change.budget.eroded


def test_sediment_deposits_at_the_foot_of_a_mountain() -> None:
    # A steep (0.4) mountain slope down to row 24, then a plain at 0.001 to the southern outlets.
    ny, nx, dx, foot = 48, 24, 100.0, 24
    rows, cols = np.mgrid[0:ny, 0:nx]
    h = (
        np.where(rows < foot, 0.4 * dx * (foot - rows), 0.0)
        + 0.001 * dx * (ny - 1 - rows)
        + 0.02 * dx * np.abs(cols - nx // 2) / nx
    )
    grid = Grid.full((ny, nx), dx)
    params = FluvialParams(uplift=0.0, k=1e-5, k_d=1.0, precipitation=1.0)
    change = step(h, grid, outlet_mask(grid, "S"), params, 100.0)
    per_row = change.dh.sum(axis=1)
    assert (per_row[:foot] < 0).all()  # the mountain erodes
    assert (per_row[foot:-1] > 0).all()  # the plain aggrades
    assert np.argmax(per_row) == foot  # most at the foot...
    assert (np.diff(per_row[foot:-1]) < 0).all()  # ...less and less downstream
    assert np.unravel_index(np.argmax(change.dh), change.dh.shape)[0] == foot
    assert per_row[foot] > 10 * per_row[-2]


def converge_to_steady_state(method: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Uplift a 48 × 48 noisy surface draining south until ∂h/∂t < 1e-3 U."""
    uplift, k = 1e-3, 1e-4
    grid = Grid.full((48, 48), 100.0)
    outlets = outlet_mask(grid, "S")
    rng = np.random.default_rng(1)
    h = rng.random(grid.shape) + 0.01 * np.arange(48)[::-1, None]
    h[outlets] = 0.0
    params = FluvialParams(uplift=uplift, k=k, k_d=0.0, precipitation=1.0)
    for _ in range(30_000):
        routing = route(h, grid, outlets, method)
        dt = 0.9 * max_stable_dt(h, grid, params, routing)
        change = step(h, grid, outlets, params, dt, routing=routing)
        h = h + change.dh
        if np.abs(change.dh).max() / dt < 1e-3 * uplift:
            return h, change.discharge, outlets
    raise AssertionError("no steady state")


@pytest.mark.parametrize("method", ["d8", pytest.param("mfd", marks=pytest.mark.slow)])
def test_steady_state_slopes_follow_uplift_over_stream_power(method: str) -> None:
    # At steady state U = K Q^m S^n, so S = (U/K)^(1/n) Q^(-m/n), S being the scheme's slope
    # (000 Eq. 9), here recomputed with NumPy.
    h, q, outlets = converge_to_steady_state(method)
    grid_valid = np.ones_like(outlets)
    slope = downstream_slope(h, grid_valid, 100.0, 100.0)
    channels = ~outlets & (q > 50 * 100.0 * 100.0)
    assert channels.sum() > 100
    predicted = (1e-3 / 1e-4) * q[channels] ** -0.4
    np.testing.assert_allclose(slope[channels], predicted, rtol=0.05)
    assert h.max() > 100.0  # relief grew from ~1 m


@pytest.mark.parametrize("k_d", [0.0, 1.0])
def test_unerosion_then_erosion_comes_back_limiter_better_than_upwind(k_d: float) -> None:
    # 000 Fig. 4-5: unerode 200 steps, erode 200 steps back, RMSE to the input.
    grid = Grid.full((64, 64), 100.0)
    h0 = hills(grid.shape, 100.0)
    outlets = outlet_mask(grid, "all")
    params = FluvialParams(uplift=0.0, k=2e-5, k_d=k_d, precipitation=1.0)
    dt = 0.05 * max_stable_dt(h0, grid, params, route(h0, grid, outlets))
    rmse, change = {}, {}
    for scheme in ("limiter", "upwind"):
        h = h0.copy()
        for _ in range(200):
            h = h + step(h, grid, outlets, params, -dt, scheme=scheme).dh
        change[scheme] = np.abs(h - h0).mean()
        for _ in range(200):
            h = h + step(h, grid, outlets, params, dt).dh
        rmse[scheme] = np.sqrt(np.mean((h - h0) ** 2))
    print(
        f"\nK_d={k_d}: mean |unerosion| {change['limiter']:.2f} m; RMSE after erosion back: "
        f"limiter {rmse['limiter']:.3f} m, upwind {rmse['upwind']:.3f} m"
    )
    assert change["limiter"] > 10.0  # the terrain really went back in time
    assert rmse["limiter"] < 0.9 * rmse["upwind"]
    assert rmse["limiter"] < 0.35 * change["limiter"]


def test_max_stable_dt_is_the_diagonal_cfl_bound() -> None:
    # A plane falling to the south-east, D8: every cell drains diagonally, Q grows downstream.
    n, dx, k = 20, 50.0, 1e-5
    rows, cols = np.mgrid[0:n, 0:n]
    h = 1000.0 - 5.0 * (rows + cols)
    grid = Grid.full((n, n), dx)
    outlets = outlet_mask(grid, "S,E")
    params = FluvialParams(uplift=0.0, k=k, k_d=0.0, precipitation=1.0)
    routing = route(h, grid, outlets, "d8")
    q = accumulate(routing, 1.0)
    q_max = q[~outlets].max()
    bound = max_stable_dt(h, grid, params, routing)
    assert bound == pytest.approx(dx / (np.sqrt(2.0) * k * q_max**0.4), rel=1e-12)

    def overshoot(dt: float) -> float:
        """How far the fastest cell falls below its old downstream neighbours (m)."""
        new = h + step(h, grid, outlets, params, dt, routing=routing).dh
        lowest_axis_neighbour = np.minimum(np.roll(h, -1, axis=0), np.roll(h, -1, axis=1))
        return float((lowest_axis_neighbour - new)[~outlets].max())

    assert overshoot(bound) <= 1e-9  # monotone: no cell jumps below its neighbours
    assert overshoot(np.sqrt(2.0) * bound) > 0.1  # the bound K Q^m dt / Δx ≤ 1 is not enough
    assert max_stable_dt(h, grid, FluvialParams(k=0.0), routing) == np.inf


def test_max_stable_dt_with_a_raster_k_and_n_other_than_one() -> None:
    # The general bound: max over free cells of n·K·Q^m·|∇h|^(n−1) with the downstream slope.
    size, dx = 24, 30.0
    rng = np.random.default_rng(4)
    rows = np.arange(size)[:, None]
    h = 500.0 - 2.0 * rows + 3.0 * rng.random((size, size))
    grid = Grid.full((size, size), dx)
    outlets = outlet_mask(grid, "S")
    k = 1e-5 * (1.0 + rng.random((size, size)))
    params = FluvialParams(k=k, m=0.5, n=1.5)
    routing = route(h, grid, outlets)
    q = accumulate(routing, 1.0)
    slope = slope_magnitude(h, grid.valid, dx, dx, DOWNSTREAM).reshape(h.shape)
    free = ~outlets & (slope > 0.0)
    speed = (1.5 * k * q**0.5 * slope**0.5)[free].max()
    expected = 1.0 / (speed * np.hypot(1.0 / dx, 1.0 / dx))
    assert max_stable_dt(h, grid, params, routing) == pytest.approx(expected, rel=1e-12)
    # the discharge of a step on this elevation gives the same bound without routing again
    q_step = step(h, grid, outlets, params, 10.0, routing=routing).discharge
    assert max_stable_dt(h, grid, params, routing, discharge=q_step) == pytest.approx(
        expected, rel=1e-12)
