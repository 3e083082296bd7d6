"""Depression routing on the 3D receivers (002 §6.2 after Fastflow, Jain et al. 2024; the basin
graph of Cordonnier, Bovy & Braun 2019).

The receivers of ``water_receivers`` end at the domain's exits or at local minima (pits).
A *basin* is the set of cells whose receivers lead to the same end: basin 0 is everything
that drains out of the domain, basins 1..n those of the n pits (numbered in cell order).
Water fills a pit's basin until it overflows at its lowest *pass* into a neighbouring basin:

1. Passes. Two horizontally adjacent cells of different basins through which water can pass
   (empty cells and surface cells; walls and buried rock cannot be flooded) link their
   basins at the level max(e_c, e_n), where e is a surface cell's proxy elevation z_c and
   an empty cell's floor (water must rise to it to enter). Between two basins only the lowest
   link counts (ties: the lowest cell index). Pairs of empty cells over two empty cells are
   left out: the pair below links the same basins lower down (an empty cell belongs to the
   basin of the cell it falls onto).
2. Minimum spanning tree of the basin graph (``scipy.sparse.csgraph``; weights the ranks of
   the pass levels, so ties are broken the same way on every run), rooted at basin 0 by a
   breadth-first search: each basin overflows into its parent, across the tree's edge.
3. Rerouting: each pit's receiver becomes the cell of the pass on its parent's side (the
   simple correction of Cordonnier et al. 2019, used by Fastflow): the pit's basin drains
   through the pit, then the pass, and the tree leads every such chain out of the domain.
4. Sealed basins: a basin the tree does not connect to basin 0 has no pass to the outside,
   e.g. a cavity closed in the rock; 002 "remove[s] all the nodes of this basin from the
   computation": its cells get the receiver ``SEALED`` and carry no water.

``topological_order`` orders the cells that carry water so that each comes before its
receiver (Kahn's algorithm), the order in which ``discharge`` accumulates; the same order read
backwards labels the basins.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree

from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.water_receivers import EXIT, PIT, SEALED, SOLID, WaterReceivers, is_surface


@dataclass(frozen=True)
class Routing:
    """The receivers after depression routing.

    Attributes:
        grid: the grid (``WaterReceivers.grid``).
        top: proxy elevations (m), ``WaterReceivers.top``.
        receiver: ``int64 (nx·ny·nz,)``: the receiving cell, ``EXIT``, ``SOLID`` or ``SEALED``
            (no ``PIT`` is left).
        order: the cells that carry water, each before its receiver (``topological_order``).
        basin: basin of each cell before rerouting, ``int32 (nx·ny·nz,)``: 0 drains out of
            the domain, k ≥ 1 the basin of the k-th pit; −1 for solid rock.
        pits: number of local minima (basins 1..pits).
        sealed: number of sealed basins (module docstring, 4).
    """

    grid: Grid3D
    top: np.ndarray
    receiver: np.ndarray
    order: np.ndarray
    basin: np.ndarray
    pits: int
    sealed: int


def topological_order(receiver: np.ndarray, top: np.ndarray) -> np.ndarray:
    """The cells that carry water, each before its receiver (Kahn's algorithm): the filled
    cells routed by ``receiver`` (``int64``: receiving cell, or a code; neither ``SOLID`` nor
    ``SEALED``) and the empty cells that one of them drains into. The other empty cells carry
    no water (nothing but filled cells drains into an empty cell) and are left out. ``top``
    tells the filled cells (> −∞, ``WaterReceivers.top``). RuntimeError if the receivers form
    a cycle."""
    order, routed = _order(receiver, top.reshape(-1))
    if order.size != routed:
        raise RuntimeError(f"the water receivers form a cycle through {routed - order.size} cells")
    return order


def route_depressions(receivers: WaterReceivers) -> Routing:
    """Reroute the pits of ``receivers`` through their basins' passes (module docstring)."""
    receiver, top = receivers.receiver, receivers.top
    order = topological_order(receiver, top)
    pits = np.flatnonzero(receiver == PIT)
    basin = _basins(order, receiver, pits)
    grid = receivers.grid
    if pits.size == 0:
        return Routing(grid, top, receiver, order, basin, 0, 0)
    rerouted = receiver.copy()
    reached = _reroute(*_passes(top, basin, grid), pits, rerouted)
    sealed = ~reached
    if sealed.any():
        rerouted[(basin > 0) & sealed[np.maximum(basin, 0)]] = SEALED
    return Routing(grid, top, rerouted, topological_order(rerouted, top), basin, int(pits.size),
                   int(sealed.sum()))


def _passes(top: np.ndarray, basin: np.ndarray, grid: Grid3D
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The lowest pass between each pair of adjacent basins (module docstring, 1), sorted by
    the basins: the two basins (the lower number first), the pass's level (m), and its cells
    in either basin."""
    nx, ny, _ = grid.shape
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    nothing = np.zeros(0, dtype=np.int64)
    _links(top, basin, grid.origin[2], grid.h, start, nothing, nothing, np.zeros(0), False)
    total = int(start.sum())
    start[1:] = np.cumsum(start[:-1])
    start[0] = 0
    cells = np.empty((2, total), dtype=np.int64)
    level = np.empty(total)
    _links(top, basin, grid.origin[2], grid.h, start, cells[0], cells[1], level, True)
    swap = basin[cells[0]] > basin[cells[1]]
    cells[:, swap] = cells[::-1, swap]
    lower, upper = basin[cells[0]], basin[cells[1]]
    key = np.lexsort((cells[1], cells[0], level, upper, lower))
    lower, upper, level, cells = lower[key], upper[key], level[key], cells[:, key]
    first = np.ones(lower.size, dtype=bool)
    first[1:] = (lower[1:] != lower[:-1]) | (upper[1:] != upper[:-1])
    return lower[first], upper[first], level[first], cells[0, first], cells[1, first]


def _reroute(lower: np.ndarray, upper: np.ndarray, level: np.ndarray, cell_lower: np.ndarray,
             cell_upper: np.ndarray, pits: np.ndarray, receiver: np.ndarray) -> np.ndarray:
    """Point the pit of each basin connected to the outside at the cell of its pass on its
    parent's side (module docstring, 2–3), in place; returns which basins are connected to
    basin 0, ``bool (pits + 1,)``."""
    by_rank = np.lexsort((upper, lower, level))
    rank = np.empty(level.size)
    rank[by_rank] = np.arange(1, level.size + 1)  # > 0: scipy ignores edges of weight 0
    count = pits.size + 1
    graph = coo_matrix((rank, (lower, upper)), shape=(count, count)).tocsr()
    tree = minimum_spanning_tree(graph).tocoo()
    _, parent = breadth_first_order(tree, 0, directed=False, return_predecessors=True)
    reached = parent >= 0
    reached[0] = True
    a, b = tree.row.astype(np.int64), tree.col.astype(np.int64)
    inside = reached[a] & reached[b]
    a, b = a[inside], b[inside]
    edge = by_rank[np.rint(tree.data[inside]).astype(np.int64) - 1]
    child = np.where(parent[b] == a, b, a)
    receiver[pits[child - 1]] = np.where(lower[edge] == parent[child], cell_lower[edge], cell_upper[edge])
    return reached


@numba.njit(cache=True)
def _order(receiver, top):
    """Kahn's algorithm over the cells that carry water (``topological_order``); returns (the
    order found, the number of those cells)."""
    n = receiver.size
    donors = np.zeros(n, dtype=np.int32)
    carries = np.zeros(n, dtype=np.bool_)
    for c in range(n):  # the filled cells, then the empty cells they drain into
        if top[c] > -np.inf and receiver[c] != SOLID and receiver[c] != SEALED:
            carries[c] = True
            if receiver[c] >= 0:
                donors[receiver[c]] += 1
    for c in range(n):
        if top[c] == -np.inf and donors[c] > 0 and receiver[c] != SEALED:
            carries[c] = True
            if receiver[c] >= 0:
                donors[receiver[c]] += 1
    routed = 0
    for c in range(n):
        if carries[c]:
            routed += 1
    order = np.empty(routed, dtype=np.int64)
    tail = 0
    for c in range(n):
        if carries[c] and donors[c] == 0:
            order[tail] = c
            tail += 1
    head = 0
    while head < tail:
        r = receiver[order[head]]
        head += 1
        if r >= 0:
            donors[r] -= 1
            if donors[r] == 0:
                order[tail] = r
                tail += 1
    return order[:tail], routed


@numba.njit(cache=True)
def _basins(order, receiver, pits):
    """Basin of every cell: that of its receiver, read in reverse topological order, then for
    the empty cells left out of the order (they drain into a cell of the order, or out)."""
    basin = np.full(receiver.size, -1, dtype=np.int32)
    for t in range(pits.size):
        basin[pits[t]] = t + 1
    for t in range(order.size - 1, -1, -1):
        c = order[t]
        r = receiver[c]
        if r >= 0:
            basin[c] = basin[r]
        elif r == EXIT:
            basin[c] = 0
    for c in range(receiver.size):
        r = receiver[c]
        if basin[c] < 0 and r >= EXIT:
            basin[c] = basin[r] if r >= 0 else 0
    return basin


@numba.njit(cache=True, inline="always")
def _floodable(top, i, j, k):
    """Whether water can enter cell (i, j, k): an empty cell or a surface cell."""
    return top[i, j, k] == -np.inf or is_surface(top, i, j, k)


@numba.njit(cache=True, parallel=True)
def _links(top, basin, ground, h, start, cell_a, cell_b, level, write):
    """The links between adjacent basins (module docstring, 1), column by column: with
    ``write`` False, their number per column into ``start[column]``; with ``write``, the
    two cells and the level of each into the arrays from ``start[column]`` on."""
    nx, ny, nz = top.shape
    for column in numba.prange(nx * ny):
        i, j = column // ny, column % ny
        s = start[column]
        found = 0
        for k in range(nz):
            c = column * nz + k
            if basin[c] < 0 or not _floodable(top, i, j, k):
                continue
            for d in range(2):
                a, b = (i + 1, j) if d == 0 else (i, j + 1)
                if a >= nx or b >= ny:
                    continue
                n = (a * ny + b) * nz + k
                if basin[n] < 0 or basin[n] == basin[c] or not _floodable(top, a, b, k):
                    continue
                empty_c, empty_n = top[i, j, k] == -np.inf, top[a, b, k] == -np.inf
                if empty_c and empty_n and k > 0 and top[i, j, k - 1] == -np.inf \
                        and top[a, b, k - 1] == -np.inf:
                    continue
                if write:
                    floor = ground + k * h
                    cell_a[s + found] = c
                    cell_b[s + found] = n
                    level[s + found] = max(floor if empty_c else top[i, j, k],
                                           floor if empty_n else top[a, b, k])
                found += 1
        if not write:
            start[column] = found
