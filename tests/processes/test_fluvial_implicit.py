"""The implicit forward fluvial step (Braun & Willett 2013; Yuan et al. 2019) against the
slope–area law of a steady state, fastscapelib's SPLEroder, mass conservation and long steps."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio

from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask, route
from unerode_cli.processes import fluvial_implicit
from unerode_cli.processes.fluvial import FluvialParams

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
TUJUNGA = DATA / "dem" / "sangabriel_bigtujunga" / "bigtujunga.tif"


def _tujunga(size: int = 160) -> tuple[np.ndarray, Grid]:
    if not TUJUNGA.exists():
        pytest.skip("the shared Big Tujunga DEM is not beside the checkout")
    with rasterio.open(TUJUNGA) as ds:
        z = ds.read(1).astype(np.float64)[:size, :size]
        dx = abs(ds.transform.a)
    return z, Grid.full(z.shape, dx)


def _steady(params: FluvialParams, method: str, h: np.ndarray, outlets: np.ndarray, dx: float = 100.0,
            dt: float = 2e5, steps: int = 150, layout: str = "ordered") -> tuple[np.ndarray, Grid]:
    """``h`` uplifted and eroded with long implicit steps until nothing changes."""
    grid = Grid.full(h.shape, dx)
    for _ in range(steps):
        change = fluvial_implicit.step(h, grid, outlets, params, dt, method=method, layout=layout)
        assert change.converged
        h = h + change.change.dh
    last = fluvial_implicit.step(h, grid, outlets, params, dt, method=method, layout=layout).change
    assert np.abs(last.dh).max() < 1e-6 * params.uplift * dt
    return h, grid


def _rough_block(size: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """A rough block draining to all four edges: a dendritic network forms."""
    h = np.random.default_rng(3).random((size, size))
    return h, outlet_mask(Grid.full(h.shape, 100.0), "all")


def _receiver_slopes(h: np.ndarray, grid: Grid, outlets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Slope to the D8 receiver and drainage area of the free cells of ``h``."""
    routing = route(h, grid, outlets, "d8")
    receivers = routing.receivers().ravel()
    free = np.flatnonzero(~outlets.ravel())
    rows, cols = np.divmod(free, grid.shape[1])
    r_rows, r_cols = np.divmod(receivers[free], grid.shape[1])
    length = np.hypot((rows - r_rows) * grid.dy, (cols - r_cols) * grid.dx)
    slope = (h.ravel()[free] - h.ravel()[receivers[free]]) / length
    area = fluvial_implicit_area(routing)
    return slope, area.ravel()[free]


def fluvial_implicit_area(routing) -> np.ndarray:
    from unerode_cli.hydro import drainage_area

    return drainage_area(routing)


@pytest.mark.parametrize("layout", fluvial_implicit.LAYOUTS)
@pytest.mark.parametrize("n", [1.0, 2.0])
def test_the_steady_state_follows_the_slope_area_law(n: float, layout: str) -> None:
    # U = K·A^m·S^n at steady state (K_d = 0, p = 1 so Q = A): S = (U / (K·A^m))^(1/n) on
    # every cell, whatever the river network that formed
    params = FluvialParams(uplift=1e-3, k=2e-5, k_d=0.0, precipitation=1.0, m=0.5, n=n)
    h, outlets = _rough_block()
    h, grid = _steady(params, "d8", h, outlets, layout=layout)
    slope, area = _receiver_slopes(h, grid, outlets)
    expected = (params.uplift / (params.k * area**params.m)) ** (1.0 / n)
    assert np.abs(slope / expected - 1.0).max() < 0.01


@pytest.mark.parametrize("layout", fluvial_implicit.LAYOUTS)
def test_the_steady_state_with_deposition_follows_yuan_et_al(layout: str) -> None:
    # With deposition (000 Eq. 3), a cell at steady state erodes its uplift plus what it traps
    # of the sediment arriving from upstream, Q̃s = U·(A − a) (a: the cell's own area):
    # K·A^m·S = U + (K_d / (p·A))·U·(A − a)   (Yuan et al. 2019, Eq. 10 with G = K_d / p).
    # One river, a column of cells draining to its south end. (On a dendritic network, D8
    # receivers of nearly equal slope swap from step to step once deposition is on, and
    # the network never settles to one steady state.)
    params = FluvialParams(uplift=1e-3, k=2e-5, k_d=1.0, precipitation=1.0, m=0.5, n=1.0)
    size = 60
    h = np.linspace(100.0, 0.0, size)[:, None] + np.random.default_rng(3).random((size, 1))
    outlets = np.zeros((size, 1), dtype=bool)
    outlets[-1, :] = True
    h, grid = _steady(params, "d8", h, outlets, layout=layout)
    slope, area = _receiver_slopes(h, grid, outlets)
    cell = grid.cell_area
    trapped = params.uplift * (area - cell) * np.minimum(params.k_d / area, 1.0 / cell)
    expected = (params.uplift + trapped) / (params.k * area**params.m)
    assert np.abs(slope / expected - 1.0).max() < 0.01


@pytest.mark.parametrize("layout", fluvial_implicit.LAYOUTS)
@pytest.mark.parametrize("method", ["d8", "mfd"])
def test_a_step_of_100_ky_stays_bounded_and_conserves_mass(method: str, layout: str) -> None:
    z, grid = _tujunga()
    outlets = outlet_mask(grid, "all")
    params = FluvialParams(uplift=1e-3, k=1e-4, k_d=1.0, precipitation=1.0, m=0.5, n=1.0)
    done = fluvial_implicit.step(z, grid, outlets, params, 1e5, method=method, layout=layout)
    assert done.converged
    new = z + done.change.dh
    assert np.isfinite(new).all()
    # no cell rises above the highest start elevation plus its uplift and deposition can only
    # fill towards it; the outlets hold
    assert new.max() <= z.max() + params.uplift * 1e5 + 1e-6
    assert np.array_equal(new[outlets], z[outlets])
    budget = done.change.budget
    assert abs(budget.residual) <= 1e-9 * budget.eroded


@pytest.mark.parametrize("layout", fluvial_implicit.LAYOUTS)
@pytest.mark.parametrize("method", ["d8", "mfd"])
@pytest.mark.parametrize("k_d", [1.0, 3.0])
def test_the_sediment_leaving_is_what_was_eroded_less_what_was_deposited(method: str, k_d: float,
                                                                         layout: str) -> None:
    z, grid = _tujunga()
    outlets = outlet_mask(grid, "all")
    params = FluvialParams(uplift=5e-4, k=1e-5, k_d=k_d, precipitation=1.0, m=0.4, n=1.0)
    for dt in (100.0, 1e4):
        done = fluvial_implicit.step(z, grid, outlets, params, dt, method=method, layout=layout)
        budget = done.change.budget
        assert done.converged and done.passes > 1
        assert budget.deposited > 0.0
        assert abs(budget.residual) <= 1e-9 * budget.eroded


def test_the_deposition_iteration_meets_its_own_equation() -> None:
    # After convergence each cell's deposition is K_d/Q times the sediment arriving from its
    # donors (000 Eq. 8), recomputed here from the returned fluxes
    z, grid = _tujunga(96)
    outlets = outlet_mask(grid, "all")
    params = FluvialParams(uplift=0.0, k=1e-5, k_d=1.0, precipitation=1.0, m=0.4, n=1.0)
    dt = 1000.0
    routing = route(z, grid, outlets, "d8")
    done = fluvial_implicit.step(z, grid, outlets, params, dt, routing=routing)
    q, qs = done.change.discharge.ravel(), done.change.sediment_flux.ravel()
    receivers = routing.receivers().ravel()
    arriving = np.zeros(q.size)
    free = np.flatnonzero(receivers >= 0)
    np.add.at(arriving, receivers[free], qs[free])
    inside = ~outlets.ravel() & (q > 0)
    trapping = np.minimum(params.k_d / q[inside], 1.0 / grid.cell_area)
    expected = arriving[inside] * trapping * dt
    used = done.deposition.ravel()[inside] * dt
    scale = np.abs(done.change.dh).max()
    assert np.abs(used - expected).max() <= 1e-5 * scale


def test_agrees_with_fastscapelib_spl_eroder() -> None:
    fs = pytest.importorskip("fastscapelib")
    z, grid = _tujunga(256)
    outlets = outlet_mask(grid, "all")
    filled = route(z, grid, outlets, "d8").filled   # both route one depression-free surface
    params = FluvialParams(uplift=0.0, k=1e-5, k_d=0.0, precipitation=1.0, m=0.5, n=1.0)
    dt = 1000.0
    ours = -fluvial_implicit.step(filled, grid, outlets, params, dt, method="d8").change.dh
    fs_grid = fs.RasterGrid(list(z.shape), [grid.dy, grid.dx], fs.NodeStatus.FIXED_VALUE)
    graph = fs.FlowGraph(fs_grid, [fs.SingleFlowRouter()])
    graph.update_routes(filled.copy())
    eroder = fs.SPLEroder(graph, params.k, params.m, params.n, 1e-5)
    theirs = eroder.erode(filled.copy(), graph.accumulate(1.0), dt)
    assert np.corrcoef(ours.ravel(), theirs.ravel())[0, 1] >= 0.999
    assert abs(ours.sum() / theirs.sum() - 1.0) < 0.01


def test_the_implicit_step_refuses_to_run_backward() -> None:
    grid = Grid.full((8, 8), 30.0)
    with pytest.raises(ValueError, match="forward"):
        fluvial_implicit.step(np.zeros((8, 8)), grid, outlet_mask(grid, "all"), FluvialParams(), -10.0)


@pytest.mark.parametrize("method", ["d8", "mfd"])
@pytest.mark.parametrize("n", [1.0, 1.5])
@pytest.mark.parametrize("k_d", [0.0, 1.0])
def test_the_lean_layout_gives_the_ordered_step(method: str, n: float, k_d: float) -> None:
    # the same equations on cell-indexed arrays: the same passes and elevations to the rounding
    # of the float32 coefficients K·Q^m·dt (≈ 1e-7 of each cell's incision)
    z, grid = _tujunga()
    outlets = outlet_mask(grid, "all")
    params = FluvialParams(uplift=5e-4, k=1e-5, k_d=k_d, precipitation=1.0, m=0.4, n=n)
    routing = route(z, grid, outlets, method)
    ordered, lean = (fluvial_implicit.step(z, grid, outlets, params, 1e4, routing=routing, layout=layout)
                     for layout in fluvial_implicit.LAYOUTS)
    assert ordered.converged and lean.converged and ordered.passes == lean.passes
    scale = np.abs(ordered.change.dh).max()
    assert np.abs(lean.change.dh - ordered.change.dh).max() <= 1e-6 * scale
    assert lean.change.budget.outflux == pytest.approx(ordered.change.budget.outflux, rel=1e-6)


@pytest.mark.parametrize("layout", fluvial_implicit.LAYOUTS)
def test_the_discharge_is_the_routings_to_float32_rounding(layout: str) -> None:
    # Q of the implicit step is the routing's accumulation of the precipitation (000 Eq. 5),
    # held in float32: hydro's float64 accumulation to float32's rounding (2^-24 of it)
    from unerode_cli.hydro import accumulate

    z, grid = _tujunga(96)
    outlets = outlet_mask(grid, "all")
    params = FluvialParams(uplift=0.0, k=1e-5, k_d=1.0, precipitation=0.7, m=0.4, n=1.0)
    routing = route(z, grid, outlets, "mfd")
    done = fluvial_implicit.step(z, grid, outlets, params, 1000.0, routing=routing, layout=layout)
    assert done.change.discharge.dtype == np.float32
    expected = accumulate(routing, 0.7)
    np.testing.assert_allclose(done.change.discharge, expected, rtol=2.0**-24, atol=0.0)
