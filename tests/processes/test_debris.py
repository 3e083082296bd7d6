"""Debris-flow erosion (001 Eq. 8), implicit downstream first, against independent NumPy
computations of the equation it solves, the explicit form of Eq. 8 and its limits."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.hydro import drainage_area, outlet_mask, route
from unerode_cli.processes.debris import (
    BACKWARD_REFUSAL,
    PARAMETERS,
    DebrisParams,
    step,
)

OFFSETS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))
S_C = math.tan(math.radians(37.0))


def shifted(a: np.ndarray, dr: int, dc: int, fill) -> np.ndarray:
    """a[r + dr, c + dc] at every cell (r, c); ``fill`` off the grid."""
    ny, nx = a.shape
    padded = np.pad(a, 1, constant_values=fill)
    return padded[1 + dr : 1 + dr + ny, 1 + dc : 1 + dc + nx]


def steepest_slope(h: np.ndarray, valid: np.ndarray, dx: float, dy: float, pos=None) -> np.ndarray:
    """max over the 8 neighbours j of (h − h_j)/L_j (m/m), −inf without neighbour; only the
    neighbours after the cell in the order (position ``pos``) when given."""
    best = np.full(h.shape, -np.inf)
    for dr, dc in OFFSETS:
        length = math.hypot(dr * dy, dc * dx)
        ok = shifted(valid, dr, dc, False) & valid
        if pos is not None:
            ok &= shifted(pos, dr, dc, -1) > pos
        slope = (h - shifted(np.where(valid, h, 0.0), dr, dc, 0.0)) / length
        best = np.where(ok, np.maximum(best, slope), best)
    return best


def pits(h: np.ndarray, valid: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """Valid non-fixed cells without a strictly lower valid neighbour."""
    return valid & ~fixed & ~(steepest_slope(h, valid, 1.0, 1.0) > 0.0)


def positions(order: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    pos = np.full(shape[0] * shape[1], -1)
    pos[order] = np.arange(order.size)
    return pos.reshape(shape)


def cone(shape: tuple[int, int], dx: float, dy: float, slope: float) -> np.ndarray:
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    r = np.hypot((cols - shape[1] // 2) * dx, (rows - shape[0] // 2) * dy)
    return 1000.0 - slope * r


def rugged(shape: tuple[int, int], dx: float, seed: int) -> np.ndarray:
    """A steep mountain with cliffs and noise (slopes 0 to > 3), > 0 m."""
    rng = np.random.default_rng(seed)
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]] * dx
    ly, lx = shape[0] * dx, shape[1] * dx
    mountain = 600.0 * np.exp(-((cols - lx / 2) ** 2 + (rows - ly / 2) ** 2) / (2 * (lx / 5) ** 2))
    ridges = 40.0 * np.sin(2 * np.pi * cols / (lx / 4)) * np.sin(2 * np.pi * rows / (ly / 3))
    h = mountain + ridges + 30.0 * rng.random(shape)
    return h - h.min() + 1.0


def test_parameters_are_declared_and_validated() -> None:
    specs = {spec.name: spec for spec in PARAMETERS}
    assert list(specs) == ["k_df", "k_da", "q_area", "q_slope", "critical_angle"]
    assert {name: (s.unit, s.default) for name, s in specs.items()} == {
        "k_df": ("m/y", 1e-4),  # 001 Table 1
        "k_da": ("m^(-2q)", 10.0),
        "q_area": ("1", 0.8),
        "q_slope": ("1", 2.0),
        "critical_angle": ("degrees", 37.0),
    }
    assert specs["k_df"].symbol == "K_df" and specs["critical_angle"].symbol == "s_c"
    assert specs["k_df"].raster and not specs["k_da"].raster
    assert DebrisParams().critical_slope == pytest.approx(0.75355405, rel=1e-8)
    grid = Grid.full((6, 6), 10.0)
    for params, message in (
        (DebrisParams(k_df=-1e-4), "parameter k_df must be ≥ 0"),
        (DebrisParams(q_slope=0.5), "parameter q_slope must be ≥ 1"),
        (DebrisParams(critical_angle=0.0), "strictly between 0 and 90"),
        (DebrisParams(critical_angle=90.0), "strictly between 0 and 90"),
        (DebrisParams(k_da=np.full((6, 6), 10.0)), "scalar"),
        (DebrisParams(k_df=np.ones((3, 3))), "shape"),
    ):
        with pytest.raises(ValueError, match=message):
            params.validate(grid)


def test_backward_steps_are_refused() -> None:
    assert "not reversible" in BACKWARD_REFUSAL
    grid = Grid.full((6, 6), 10.0)
    h = cone((6, 6), 10.0, 10.0, 2.0)
    with pytest.raises(ValueError, match=re.escape(BACKWARD_REFUSAL)):
        step(h, grid, outlet_mask(grid, "all"), DebrisParams(), -10.0)


@pytest.mark.parametrize("direction", [(1.0, 0.0), (0.6, 0.8), (1.0, 1.0)])
def test_plane_below_the_critical_slope_does_not_move(direction) -> None:
    grid = Grid.full((20, 24), 10.0, 12.0)
    rows, cols = np.mgrid[0:20, 0:24]
    ux, uy = np.array(direction) / np.hypot(*direction)
    slope = 0.999 * S_C  # |∇z| just below s_c, in the steepest direction
    h = 500.0 + slope * (ux * cols * 10.0 + uy * rows * 12.0)
    change = step(h, grid, outlet_mask(grid, "all"), DebrisParams(k_df=2.5e-4), 1e9)
    assert (change.dh == 0.0).all()
    assert change.budget == type(change.budget)(0.0, 0.0, 0.0)


@pytest.mark.parametrize("q_slope", [1.0, 2.0, 2.5, 3.0])
def test_the_implicit_equation_of_eq_8_is_solved(q_slope: float) -> None:
    # Δh = −dt·k_df·(1 + k_da·A^q)·max(0, S⁺ − s_c)^q' with S⁺ the steepest slope at the end of
    # the step towards the neighbours downstream in the order (NumPy, independent of the kernel)
    ny, nx, dx, dy = 36, 40, 20.0, 25.0
    valid = np.ones((ny, nx), dtype=bool)
    valid[5:9, 28:33] = False  # a nodata hole: its shore is an outlet
    grid = Grid(dx, dy, valid)
    h = rugged((ny, nx), 22.0, 1)
    h[~valid] = np.nan
    before = h.copy()
    fixed = outlet_mask(grid, "all")
    rng = np.random.default_rng(2)
    k_df = rng.uniform(1e-4, 2.5e-4, (ny, nx))
    params = DebrisParams(k_df=k_df, k_da=10.0, q_area=0.8, q_slope=q_slope, critical_angle=37.0)
    routing = route(h, grid, fixed, "d8")
    dt = 200.0
    change = step(h, grid, fixed, params, dt, routing=routing)
    np.testing.assert_array_equal(h, before)  # the input is not modified
    dh = change.dh
    assert (dh[~valid] == 0.0).all() and (dh[fixed] == 0.0).all() and (dh <= 0.0).all()
    new = np.where(valid, h + dh, np.nan)
    after = steepest_slope(new, valid, dx, dy, positions(routing.order, grid.shape))
    area = drainage_area(routing)
    free = valid & ~fixed
    expected = -dt * k_df * (1 + 10.0 * area**0.8) * np.maximum(0.0, after - S_C) ** q_slope
    eroded = dh < 0
    assert 0.1 * free.sum() < eroded.sum() < 0.9 * free.sum()  # some cells erode, not all
    np.testing.assert_allclose(dh[free], expected[free], rtol=1e-8, atol=1e-10 * np.abs(dh).max())
    assert after[eroded].min() >= S_C - 1e-9  # never below s_c over the steepest descent
    assert after[~eroded & free].max() <= S_C + 1e-12  # the others stay at or below s_c
    budget = change.budget
    assert budget.eroded == pytest.approx(-dh.sum() * grid.cell_area, rel=1e-12)
    assert budget.deposited == 0.0 and budget.outflux == budget.eroded and budget.residual == 0.0
    # the routing computed inside is the D8 one towards the fixed cells
    np.testing.assert_array_equal(step(h, grid, fixed, params, dt).dh, dh)
    with pytest.raises(ValueError, match="other outlets"):
        step(h, grid, outlet_mask(grid, "N"), params, dt, routing=routing)


def test_small_steps_agree_with_the_explicit_eq_8() -> None:
    ny, nx, dx, dy = 31, 35, 10.0, 10.0
    grid = Grid.full((ny, nx), dx, dy)
    h = cone((ny, nx), dx, dy, 1.6)
    fixed = outlet_mask(grid, "all")
    params = DebrisParams()
    routing = route(h, grid, fixed, "d8")
    dt = 1e-3
    change = step(h, grid, fixed, params, dt, routing=routing)
    slope = steepest_slope(h, grid.valid, dx, dy)  # 001 Eq. 8 at time t, D8 slope
    rate = 1e-4 * (1 + 10.0 * drainage_area(routing) ** 0.8) * np.maximum(0.0, slope - S_C) ** 2
    free = ~fixed
    np.testing.assert_allclose(change.dh[free] / dt, -rate[free], rtol=1e-3)
    assert rate[free].min() > 0.0


def test_steep_cone_relaxes_towards_the_critical_slope() -> None:
    # Without the drainage term (k_da = 0) Eq. 8 only wears slopes down towards s_c: the
    # steepest slope anywhere never grows. (With k_da > 0 cells of larger drainage area erode
    # faster and may steepen the slopes beside them: that is how 001 gets its gullies.)
    ny, nx, dx, dy = 41, 31, 10.0, 12.0
    grid = Grid.full((ny, nx), dx, dy)
    h = cone((ny, nx), dx, dy, 1.5)
    fixed = outlet_mask(grid, "all")
    params = DebrisParams(k_df=2.5e-4, k_da=0.0)
    maxima = [steepest_slope(h, grid.valid, dx, dy)[~fixed].max()]
    for _ in range(10):
        routing = route(h, grid, fixed, "d8")
        change = step(h, grid, fixed, params, 1e5, routing=routing)
        assert (change.dh <= 0.0).all() and np.isfinite(change.dh).all()
        new = h + change.dh
        eroded = change.dh < 0
        after = steepest_slope(new, grid.valid, dx, dy, positions(routing.order, grid.shape))
        assert after[eroded].min() >= S_C - 1e-9
        h = new
        maxima.append(steepest_slope(h, grid.valid, dx, dy)[~fixed].max())
    assert maxima[0] == pytest.approx(1.5, rel=1e-3)
    assert (np.diff(maxima) <= 1e-12).all()  # monotone
    assert maxima[-1] < 0.95 * maxima[0]  # measured: 1.50 → 1.27
    assert min(maxima) > S_C


def test_a_huge_step_is_stable_and_makes_no_pits() -> None:
    ny, nx, dx, dy = 40, 44, 15.0, 15.0
    valid = np.ones((ny, nx), dtype=bool)
    valid[30:34, 6:10] = False
    grid = Grid(dx, dy, valid)
    h = rugged((ny, nx), 15.0, 3)
    h[~valid] = np.nan
    fixed = outlet_mask(grid, "all")
    routing = route(h, grid, fixed, "d8")
    pits_before = pits(h, valid, fixed)
    assert pits_before.any()  # the noise leaves some
    change = step(h, grid, fixed, DebrisParams(), 1e12, routing=routing)
    assert np.isfinite(change.dh).all()
    new = np.where(valid, h + change.dh, np.nan)
    pits_after = pits(new, valid, fixed)
    assert not (pits_after & ~pits_before).any()
    eroded = change.dh < 0
    after = steepest_slope(new, valid, dx, dy, positions(routing.order, grid.shape))
    # every eroding cell ends at the critical slope over its steepest downstream neighbour
    assert eroded.sum() > 100
    assert after[eroded].min() >= S_C - 1e-9
    assert after[eroded].max() <= S_C + 1e-3  # measured: s_c + 7e-5
    assert change.budget.eroded > 0 and change.budget.residual == 0.0


def test_larger_drainage_area_erodes_more_at_equal_slope() -> None:
    # A plane dipping south with outlets on the south edge: every cell drains due south, so
    # the row r (from the north) has A = (r + 1)·dx·dy and the same slope everywhere.
    ny, nx, dx, dy = 30, 6, 10.0, 10.0
    grid = Grid.full((ny, nx), dx, dy)
    rows = np.mgrid[0:ny, 0:nx][0]
    slope = 1.2
    h = 1000.0 - slope * rows * dy
    fixed = outlet_mask(grid, "S")
    dt = 1e-4  # the implicit correction, O(dt·K'·(S − s_c)/L), is then < 1e-5
    area = (rows + 1) * dx * dy
    for k_da in (0.0, 10.0):
        change = step(h, grid, fixed, DebrisParams(k_da=k_da), dt)
        column = change.dh[:-1, 2]
        explicit = -dt * 1e-4 * (1 + k_da * area[:-1, 2] ** 0.8) * (slope - S_C) ** 2
        np.testing.assert_allclose(column, explicit, rtol=1e-4)
        if k_da:
            assert (np.diff(column) < 0).all()  # further down, more area, more erosion
            assert column[-1] / column[0] == pytest.approx(
                (1 + k_da * area[-2, 2] ** 0.8) / (1 + k_da * area[0, 2] ** 0.8), rel=1e-4
            )  # measured ratio ≈ 14.8
        else:
            np.testing.assert_allclose(column, column[0], rtol=1e-4)
