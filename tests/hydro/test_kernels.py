"""Routing kernels against plain reference implementations: priority-flood+ε (bucket queue),
fused accumulation, work arrays reused between calls."""

from __future__ import annotations

import heapq

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.hydro import accumulate, kernels, outlet_mask, route

NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def reference_flood(z: np.ndarray, valid: np.ndarray, outlets: np.ndarray) -> np.ndarray:
    """Barnes et al. 2014 Algorithm 3 with a binary heap (heapq), for small grids."""
    ny, nx = z.shape
    zf = np.where(valid, z, np.inf).astype(float)
    closed = ~valid | outlets
    heap = [(zf[r, c], r, c) for r, c in zip(*np.nonzero(outlets), strict=True)]
    heapq.heapify(heap)
    pit: list[tuple[int, int]] = []
    while heap or pit:
        if pit and (not heap or zf[pit[0]] < heap[0][0]):
            r, c = pit.pop(0)
        else:
            _, r, c = heapq.heappop(heap)
        zc = zf[r, c]
        lifted = max(zc + kernels.FILL_EPSILON, np.nextafter(zc, np.inf))
        for dr, dc in NEIGHBOURS:
            rr, cc = r + dr, c + dc
            if not (0 <= rr < ny and 0 <= cc < nx) or closed[rr, cc]:
                continue
            closed[rr, cc] = True
            if zf[rr, cc] <= zc:
                zf[rr, cc] = lifted
                pit.append((rr, cc))
            else:
                heapq.heappush(heap, (zf[rr, cc], rr, cc))
    return zf


def reference_accumulate(routing, source: np.ndarray) -> np.ndarray:
    """acc = source + Σ_donors α·acc(donor), from ``Routing.fractions`` and ``Routing.order``."""
    ny, nx = routing.grid.shape
    fractions = routing.fractions().reshape(-1, 8)
    offsets = np.array([dr * nx + dc for dr, dc in NEIGHBOURS])
    acc = np.zeros(ny * nx)
    src = source.ravel()
    for i in routing.order:
        acc[i] += src[i]
        for k in np.nonzero(fractions[i])[0]:
            acc[i + offsets[k]] += fractions[i, k] * acc[i]
    return acc.reshape(ny, nx)


def check_valid_fill(z, valid, outlets, filled) -> None:
    """Every valid non-outlet cell has a strictly lower valid neighbour; nothing is lowered."""
    ny, nx = z.shape
    padded = np.pad(filled, 1, constant_values=np.inf)
    lowest = np.min(
        [padded[1 + dr : 1 + dr + ny, 1 + dc : 1 + dc + nx] for dr, dc in NEIGHBOURS], axis=0
    )
    free = valid & ~outlets
    assert (lowest[free] < filled[free]).all()
    assert (filled[valid] >= z[valid]).all()
    assert np.isinf(filled[~valid]).all()


@pytest.mark.parametrize("seed", range(6))
def test_bucket_queue_floods_like_a_single_heap(seed: int) -> None:
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(3, 40)), int(rng.integers(3, 40)))
    z = rng.random(shape) * 10.0 + np.arange(shape[0])[:, None] * 0.05  # no ties
    valid = rng.random(shape) > 0.1
    valid[0] = True
    outlets = np.zeros(shape, dtype=bool)
    outlets[0] = True
    outlets[rng.random(shape) > 0.97] = True
    outlets &= valid
    filled, order = kernels.priority_flood_epsilon(z, valid, outlets)
    reached = reference_flood(z, valid, outlets)
    np.testing.assert_array_equal(filled[np.isfinite(reached)], reached[np.isfinite(reached)])
    assert (np.diff(filled.ravel()[order]) <= 0).all()
    assert np.array_equal(np.sort(order), np.flatnonzero(np.isfinite(reached)))


@pytest.mark.parametrize(
    "elevation",
    [
        lambda shape, rng: np.zeros(shape),  # flat: one bucket
        lambda shape, rng: np.round(rng.random(shape) * 3.0),  # ties
        lambda shape, rng: np.where(rng.random(shape) > 0.5, 1e300, -1e300),  # span overflows
        lambda shape, rng: rng.random(shape) * 1e-12 + 5e6,  # span of a few ulps
    ],
)
def test_bucket_queue_handles_degenerate_ranges(elevation) -> None:
    rng = np.random.default_rng(7)
    shape = (23, 17)
    z = elevation(shape, rng)
    valid = rng.random(shape) > 0.2
    valid[:, 0] = True
    outlets = np.zeros(shape, dtype=bool)
    outlets[:, 0] = True
    filled, order = kernels.priority_flood_epsilon(z, valid, outlets)
    reached = np.isfinite(reference_flood(z, valid, outlets))
    assert np.array_equal(np.sort(order), np.flatnonzero(reached))
    check_valid_fill(np.where(reached, z, 0.0), reached, outlets, np.where(reached, filled, np.inf))
    assert (np.diff(filled.ravel()[order]) <= 0).all()


@pytest.mark.parametrize("method", ["mfd", "d8"])
def test_fused_accumulation_matches_the_fractions(method: str) -> None:
    rng = np.random.default_rng(3)
    grid = Grid.full((31, 26), 20.0, 30.0)
    routing = route(rng.random(grid.shape) * 5.0, grid, outlet_mask(grid, "all"), method)
    source = rng.uniform(0.5, 2.0, grid.shape)
    expected = reference_accumulate(routing, source * grid.cell_area)
    np.testing.assert_allclose(accumulate(routing, source), expected, rtol=1e-13)


def test_route_reuses_its_work_arrays_between_grids() -> None:
    results = []
    for n in (40, 25, 40):
        grid = Grid.full((n, n + 3), 10.0)
        z = np.random.default_rng(n).random(grid.shape) * 3.0
        routing = route(z, grid, outlet_mask(grid, "all"), "mfd")
        filled, order = kernels.priority_flood_epsilon(z, grid.valid, routing.outlets)
        np.testing.assert_array_equal(routing.filled, filled)
        np.testing.assert_array_equal(routing.order, order)
        results.append(routing)
    np.testing.assert_array_equal(results[0].filled, results[2].filled)
    np.testing.assert_array_equal(results[0].order, results[2].order)
