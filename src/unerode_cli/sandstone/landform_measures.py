"""Measures of the landforms of 002 Fig. 7 on a voxelisation of the particles: the arch's opening,
bridge and intrados, the hoodoo's neck under its cap, the arcade's openings and pillars, the
alcove's recess and roof.

Every measure takes ``rock``, a boolean voxel grid ``(nx, ny, nz)`` (True: rock) on a
:class:`~unerode_cli.sandstone.grid3d.Grid3D` (x east, y north, z up; cell edge ``h`` in m), as
:func:`voxelise` makes it from particle positions. On the sampling lattice's surface grid
(``Lattice.surface_grid``) each lattice cell holds at most one particle, so the voxels of the
rock as sampled are exactly its particles' cells; lengths come in whole cells (± h).

Openings are seen along y (the rocks of Fig. 7 rows 1 and 3 are fins and walls along x): a pixel
(i, k) of the x–z plane is *see-through* when no voxel of its row along y holds rock, and an
*opening* is a 4-connected region of see-through pixels that reaches neither the sky (the top of
the grid) nor the grid's ends along x: rock (or the ground, z = the grid's bottom) surrounds it.

The curvature of a roof is its *rise*: the roof's height at mid-span minus the mean of its heights
at the two quarter-spans (m). A flat roof has rise 0; a half-circle of radius R springing from
the ends of its span, h(x) = √(R² − x²) on x ∈ [−R, R], has rise R(1 − √3/2) ≈ 0.134 R; a pointed
or parabolic roof h(x) = H(1 − (2x/L)²) has rise H/4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from unerode_cli.sandstone.grid3d import Grid3D

#: Half-width of the window (a share of the span) over which a roof's height is averaged at
#: mid-span and at the quarter-spans.
RISE_WINDOW = 1.0 / 16.0


def voxelise(positions: np.ndarray, grid: Grid3D) -> np.ndarray:
    """Boolean voxels ``(nx, ny, nz)`` of ``grid``: True where a cell holds a particle of
    ``positions`` ``(N, 3)`` (m)."""
    return grid.occupancy(positions) > 0


def see_through(rock: np.ndarray) -> np.ndarray:
    """Pixels ``(nx, nz)`` of the x–z plane whose row along y holds no rock."""
    return ~rock.any(axis=1)


def openings(rock: np.ndarray, min_cells: int = 1) -> tuple[np.ndarray, int]:
    """The openings seen along y (module docstring): labels ``(nx, nz)`` (0: rock or sky, 1…n:
    the openings, largest first) and their count n; openings of fewer than ``min_cells`` pixels
    are dropped."""
    clear = see_through(rock)
    # the sky: a frame of see-through pixels above and at both ends along x, none below (the ground)
    padded = np.pad(clear, ((1, 1), (0, 1)), constant_values=True)
    labels, _ = ndimage.label(padded)
    enclosed = clear & (labels[1:-1, :-1] != labels[0, 0])
    regions, count = ndimage.label(enclosed)
    sizes = np.bincount(regions.ravel(), minlength=count + 1)[1:]
    order = np.argsort(-sizes, kind="stable")
    order = order[sizes[order] >= min_cells]
    lookup = np.zeros(count + 1, dtype=regions.dtype)
    lookup[order + 1] = np.arange(1, order.size + 1)
    return lookup[regions], int(order.size)


@dataclass(frozen=True)
class Roof:
    """The roof of a region of the x–z plane: the columns ``first``…``last`` (cell indices along
    x) holding it, its span (m, whole columns) and the height (m above the grid's bottom) of
    its top edge in each column, ``heights`` ``(last − first + 1,)``."""

    first: int
    last: int
    span: float
    heights: np.ndarray

    def at(self, share: float, h: float) -> float:
        """Mean roof height (m) within ±RISE_WINDOW of the span around ``share`` of it (0: its
        west end, 1: its east end), the columns' heights interpolated linearly between centres."""
        centres = (np.arange(self.heights.size) + 0.5) * h
        where = share * self.span + np.linspace(-RISE_WINDOW, RISE_WINDOW, 9) * self.span
        return float(np.interp(where, centres, self.heights).mean())

    def rise(self, h: float) -> float:
        """Height at mid-span minus the mean of the heights at the quarter-spans (m)."""
        return self.at(0.5, h) - 0.5 * (self.at(0.25, h) + self.at(0.75, h))


def roof(region: np.ndarray, h: float) -> Roof:
    """The :class:`Roof` of ``region``, a boolean ``(nx, nz)`` of the x–z plane with at least
    one pixel: in each column from its westmost to its eastmost, the top edge of its highest
    pixel (k + 1)·h; a column inside the span that holds none takes the heights of its
    neighbours, interpolated linearly."""
    columns = np.flatnonzero(region.any(axis=1))
    first, last = int(columns[0]), int(columns[-1])
    part = region[first:last + 1]
    top = np.where(part.any(axis=1), part.shape[1] - np.argmax(part[:, ::-1], axis=1), 0) * h
    held = part.any(axis=1)
    index = np.arange(part.shape[0])
    heights = np.interp(index, index[held], top[held])
    return Roof(first, last, (last - first + 1) * h, heights)


@dataclass(frozen=True)
class ArchMeasure:
    """The arch's largest opening seen along y: ``openings`` their count; ``area`` (m²) and
    ``span`` (m) of the largest; its intrados (the opening's roof) at mid-span and the mean of
    its quarter-spans (m above the grid's bottom, a scene's ground), their difference ``rise``
    (m) and ``rise_cells`` (rise / h); ``bridge_thickness`` (m) of rock above the intrados at
    mid-span (in the x–z projection); ``joined``: the piece of rock holding the bridge at
    mid-span (cells joined by faces, edges or corners, as ``support`` joins rock) touches the
    ground on both sides of the opening (it rests on both supports); ``continuous``: that piece
    holds rock above the opening in every column of the span."""

    openings: int
    area: float
    span: float
    mid: float
    quarters: float
    rise: float
    rise_cells: float
    bridge_thickness: float
    joined: bool
    continuous: bool


def measure_arch(rock: np.ndarray, h: float, min_cells: int = 4) -> ArchMeasure:
    """:class:`ArchMeasure` of the voxels ``rock`` ``(nx, ny, nz)`` of cell ``h`` (m), openings
    of at least ``min_cells`` pixels; zeros and False where there is no opening."""
    labels, count = openings(rock, min_cells)
    if count == 0:
        return ArchMeasure(0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False, False)
    region = labels == 1
    intrados = roof(region, h)
    mid = intrados.at(0.5, h)
    quarters = 0.5 * (intrados.at(0.25, h) + intrados.at(0.75, h))
    pieces, _ = ndimage.label(rock, structure=np.ones((3, 3, 3)))
    middle = (intrados.first + intrados.last) // 2
    k = int(np.max(np.flatnonzero(region[middle]))) + 1
    column = rock[middle, :, k:]
    solid = see_through(rock)[middle, k:] == 0
    thickness = float(np.count_nonzero(solid)) * h
    if not column.any():
        return ArchMeasure(count, float(region.sum()) * h * h, intrados.span, mid, quarters, mid - quarters,
                           (mid - quarters) / h, thickness, False, False)
    cells = np.argwhere(column)
    j, dk = cells[np.argmin(cells[:, 1])]
    piece = pieces == pieces[middle, j, k + dk]
    ground = piece[:, :, 0].any(axis=1)
    joined = bool(ground[:intrados.first].any() and ground[intrados.last + 1:].any())
    tops = np.round(intrados.heights / h).astype(int)
    above = np.arange(rock.shape[2])[None, :] >= tops[:, None]
    spanned = (piece[intrados.first:intrados.last + 1].any(axis=1) & above).any(axis=1)
    return ArchMeasure(count, float(region.sum()) * h * h, intrados.span, mid, quarters, mid - quarters,
                       (mid - quarters) / h, thickness, joined, bool(spanned.all()))


@dataclass(frozen=True)
class HoodooMeasure:
    """The hoodoo's cap and neck: the cap's widest extents along x and y (m) over the slices at
    and above the cap's base; the neck, the slice of least rock area between the ground and the
    cap's base: its height (m above the grid's bottom), area (m²) and extents along x and y (m);
    ``ratio_x``, ``ratio_y`` the neck's extents over the cap's; ``retreat`` (m) of the neck's
    west, east, south and north edges inside those of the cap's widest slice (positive: narrowed
    from that side)."""

    cap_x: float
    cap_y: float
    neck_z: float
    neck_area: float
    neck_x: float
    neck_y: float
    ratio_x: float
    ratio_y: float
    retreat: tuple[float, float, float, float]


def _edges(mask: np.ndarray) -> np.ndarray:
    """Per slice of ``mask`` ``(nx, ny, nz)``: the first and last occupied cell along x and along
    y, ``(nz, 4)`` (west, east, south, north; −1 where the slice is empty)."""
    along_x, along_y = mask.any(axis=1), mask.any(axis=0)
    out = np.full((mask.shape[2], 4), -1)
    for axis, line in enumerate((along_x, along_y)):
        held = line.any(axis=0)
        out[held, 2 * axis] = np.argmax(line, axis=0)[held]
        out[held, 2 * axis + 1] = line.shape[0] - 1 - np.argmax(line[::-1], axis=0)[held]
    return out


def measure_hoodoo(rock: np.ndarray, h: float, cap_base: float, z0: float = 0.0) -> HoodooMeasure:
    """:class:`HoodooMeasure` of the voxels ``rock`` ``(nx, ny, nz)`` of cell ``h`` (m) whose
    bottom lies at ``z0`` (m); ``cap_base`` (m) is the altitude of the cap's base (slices whose
    centre lies above it are the cap's, those below the stem's). ValueError without rock in
    the cap or the stem."""
    centres = z0 + (np.arange(rock.shape[2]) + 0.5) * h
    edges = _edges(rock)
    area = rock.sum(axis=(0, 1)) * h * h
    cap, stem = (centres > cap_base) & (area > 0), (centres < cap_base) & (area > 0)
    if not cap.any() or not stem.any():
        raise ValueError("the hoodoo needs rock both above and below the cap's base")
    width_x = (edges[:, 1] - edges[:, 0] + 1) * h
    width_y = (edges[:, 3] - edges[:, 2] + 1) * h
    top = np.flatnonzero(cap)[np.argmax((width_x * width_y)[cap])]
    neck = np.flatnonzero(stem)[np.argmin(area[stem])]
    cap_x, cap_y = float(width_x[cap].max()), float(width_y[cap].max())
    sign = np.array([1, -1, 1, -1])
    retreat = tuple(float(v) for v in (sign * (edges[neck] - edges[top]) * h))
    return HoodooMeasure(cap_x, cap_y, float(centres[neck]), float(area[neck]), float(width_x[neck]),
                         float(width_y[neck]), float(width_x[neck]) / cap_x, float(width_y[neck]) / cap_y,
                         retreat)  # type: ignore[arg-type]


@dataclass(frozen=True)
class ArcadeMeasure:
    """The arcade's openings seen along y, west to east (by the x of their centroids): their
    count, areas (m²) and spans (m, whole columns); ``pillars`` the width (m) of the rock between
    each two consecutive openings: in each row (height) holding both, the columns between the
    western one's eastmost pixel and the eastern one's westmost, the median over those rows
    (NaN when no row holds both; ≤ 0 when they overlap along x more than they are apart)."""

    openings: int
    areas: tuple[float, ...]
    spans: tuple[float, ...]
    pillars: tuple[float, ...]


def _pillar(west: np.ndarray, east: np.ndarray, h: float) -> float:
    """Median over the rows holding both regions ``(nx, nz)`` of the columns between ``west``'s
    eastmost pixel and ``east``'s westmost (m)."""
    rows = west.any(axis=0) & east.any(axis=0)
    if not rows.any():
        return math.nan
    last = west.shape[0] - 1 - np.argmax(west[::-1, rows], axis=0)
    first = np.argmax(east[:, rows], axis=0)
    return float(np.median(first - last - 1)) * h


def measure_arcade(rock: np.ndarray, h: float, min_cells: int = 4) -> ArcadeMeasure:
    """:class:`ArcadeMeasure` of the voxels ``rock`` ``(nx, ny, nz)`` of cell ``h`` (m), openings
    of at least ``min_cells`` pixels."""
    labels, count = openings(rock, min_cells)
    index = np.arange(1, count + 1)
    x = np.arange(rock.shape[0])[:, None] * np.ones(labels.shape)
    order = index[np.argsort(ndimage.mean(x, labels, index), kind="stable")] if count else index
    regions = [labels == i for i in order]
    areas = tuple(float(r.sum()) * h * h for r in regions)
    spans = tuple(float(np.count_nonzero(r.any(axis=1))) * h for r in regions)
    pillars = tuple(_pillar(a, b, h) for a, b in zip(regions, regions[1:], strict=False))
    return ArcadeMeasure(count, areas, spans, pillars)


@dataclass(frozen=True)
class AlcoveMeasure:
    """The recess cut into a face looking south (−y): the largest 4-connected region of the x–z
    plane where rock lies behind the face's initial plane, at least ``min_depth`` behind it; its
    ``width`` (m, whole columns), ``height`` (m, the roof's highest point above the grid's
    bottom), ``area`` (m²), ``depth`` (m, deepest) and ``mean_depth`` (m), and its roof: the
    height at mid-width and the mean at the quarter-widths (m), their difference ``rise`` (m)
    and ``rise_cells`` (rise / h)."""

    width: float
    height: float
    area: float
    depth: float
    mean_depth: float
    mid: float
    quarters: float
    rise: float
    rise_cells: float


def recess_depth(rock: np.ndarray, h: float, face: int) -> np.ndarray:
    """Per pixel ``(nx, nz)`` of the x–z plane, how far (m) behind the face's initial plane (the
    south edge of the cells of index ``face`` along y) the first rock lies; the grid's depth
    behind it where the row holds none."""
    behind = rock[:, face:, :]
    first = np.where(behind.any(axis=1), np.argmax(behind, axis=1), behind.shape[1])
    return first * h


def measure_alcove(rock: np.ndarray, h: float, face: int, columns: tuple[int, int],
                   min_depth: float) -> AlcoveMeasure:
    """:class:`AlcoveMeasure` of the voxels ``rock`` ``(nx, ny, nz)`` of cell ``h`` (m) whose face
    looking south began at the cells ``face`` along y, within the columns ``columns`` (first,
    last + 1) along x, for a recess at least ``min_depth`` (m) deep; zeros without one."""
    depth = recess_depth(rock, h, face)
    backed = rock[:, face:, :].any(axis=1)
    deep = np.zeros(depth.shape, dtype=bool)
    deep[columns[0]:columns[1]] = (depth >= min_depth - 1e-9)[columns[0]:columns[1]]
    deep &= backed
    regions, count = ndimage.label(deep)
    if count == 0:
        return AlcoveMeasure(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    largest = 1 + int(np.argmax(np.bincount(regions.ravel())[1:]))
    region = regions == largest
    top = roof(region, h)
    mid, quarters = top.at(0.5, h), 0.5 * (top.at(0.25, h) + top.at(0.75, h))
    return AlcoveMeasure(top.span, float(top.heights.max()), float(region.sum()) * h * h,
                         float(depth[region].max()), float(depth[region].mean()), mid, quarters,
                         mid - quarters, (mid - quarters) / h)
