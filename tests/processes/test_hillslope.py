"""Hill-slope diffusion (001 §6.4) by Peaceman–Rachford ADI, against analytic solutions,
a dense-matrix computation of the same scheme and conservation of mass."""

from __future__ import annotations

import re

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.processes.hillslope import (
    BACKWARD_REFUSAL,
    PARAMETERS,
    HillslopeParams,
    step,
)


def rough_surface(shape: tuple[int, int], seed: int) -> np.ndarray:
    """Smooth hills plus noise at the cell scale (m), 100-400 m."""
    rng = np.random.default_rng(seed)
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    hills = 100.0 * np.sin(cols / 3.0) * np.cos(rows / 4.0)
    return 250.0 + hills + 50.0 * rng.random(shape)


def run(h: np.ndarray, grid: Grid, fixed: np.ndarray, params: HillslopeParams, dts) -> np.ndarray:
    for dt in dts:
        h = h + step(h, grid, fixed, params, dt).dh
    return h


def test_parameters_are_declared_and_validated() -> None:
    assert [spec.name for spec in PARAMETERS] == ["k_h", "uplift"]
    k_h = PARAMETERS[0]
    assert (k_h.unit, k_h.default, k_h.minimum, k_h.raster) == ("m²/y", 0.01, 0.0, True)
    assert HillslopeParams() == HillslopeParams(k_h=0.01, uplift=0.0)  # 001 Table 1: 0.01-0.05
    grid = Grid.full((6, 6), 10.0)
    h = rough_surface((6, 6), 0)
    no_fixed = np.zeros((6, 6), dtype=bool)
    with pytest.raises(ValueError, match="parameter k_h must be ≥ 0"):
        step(h, grid, no_fixed, HillslopeParams(k_h=-0.01), 100.0)
    with pytest.raises(ValueError, match="shape"):
        HillslopeParams(k_h=np.ones((3, 3))).validate(grid)
    with pytest.raises(ValueError, match="shape"):
        step(h, grid, np.zeros((5, 6), dtype=bool), HillslopeParams(), 100.0)
    assert not step(h, grid, no_fixed, HillslopeParams(k_h=0.05), 0.0).dh.any()


def test_backward_diffusion_is_refused() -> None:
    assert "ill-posed" in BACKWARD_REFUSAL and "without bound" in BACKWARD_REFUSAL
    grid = Grid.full((5, 5), 10.0)
    h = rough_surface((5, 5), 1)
    with pytest.raises(ValueError, match=re.escape(BACKWARD_REFUSAL)):
        step(h, grid, np.zeros((5, 5), dtype=bool), HillslopeParams(), -1.0)


@pytest.mark.parametrize(("dx", "dy"), [(8.0, 8.0), (8.0, 12.0)])
def test_gaussian_hill_follows_the_heat_kernel(dx: float, dy: float) -> None:
    # 2-D heat kernel: h = A σ0²/(σ0² + 2kt) exp(−r²/(2(σ0² + 2kt))); the domain reaches
    # 5.5 final standard deviations, where the hill is < 1e-6 of its peak (edges don't matter).
    sigma0, k, amplitude = 80.0, 0.05, 100.0
    half = 5.5 * np.sqrt(2.0) * sigma0
    nx, ny = 2 * int(half / dx) + 1, 2 * int(half / dy) + 1
    x = (np.arange(nx) - nx // 2) * dx
    y = (np.arange(ny) - ny // 2) * dy
    r2 = x[None, :] ** 2 + y[:, None] ** 2
    grid = Grid.full((ny, nx), dx, dy)
    h0 = amplitude * np.exp(-r2 / (2 * sigma0**2))
    duration = sigma0**2 / (2 * k)  # the variance doubles, the peak halves
    dt = duration / 5
    assert dt > 20 * min(dx, dy) ** 2 / (4 * k)  # far beyond the explicit limit
    h = run(h0, grid, np.zeros(grid.shape, dtype=bool), HillslopeParams(k_h=k), [dt] * 5)
    s2 = sigma0**2 + 2 * k * duration
    exact = amplitude * sigma0**2 / s2 * np.exp(-r2 / (2 * s2))
    error = np.abs(h - exact).max() / amplitude
    assert error < 0.01  # measured: 4.7e-4 (dx = dy), 2.7e-4 (dx ≠ dy)
    assert h.max() == pytest.approx(amplitude / 2, rel=0.01)


def test_uplifted_strip_reaches_the_parabolic_steady_state_in_a_few_long_steps() -> None:
    # 1-D steady state of 0 = U + k h'' with h(±L) = 0: h = U (L² − x²) / (2 k).
    nx, ny, dx, dy = 41, 3, 25.0, 40.0
    grid = Grid.full((ny, nx), dx, dy)
    fixed = np.zeros((ny, nx), dtype=bool)
    fixed[:, [0, -1]] = True
    uplift, k = 1e-4, 0.02
    x = (np.arange(nx) - nx // 2) * dx
    length = x[-1]
    exact = uplift * (length**2 - x**2) / (2 * k)
    # Long steps cycling over the spectrum of the operator (Wachspress-like parameters): each
    # step damps the modes of decay rate λ ≈ 2/dt; λ spans π²k/(2L)² … 4k/dx².
    lam_min, lam_max = k * np.pi**2 / (2 * length) ** 2, 4 * k / dx**2
    cycle = list(2.0 / np.geomspace(lam_max, lam_min, 8))
    explicit_limit = dx**2 / (2 * k)
    assert max(cycle) > 500 * explicit_limit
    h = run(np.zeros((ny, nx)), grid, fixed, HillslopeParams(k_h=k, uplift=uplift), cycle * 2)
    error = np.abs(h - exact[None, :]).max() / exact.max()
    assert error < 0.01  # measured: 4.6e-6 after 16 steps
    assert (h[:, [0, -1]] == 0.0).all()
    np.testing.assert_allclose(h, np.broadcast_to(h[1], h.shape), rtol=1e-12)  # no y flux


def pr_step_dense(h, valid, fixed, k, uplift, dx, dy, dt):
    """The Peaceman–Rachford step written with dense matrices: finite-volume Laplacians Lx,
    Ly (harmonic-mean face conductivities, closed faces to nodata and outside), identity rows
    for fixed and nodata cells."""
    ny, nx = h.shape
    n = ny * nx
    lx, ly = np.zeros((n, n)), np.zeros((n, n))
    idx = np.arange(n).reshape(ny, nx)
    for r in range(ny):
        for c in range(nx):
            for dr, dc, lap, d in ((0, 1, lx, dx), (1, 0, ly, dy)):
                rr, cc = r + dr, c + dc
                if rr >= ny or cc >= nx or not (valid[r, c] and valid[rr, cc]):
                    continue
                g = 2 * k[r, c] * k[rr, cc] / (k[r, c] + k[rr, cc]) / d**2
                i, j = idx[r, c], idx[rr, cc]
                lap[i, i] -= g
                lap[i, j] += g
                lap[j, j] -= g
                lap[j, i] += g
    free = (valid & ~fixed).ravel()
    lx[~free], ly[~free] = 0.0, 0.0
    tau, eye = dt / 2, np.eye(n)
    source = np.where(free, tau * uplift.ravel(), 0.0)
    v = np.where(valid, h, 0.0).ravel()
    half = np.linalg.solve(eye - tau * lx, (eye + tau * ly) @ v + source)
    new = np.linalg.solve(eye - tau * ly, (eye + tau * lx) @ half + source)
    return new.reshape(ny, nx)


def test_one_step_equals_the_scheme_written_with_dense_matrices() -> None:
    # wider than the 128-column blocks of the y sweep, so that a block boundary is crossed
    ny, nx, dx, dy = 6, 133, 20.0, 30.0
    rng = np.random.default_rng(3)
    valid = np.ones((ny, nx), dtype=bool)
    valid[2:4, 3] = False
    valid[5, 6] = False
    valid[1:3, 127:129] = False
    fixed = np.zeros((ny, nx), dtype=bool)
    fixed[0, :4] = True
    fixed[5, 8] = True
    fixed[4, 130] = True
    k = rng.uniform(0.01, 0.05, (ny, nx))
    k[~valid] = np.nan  # a parameter map may hold nodata where the DEM does
    uplift = rng.uniform(0.0, 1e-3, (ny, nx))
    h = rough_surface((ny, nx), 4)
    h[~valid] = np.nan
    grid = Grid(dx, dy, valid)
    for dt in (50.0, 5e4, 1e8):
        change = step(h, grid, fixed, HillslopeParams(k_h=k, uplift=uplift), dt)
        expected = pr_step_dense(h, valid, fixed, np.nan_to_num(k, nan=1.0), uplift, dx, dy, dt)
        free = valid & ~fixed
        np.testing.assert_allclose((h + change.dh)[free], expected[free], rtol=1e-10, atol=1e-10)
        assert (change.dh[~free] == 0.0).all()
        assert np.isfinite(change.dh).all()


def test_mass_is_conserved_with_closed_edges_and_nodata_carries_no_flux() -> None:
    ny, nx, dx, dy = 40, 50, 30.0, 20.0
    valid = np.ones((ny, nx), dtype=bool)
    valid[:, 24] = False  # a nodata wall splits the domain in two
    valid[10:15, 5:9] = False  # and a nodata hole
    grid = Grid(dx, dy, valid)
    rng = np.random.default_rng(5)
    k = rng.uniform(0.01, 0.05, (ny, nx))
    h = rough_surface((ny, nx), 6)
    h[~valid] = np.nan
    before = h.copy()
    no_fixed = np.zeros((ny, nx), dtype=bool)
    left, right = valid.copy(), valid.copy()
    left[:, 24:] = False
    right[:, :25] = False
    area = grid.cell_area
    for dt in (100.0, 1e4, 1e7):
        change = step(h, grid, no_fixed, HillslopeParams(k_h=k), dt)
        np.testing.assert_array_equal(h, before)  # the input is not modified
        budget = change.budget
        assert budget.eroded > 1e3  # it does move material (m³)
        for part in (left, right):  # no flux through the wall: each part keeps its volume
            assert abs(change.dh[part].sum() * area) <= 1e-10 * budget.eroded
        assert abs(budget.outflux) <= 1e-10 * budget.eroded
        assert budget.deposited == pytest.approx(budget.eroded, rel=1e-10)
        assert (change.dh[~valid] == 0.0).all()
    # what happens on the right of the wall does not depend on the left, bit for bit
    other = h.copy()
    other[left] += 50.0 * rng.random(np.count_nonzero(left))
    params = HillslopeParams(k_h=k)
    np.testing.assert_array_equal(
        step(other, grid, no_fixed, params, 1e4).dh[right], step(h, grid, no_fixed, params, 1e4).dh[right]
    )
    # with uplift the volume grows by exactly Σ U·dt·A
    uplift = rng.uniform(0.0, 1e-3, (ny, nx))
    change = step(h, grid, no_fixed, HillslopeParams(k_h=k, uplift=uplift), 1e4)
    gained = change.dh[valid].sum() * area
    assert gained == pytest.approx(uplift[valid].sum() * 1e4 * area, rel=1e-12)
    assert abs(change.budget.outflux) <= 1e-10 * change.budget.eroded


def test_fixed_cells_keep_their_elevation_and_the_budget_counts_what_leaves() -> None:
    ny, nx = 30, 30
    grid = Grid.full((ny, nx), 25.0)
    fixed = np.zeros((ny, nx), dtype=bool)
    fixed[[0, -1], :] = True
    fixed[:, [0, -1]] = True
    fixed[14, 14] = True  # an interior Dirichlet node too
    h = rough_surface((ny, nx), 8)
    params = HillslopeParams(k_h=0.03, uplift=2e-4)
    for dt in (10.0, 1e5):
        change = step(h, grid, fixed, params, dt)
        assert (change.dh[fixed] == 0.0).all()
        np.testing.assert_array_equal((h + change.dh)[fixed], h[fixed])
        free = ~fixed
        e = change.dh[free] - 2e-4 * dt
        budget = change.budget
        assert budget.eroded == pytest.approx(np.maximum(0, -e).sum() * grid.cell_area, rel=1e-12)
        assert budget.deposited == pytest.approx(np.maximum(0, e).sum() * grid.cell_area, rel=1e-12)
        # the volume lost by the free cells, uplift aside, left through the fixed cells
        assert budget.outflux == pytest.approx(-e.sum() * grid.cell_area, rel=1e-9)
        assert budget.residual == pytest.approx(0.0, abs=1e-9 * budget.eroded)
