"""Deposition of eroded particles (002 §7): each falls to the nearest stable cell below it.

On the occupancy grid, a cell with particles whose upper neighbour is empty (or the grid's top)
is a *surface cell*; its proxy elevation is its floor plus its fill, z_c = z_floor +
h·min(n/n_full, 1) with n its particle count and n_full = ``particles_per_cell``. Below the
grid lies the ground (z = the grid's origin), a surface wherever the cell above it is empty.
Every cell has one receiver, where an eroded particle in it goes next:

- an empty cell: the surface cell it falls onto, straight down (or the ground);
- a cell with particles and an empty cell below (a ceiling): where that cell falls onto;
- a surface cell: *stable* when no neighbour of the 8 around it at its level is lower by more
  than the angle of repose (drop / distance > tan θ, distances h and h√2). An unstable one
  gives to one of its too-low neighbours, chosen at random with a probability proportional to
  the slope; a neighbour's height is that of the surface it would fall onto (its own if it is
  a surface cell); beyond the grid's sides lies ground, where a particle is *exported*;
- a cell with particles under a full one (a wall): the surface below one of its empty
  side neighbours, at random (beyond the grid's side: exported); with none (buried), the cell
  above.

002 §7 starts these pointers at the water's receivers of §6.2 (``water_receivers``, after
depression routing). Off the surface they are the same rule (empty cells fall, ceilings drop,
walls shed sideways at random); on the surface a grain follows gravity only, for these reasons:
- it leaves a cell only toward a neighbour lower by more than the angle of repose, and among
  8 neighbours, not 4, so that a pile's flank keeps one angle all around (with the water's 4,
  a slope along a diagonal would stand at atan(√2 tan θ));
- heights are fills counted in particles, which resolve an eighth of a cell, where the water's
  proxy, the highest particle, stands up to half a cell above a partly filled cell's fill;
- the deposition grid moves by a random offset every frame (002 §7, below), the water's grid
  does not, so the water's receivers are not those of the cells a grain is counted in;
- depression routing changes nothing for a grain: a pit (no lower neighbour) is stable, so
  its pointer stops there before the rerouted link to the pass, and a sealed cavity keeps
  what falls into it.

Moves from a surface cell go to a strictly lower one, so the chains end (at a stable cell, or
the export sink); pointer jumping p(c) ← p(p(c)) for ⌈log₂ n⌉ rounds over the n surface cells
(and open ground) finds their ends (002: "the total number of surface cells"). The other
cells lead to a surface in one step (a buried one after climbing its column), so each eroded
particle walks that step itself and takes its surface cell's end. It is then placed at
random in its end cell's footprint, stacked from the proxy elevation up by h/n_full per
particle (002: "increasing after each deposited particle to maintain a target particle
density").

The deposition grid is best coarser than the particle spacing (the MPM grid, 8 particles per
cell): heights then resolve an eighth of a cell, and a pile's flank stands within a couple of
degrees of θ; on a grid of one particle per cell every step is a whole cell and the piles
stand as terraces at about 45° whatever θ below that.

Random choices come from a counter-based hash of (seed, frame, cell or particle), so results
do not depend on the number of threads. 002 moves the grid by a random offset at every
deposition against staircase artefacts: ``offset_grid`` gives that grid for a frame, on which
the caller counts the occupancy it passes to ``deposit``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.hashing import (
    DRAW_OFFSET_X,
    DRAW_OFFSET_Y,
    DRAW_RECEIVER,
    DRAW_WALL,
    DRAW_X,
    DRAW_Y,
    uniform,
)

#: The 8 horizontal neighbours (di, dj) and their distances in cells.
_NEIGHBOURS = np.array([(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)],
                       dtype=np.int64)
#: The 4 side neighbours a particle leaves a wall by.
_SIDES = _NEIGHBOURS[:4].copy()
_DISTANCES = np.array([1.0, 1.0, 1.0, 1.0, math.sqrt(2.0), math.sqrt(2.0), math.sqrt(2.0), math.sqrt(2.0)])


@dataclass(frozen=True)
class DepositionParams:
    """Parameters of deposition (002 §7, Table 1).

    Attributes:
        repose_angle: angle of repose θ (degrees) of the deposit; a surface cell is stable
            when no neighbour lies lower by more than tan θ × distance.
        deposit_viability: viability b given to deposited particles (002 Table 1: 0 to 0.2);
            read by the caller, which creates them.
        particles_per_cell: particles that fill a cell of the deposition grid: 8 on the MPM
            grid (cells two sampling spacings wide). A deposit's heights come in steps of
            h/particles_per_cell, so the grid of one particle per cell would quantise them to
            whole cells and no slope below 45° could hold (module docstring).
    """

    repose_angle: float = 33.0
    deposit_viability: float = 0.0
    particles_per_cell: int = 8

    def __post_init__(self) -> None:
        if not 0.0 <= self.repose_angle < 90.0:
            raise ValueError(f"the angle of repose must lie in [0, 90) degrees, not {self.repose_angle}")
        if not (math.isfinite(self.deposit_viability) and self.deposit_viability >= 0.0):
            raise ValueError(f"the deposit viability must be finite and ≥ 0, not {self.deposit_viability}")
        if self.particles_per_cell < 1:
            raise ValueError(f"a cell must hold at least one particle, not {self.particles_per_cell}")


def offset_grid(grid: Grid3D, seed: int, frame: int) -> Grid3D:
    """``grid`` moved horizontally by a random fraction of a cell for ``frame`` (002 §7) and
    grown by one cell along x and y, so that it still covers ``grid``; the ground stays at
    the same height."""
    u = np.array([uniform(seed, frame, 0, DRAW_OFFSET_X), uniform(seed, frame, 0, DRAW_OFFSET_Y)])
    x, y, z = grid.origin
    nx, ny, nz = grid.shape
    return Grid3D((x - u[0] * grid.h, y - u[1] * grid.h, z), grid.h, (nx + 1, ny + 1, nz))


def deposit(eroded: np.ndarray, occupancy: np.ndarray, grid: Grid3D, params: DepositionParams,
            seed: int, frame: int) -> tuple[np.ndarray, int]:
    """Deposit the ``eroded`` particles (002 §7; module docstring).

    Args:
        eroded: positions ``(M, 3)`` (m) of the particles eroded this frame; one beyond the
            grid's sides is exported, one above its top falls from the top.
        occupancy: particles per cell of ``grid`` (``Grid3D.occupancy``) of the rock that
            stays, ``int32 (nx, ny, nz)``.
        grid: the deposition grid, e.g. ``offset_grid(MPM grid, seed, frame)``.
        params: angle of repose and particles per cell.
        seed, frame: key the random choices (integers ≥ 0).

    Returns the positions ``(K, 3)`` (m) of the deposited particles, in the order of
    ``eroded`` with the exported ones left out, and the number exported (M = K + exported).
    """
    eroded = np.ascontiguousarray(np.asarray(eroded, dtype=np.float64).reshape(-1, 3))
    occupancy = np.ascontiguousarray(occupancy, dtype=np.int32)
    if occupancy.shape != grid.shape:
        raise ValueError(f"the occupancy's shape {occupancy.shape} is not the grid's {grid.shape}")
    origin = np.asarray(grid.origin, dtype=np.float64)
    key = (np.uint64(seed), np.uint64(frame))
    # the sites (surface cells and open ground), column by column, bottom up
    column_start = np.zeros(occupancy.shape[0] * occupancy.shape[1] + 1, dtype=np.int64)
    _count_sites(occupancy, column_start[1:])
    np.cumsum(column_start, out=column_start)
    site_k = np.empty(column_start[-1], dtype=np.int64)
    _list_sites(occupancy, column_start, site_k)
    fill = (origin[2], grid.h, float(params.particles_per_cell))
    receiver = np.empty(site_k.size + 1, dtype=np.int64)
    _site_receivers(occupancy, column_start, site_k, *fill, math.tan(math.radians(params.repose_angle)),
                    _NEIGHBOURS, _DISTANCES, *key, receiver)
    end = _jump(receiver)
    entry = np.empty(eroded.shape[0], dtype=np.int64)
    _entry_sites(eroded, origin, grid.h, occupancy, column_start, site_k, *key, entry)
    target = end[entry]
    kept = np.flatnonzero(target < site_k.size)
    target = target[kept]
    placed = np.empty((kept.size, 3))
    _place(kept, target, _rank_within(target), occupancy, column_start, site_k, origin, *fill, *key,
           placed)
    return placed, int(eroded.shape[0] - kept.size)


def _rank_within(values: np.ndarray) -> np.ndarray:
    """For each entry, how many earlier entries hold the same value."""
    order = np.argsort(values, kind="stable")
    rank = np.empty(values.size, dtype=np.int64)
    if values.size:
        ordered = values[order]
        first = np.r_[True, ordered[1:] != ordered[:-1]]
        group_start = np.maximum.accumulate(np.where(first, np.arange(values.size), 0))
        rank[order] = np.arange(values.size) - group_start
    return rank


@numba.njit(cache=True, inline="always")
def _is_site(occupancy, i, j, k):
    """Whether cell (i, j, k) is a surface cell, or, for k = −1, the ground is open there."""
    nz = occupancy.shape[2]
    if k < 0:
        return nz == 0 or occupancy[i, j, 0] == 0
    return occupancy[i, j, k] > 0 and (k == nz - 1 or occupancy[i, j, k + 1] == 0)


@numba.njit(cache=True, parallel=True)
def _count_sites(occupancy, counts):
    nx, ny, nz = occupancy.shape
    for i in numba.prange(nx):
        for j in range(ny):
            n = 0
            for k in range(-1, nz):
                if _is_site(occupancy, i, j, k):
                    n += 1
            counts[i * ny + j] = n


@numba.njit(cache=True, parallel=True)
def _list_sites(occupancy, column_start, site_k):
    nx, ny, nz = occupancy.shape
    for i in numba.prange(nx):
        for j in range(ny):
            s = column_start[i * ny + j]
            for k in range(-1, nz):
                if _is_site(occupancy, i, j, k):
                    site_k[s] = k
                    s += 1


@numba.njit(cache=True, inline="always")
def _site_of(column_start, site_k, column, k):
    """Index of the site at level k of ``column`` (−1 when there is none)."""
    for s in range(column_start[column], column_start[column + 1]):
        if site_k[s] == k:
            return s
    return -1


@numba.njit(cache=True, inline="always")
def _fall(occupancy, i, j, k):
    """Level of the first cell with particles at or below (i, j, k); −1: the ground."""
    while k >= 0 and occupancy[i, j, k] == 0:
        k -= 1
    return k


@numba.njit(cache=True, inline="always")
def _height(occupancy, i, j, k, ground, h, per_cell):
    """Proxy elevation (m) of the site at level k of column (i, j): floor plus fill."""
    if k < 0:
        return ground
    return ground + (k + min(occupancy[i, j, k] / per_cell, 1.0)) * h


@numba.njit(cache=True, parallel=True)
def _site_receivers(occupancy, column_start, site_k, ground, h, per_cell, tan_repose, neighbours,
                    distances, seed, frame, receiver):
    """Receiver of each site: itself when stable, else a too-low neighbour's landing site
    drawn in proportion to the slopes (module docstring); ``receiver[-1]`` is the export sink."""
    nx, ny, nz = occupancy.shape
    sink = site_k.size
    receiver[sink] = sink
    for c in numba.prange(nx * ny):
        i, j = c // ny, c % ny
        slopes = np.zeros(neighbours.shape[0])
        targets = np.empty(neighbours.shape[0], dtype=np.int64)
        for s in range(column_start[c], column_start[c + 1]):
            k = site_k[s]
            z = _height(occupancy, i, j, k, ground, h, per_cell)
            total = 0.0
            for n in range(neighbours.shape[0]):
                slopes[n] = 0.0
                a, b = i + neighbours[n, 0], j + neighbours[n, 1]
                if a < 0 or b < 0 or a >= nx or b >= ny:
                    zn, target = ground, sink
                else:
                    if k >= 0 and occupancy[a, b, k] == 0:
                        level = _fall(occupancy, a, b, k)
                    elif _is_site(occupancy, a, b, k):
                        level = k
                    else:  # a full cell under another, or the ground under rock: higher
                        continue
                    zn = _height(occupancy, a, b, level, ground, h, per_cell)
                    target = _site_of(column_start, site_k, a * ny + b, level)
                slope = (z - zn) / (distances[n] * h)
                if slope > tan_repose:
                    slopes[n] = slope
                    targets[n] = target
                    total += slope
            receiver[s] = s
            if total > 0.0:
                pick = uniform(seed, frame, s, DRAW_RECEIVER) * total
                for n in range(neighbours.shape[0]):
                    if slopes[n] > 0.0:
                        receiver[s] = targets[n]  # the last one if rounding leaves pick ≥ 0
                        pick -= slopes[n]
                        if pick < 0.0:
                            break


@numba.njit(cache=True, parallel=True)
def _jump_round(pointer, out):
    changed = 0
    for c in numba.prange(pointer.size):
        out[c] = pointer[pointer[c]]
        if out[c] != pointer[c]:
            changed += 1
    return changed


def _jump(receiver: np.ndarray) -> np.ndarray:
    """Pointer jumping p(c) ← p(p(c)), at most ⌈log₂ n⌉ rounds (fewer when nothing changes):
    each entry then points to the end of its receiver chain."""
    pointer, spare = receiver.copy(), np.empty_like(receiver)
    for _ in range(max(1, math.ceil(math.log2(max(receiver.size, 2))))):
        changed = _jump_round(pointer, spare)
        pointer, spare = spare, pointer
        if changed == 0:
            break
    return pointer


@numba.njit(cache=True, parallel=True)
def _entry_sites(eroded, origin, h, occupancy, column_start, site_k, seed, frame, entry):
    """The site where each eroded particle first comes to rest (module docstring: falls, ceilings,
    walls, buried cells) or the export sink."""
    nx, ny, nz = occupancy.shape
    sink = site_k.size
    for p in numba.prange(eroded.shape[0]):
        i = int(math.floor((eroded[p, 0] - origin[0]) / h))
        j = int(math.floor((eroded[p, 1] - origin[1]) / h))
        k = min(max(int(math.floor((eroded[p, 2] - origin[2]) / h)), 0), nz - 1)
        if i < 0 or j < 0 or i >= nx or j >= ny:
            entry[p] = sink
            continue
        while True:
            if occupancy[i, j, k] == 0:
                entry[p] = _site_of(column_start, site_k, i * ny + j, _fall(occupancy, i, j, k))
                break
            if _is_site(occupancy, i, j, k):
                entry[p] = _site_of(column_start, site_k, i * ny + j, k)
                break
            if k > 0 and occupancy[i, j, k - 1] == 0:  # a ceiling: falls
                entry[p] = _site_of(column_start, site_k, i * ny + j, _fall(occupancy, i, j, k - 1))
                break
            options = 0
            for d in range(4):
                a, b = i + _SIDES[d, 0], j + _SIDES[d, 1]
                if a < 0 or b < 0 or a >= nx or b >= ny or occupancy[a, b, k] == 0:
                    options += 1
            if options == 0:  # buried: the cell above
                k += 1
                continue
            pick = int(uniform(seed, frame, (i * ny + j) * nz + k, DRAW_WALL) * options)
            for d in range(4):
                a, b = i + _SIDES[d, 0], j + _SIDES[d, 1]
                if a < 0 or b < 0 or a >= nx or b >= ny or occupancy[a, b, k] == 0:
                    if pick == 0:
                        if a < 0 or b < 0 or a >= nx or b >= ny:
                            entry[p] = sink
                        else:
                            entry[p] = _site_of(column_start, site_k, a * ny + b, _fall(occupancy, a, b, k))
                        break
                    pick -= 1
            break


@numba.njit(cache=True, parallel=True)
def _place(kept, target, rank, occupancy, column_start, site_k, origin, ground, h, per_cell, seed, frame,
           out):
    """Positions of the deposited particles ``kept``: at random in their site's footprint, stacked
    by ``rank`` from its proxy elevation up by h/per_cell each."""
    ny = occupancy.shape[1]
    n_columns = column_start.size - 1
    for t in numba.prange(kept.size):
        s = target[t]
        lo, hi = 0, n_columns  # the column holding site s: column_start[c] ≤ s < column_start[c + 1]
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if column_start[mid] <= s:
                lo = mid
            else:
                hi = mid
        i, j = lo // ny, lo % ny
        p = kept[t]
        out[t, 0] = origin[0] + (i + uniform(seed, frame, p, DRAW_X)) * h
        out[t, 1] = origin[1] + (j + uniform(seed, frame, p, DRAW_Y)) * h
        out[t, 2] = _height(occupancy, i, j, site_k[s], ground, h, per_cell) + (rank[t] + 0.5) * h / per_cell
