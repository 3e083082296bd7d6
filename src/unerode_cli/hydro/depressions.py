"""Depressions filled to their spill level, and the lakes that water in them forms.

``fill_depressions`` is the exact priority-flood of Barnes, Lehman & Mulla (2014, Algorithm 2:
the improved Priority-Flood, with a plain queue for the cells of depressions): seeded from the
outlets, every cell is raised to the lowest level at which water can leave it along some
8-neighbour path, i.e. filled(c) = max(z(c), min over the neighbours n of filled(n)), with
filled = z on outlets. Unlike the routing surface of :func:`unerode_cli.hydro.route`
(priority-flood+ε), the water surface of a lake is flat: the spill level itself, the elevation
of the lowest cell on the lake's rim through which it drains.

The water depth is filled − z. A lake is a connected set (8 neighbours) of cells under water;
two such cells side by side always share one water level, since each is filled to the minimum
filled level of its neighbours.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.hydro.kernels import DCOL, DROW, _heap_pop, _heap_push
from unerode_cli.hydro.routing import flood_inputs, require_all_reached

#: Default of ``lake_stats``'s ``min_depth`` (m): a water body whose deepest cell is shallower
#: than this is taken for a pit of the DEM (rounding, interpolation, float32 storage), not a lake.
MIN_LAKE_DEPTH = 0.5


@numba.njit(cache=True)
def spill_levels(z, valid, outlets):
    """Exact priority-flood (Barnes et al. 2014, Algorithm 2) of ``z`` from ``outlets``.

    Cells leave a min-heap of open cells (the 4-ary heap of ``kernels``) or, first, a FIFO of
    cells flooded at the level of the cell that reached them; a neighbour not yet reached is
    filled to max(its elevation, the current level). ``z`` is not modified; nodata cells are
    never entered.

    Args:
        z: float64[ny, nx] elevation (m).
        valid: bool[ny, nx] domain mask.
        outlets: bool[ny, nx] valid cells that drain out of the domain.

    Returns:
        (filled float64[ny, nx]: the spill surface (m), NaN on nodata cells and on valid cells
         that no outlet reaches; count: the number of valid cells reached, outlets included).
    """
    ny, nx = z.shape
    n = ny * nx
    zin = z.ravel()
    ok = valid.ravel()
    out = outlets.ravel()
    filled = np.full(n, np.nan)
    closed = np.empty(n, dtype=np.bool_)
    heap = np.empty((n, 2), dtype=np.float64)
    pit = np.empty(n, dtype=np.int64)
    size = 0
    for i in range(n):
        closed[i] = not ok[i]
        if ok[i] and out[i]:
            closed[i] = True
            filled[i] = zin[i]
            size = _heap_push(heap, size, zin[i], i)
    head = 0
    tail = 0
    count = 0
    while True:
        if head < tail:
            c = pit[head]
            head += 1
        elif size > 0:
            c, size = _heap_pop(heap, size)
        else:
            break
        count += 1
        level = filled[c]
        r = c // nx
        col = c - r * nx
        for k in range(8):
            rr = r + DROW[k]
            cc = col + DCOL[k]
            if rr < 0 or rr >= ny or cc < 0 or cc >= nx:
                continue
            j = rr * nx + cc
            if closed[j]:
                continue
            closed[j] = True
            if zin[j] <= level:
                filled[j] = level
                pit[tail] = j
                tail += 1
            else:
                filled[j] = zin[j]
                size = _heap_push(heap, size, zin[j], j)
    return filled.reshape(z.shape), count


def fill_depressions(elevation: np.ndarray, grid: Grid, outlets: np.ndarray) -> np.ndarray:
    """The spill surface of ``elevation`` (m): every depression filled flat to the level at
    which it overflows towards ``outlets`` (exact priority-flood, Barnes et al. 2014);
    float64[ny, nx], NaN on nodata. The elevation is not modified.

    Raises:
        ValueError: shape mismatch, no outlet, non-finite elevation in the domain, or valid
            cells that cannot reach any outlet.
    """
    z, outlets = flood_inputs(elevation, grid, outlets)
    filled, count = spill_levels(z, grid.valid, outlets)
    require_all_reached(grid.valid, count)
    return filled


def water_depth(surface: np.ndarray, grid: Grid, outlets: np.ndarray) -> np.ndarray:
    """Depth (m) of the water that the depressions of ``surface`` (m) hold up to their spill
    level: filled − surface (see :func:`fill_depressions`); float64[ny, nx], 0 outside
    depressions and on nodata."""
    filled = fill_depressions(surface, grid, outlets)
    valid = grid.valid
    depth = np.zeros(grid.shape, dtype=np.float64)
    depth[valid] = filled[valid] - surface[valid]
    return depth


@dataclass(frozen=True)
class LakeStats:
    """The lakes of a water-depth map (see :func:`lake_stats`).

    Attributes:
        count: number of lakes.
        area_m2: their total surface area (m²).
        volume_m3: the water they hold (m³), Σ depth × cell area.
        largest_area_m2: area of the largest lake (m²; 0 without lakes).
        max_depth_m: depth of the deepest cell (m; 0 without lakes).
        min_depth_m: the depth a water body must exceed somewhere to count (m).
    """

    count: int
    area_m2: float
    volume_m3: float
    largest_area_m2: float
    max_depth_m: float
    min_depth_m: float


def lake_labels(depth: np.ndarray, min_depth: float = MIN_LAKE_DEPTH) -> tuple[np.ndarray, int]:
    """Label the lakes of ``depth`` (m): the connected sets (8 neighbours) of cells with water
    (depth > 0) whose deepest cell is deeper than ``min_depth`` (m).

    Returns:
        (int32[ny, nx] lake number 1..count, 0 where there is no lake; count).
    """
    from scipy import ndimage

    if not min_depth >= 0.0:
        raise ValueError(f"the minimum lake depth must be ≥ 0 m, got {min_depth:g}")
    wet = depth > 0.0
    labels, found = ndimage.label(wet, structure=np.ones((3, 3), dtype=bool))
    if found == 0:
        return labels.astype(np.int32), 0
    # a lake's deepest cell is deeper than min_depth where any of its cells is (a count, not a sort)
    keep = np.bincount(labels[depth > min_depth], minlength=found + 1)[1:] > 0
    number = np.zeros(found + 1, dtype=np.int32)
    number[1:][keep] = np.arange(1, int(keep.sum()) + 1, dtype=np.int32)
    return number[labels], int(keep.sum())


def lake_stats(depth: np.ndarray, grid: Grid, min_depth: float = MIN_LAKE_DEPTH) -> LakeStats:
    """Count, area and volume of the lakes of the water-depth map ``depth`` (m, float[ny, nx]).

    A lake is a connected set (8 neighbours) of valid cells under water (depth > 0), counted
    when its deepest cell is deeper than ``min_depth`` (m; default ``MIN_LAKE_DEPTH`` = 0.5 m,
    which leaves out the pits of DEM noise); its area is its cell count × ``grid.cell_area``
    (m²; on geographic rasters the grid's cell sizes are metres at the centre latitude) and its
    volume Σ depth × cell area (m³).
    """
    if depth.shape != grid.shape:
        raise ValueError(f"the depth map has shape {depth.shape}, the grid has {grid.shape}")
    depth = np.where(grid.valid & np.isfinite(depth), depth, 0.0)
    labels, count = lake_labels(depth, min_depth)
    cell = grid.cell_area
    if count == 0:
        return LakeStats(0, 0.0, 0.0, 0.0, 0.0, float(min_depth))
    cells = np.bincount(labels.ravel(), minlength=count + 1)[1:]
    water = labels > 0
    return LakeStats(
        count=count,
        area_m2=float(cells.sum() * cell),
        volume_m3=float(depth[water].sum() * cell),
        largest_area_m2=float(cells.max() * cell),
        max_depth_m=float(depth[water].max()),
        min_depth_m=float(min_depth),
    )
