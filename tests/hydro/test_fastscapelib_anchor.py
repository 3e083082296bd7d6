"""Routing against fastscapelib's routers, cell for cell (skipped where it is not installed).

fastscapelib is a bench-only dependency (``make bench`` installs it when it can); these tests
run wherever it is importable. Both libraries route the same priority-flooded surface, so
the comparison is on receivers and weights alone.
"""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.hydro import drainage_area, outlet_mask, route

fs = pytest.importorskip("fastscapelib")

N = 40
DX = 30.0


def _graph(filled: np.ndarray, router) -> tuple[object, object]:
    """fastscapelib's grid and flow graph routed over ``filled``; the graph does not own its
    grid, so callers keep both."""
    grid = fs.RasterGrid([N, N], [DX, DX], fs.NodeStatus.FIXED_VALUE)
    graph = fs.FlowGraph(grid, [router])
    graph.update_routes(filled.copy())
    return grid, graph


def _routing(z: np.ndarray, method: str):
    grid = Grid.full((N, N), DX)
    return route(z, grid, outlet_mask(grid, "all"), method)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_d8_receivers_and_ties_match_fastscapelib(seed: int) -> None:
    # Elevations on a 3 m step: many neighbours are equally steep, so the tie-breaking
    # (first neighbour in row-major order) is exercised.
    z = np.random.default_rng(seed).integers(0, 6, (N, N)) * 3.0 + 100.0
    routing = _routing(z, "d8")
    fs_grid, graph = _graph(routing.filled, fs.SingleFlowRouter())
    theirs = graph.impl().receivers[:, 0].astype(np.int64)
    free = ~routing.outlets.ravel()
    ours = routing.receivers().ravel()
    assert np.count_nonzero(ours[free] != theirs[free]) == 0
    np.testing.assert_allclose(drainage_area(routing), graph.accumulate(1.0), rtol=1e-12)


def test_mfd_weights_and_drainage_area_match_fastscapelib() -> None:
    z = np.random.default_rng(5).random((N, N)) * 10.0 + 100.0
    routing = _routing(z, "mfd")
    fs_grid, graph = _graph(routing.filled, fs.MultiFlowRouter(1.0))
    impl = graph.impl()
    receivers = impl.receivers.astype(np.int64)
    weights = impl.receivers_weight
    counts = impl.receivers_count
    offsets = np.array([-N - 1, -N, -N + 1, -1, 1, N - 1, N, N + 1])
    fractions = routing.fractions().reshape(N * N, 8)
    worst = 0.0
    for cell in np.flatnonzero(~routing.outlets.ravel()):
        theirs: dict[int, float] = {}
        for k in range(counts[cell]):
            theirs[receivers[cell, k]] = theirs.get(receivers[cell, k], 0.0) + weights[cell, k]
        ours = {cell + offsets[k]: fractions[cell, k] for k in range(8) if fractions[cell, k] > 0}
        worst = max(worst, max(abs(theirs.get(j, 0.0) - ours.get(j, 0.0))
                               for j in set(theirs) | set(ours)))
    assert worst < 1e-12
    np.testing.assert_allclose(drainage_area(routing), graph.accumulate(1.0), rtol=1e-9)
