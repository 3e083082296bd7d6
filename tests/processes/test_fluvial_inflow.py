"""Rivers entering the map (000 §6.3.1): water and sediment brought in at an edge cell."""

from __future__ import annotations

import numpy as np
import pytest
from tests.processes.test_fluvial import hills

from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask, route
from unerode_cli.processes.fluvial import FluvialParams, Inflow, step

SHAPE = (30, 24)
DX = 30.0
ENTRY = (1, 12)  # one cell inside the north edge
Q_IN, QS_IN = 3.0e6, 2.0e3  # m³/y


def plane() -> np.ndarray:
    """A plane tilted 2 % towards the south edge (m)."""
    rows, cols = np.indices(SHAPE)
    return 100.0 - 0.02 * DX * rows + 0.001 * DX * np.cos(cols)


def inflow(discharge: float = Q_IN, sediment: float = QS_IN) -> Inflow:
    q, qs = np.zeros(SHAPE), np.zeros(SHAPE)
    q[ENTRY], qs[ENTRY] = discharge, sediment
    return Inflow(q, qs)


def south_outlets(grid: Grid) -> np.ndarray:
    return outlet_mask(grid, "S")


def test_inflow_sediment_alone_is_deposited_or_carried_out() -> None:
    grid = Grid(DX, DX, np.ones(SHAPE, dtype=bool))
    outlets = south_outlets(grid)
    dt = 500.0
    change = step(plane(), grid, outlets, FluvialParams(k=0.0, k_d=1.0), dt, inflow=inflow())
    budget = change.budget
    deposited = float(change.dh[~outlets].sum()) * grid.cell_area
    assert budget.eroded == 0.0
    assert budget.inflow == pytest.approx(dt * QS_IN, rel=1e-12)
    assert deposited == pytest.approx(budget.deposited, rel=1e-9)
    assert budget.deposited > 0.05 * budget.inflow and budget.outflux > 0.05 * budget.inflow
    assert budget.deposited + budget.outflux == pytest.approx(dt * QS_IN, rel=1e-9)
    assert change.sediment_flux[outlets].sum() * dt == pytest.approx(budget.outflux, rel=1e-12)
    assert (change.dh >= 0.0).all()
    assert (change.dh[: ENTRY[0]] == 0.0).all()  # nothing upstream of the entry point


@pytest.mark.parametrize("method", ["mfd", "d8"])
def test_outlet_discharge_grows_by_the_inflow_discharge(method: str) -> None:
    grid = Grid(DX, DX, np.ones(SHAPE, dtype=bool))
    outlets = south_outlets(grid)
    routing = route(plane(), grid, outlets, method)
    params = FluvialParams(k=1e-5, precipitation=0.7)
    without = step(plane(), grid, outlets, params, 100.0, routing=routing)
    with_inflow = step(plane(), grid, outlets, params, 100.0, routing=routing, inflow=inflow())
    rain = 0.7 * grid.cell_area * SHAPE[0] * SHAPE[1]
    assert without.discharge[outlets].sum() == pytest.approx(rain, rel=1e-12)
    assert with_inflow.discharge[outlets].sum() - without.discharge[outlets].sum() == pytest.approx(
        Q_IN, rel=1e-9)
    assert with_inflow.discharge[ENTRY] == pytest.approx(Q_IN + without.discharge[ENTRY], rel=1e-15)


@pytest.mark.parametrize("dt", [400.0, -400.0])
def test_budget_closes_with_inflow_forward_and_backward(dt: float) -> None:
    grid = Grid(DX, DX, np.ones(SHAPE, dtype=bool))
    h = hills(SHAPE, DX)
    outlets = outlet_mask(grid, "N,E,S,W")
    outlets[ENTRY[0] - 1, ENTRY[1] - 1 : ENTRY[1] + 2] = False
    entry = inflow(2.0e5, 5.0e3)
    change = step(h, grid, outlets, FluvialParams(k=2e-5, k_d=0.5), dt, inflow=entry)
    budget = change.budget
    removed = -change.dh[change.dh < 0].sum() * grid.cell_area
    added = change.dh[change.dh > 0].sum() * grid.cell_area
    assert budget.eroded == pytest.approx(removed, rel=1e-9)
    assert budget.deposited == pytest.approx(added, rel=1e-9)
    assert budget.inflow == pytest.approx(dt * 5.0e3, rel=1e-12)  # negative backward: sent back
    assert abs(budget.residual) <= 1e-9 * max(budget.eroded, budget.deposited)


def test_backward_inflow_undoes_forward_deposition() -> None:
    """With K = 0, a backward step un-deposits what a forward step of the same inflow put down."""
    grid = Grid(DX, DX, np.ones(SHAPE, dtype=bool))
    outlets = south_outlets(grid)
    params = FluvialParams(k=0.0, k_d=1.0)
    forward = step(plane(), grid, outlets, params, 20.0, inflow=inflow())
    backward = step(plane() + forward.dh, grid, outlets, params, -20.0, inflow=inflow())
    # the deposit of the forward step shifts the routing a little, hence 2 %
    assert backward.budget.eroded == pytest.approx(forward.budget.deposited, rel=0.02)
    assert backward.budget.deposited == 0.0
    assert backward.budget.inflow == pytest.approx(-forward.budget.inflow, rel=1e-12)
    assert backward.budget.outflux < 0.0  # what the deposits do not give back comes in at the outlets
    assert abs(backward.budget.residual) <= 1e-9 * backward.budget.eroded
    assert (backward.dh <= 0.0).all()
