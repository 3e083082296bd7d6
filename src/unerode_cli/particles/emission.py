"""Where particles start (003 §5): rain over the domain or a mask, or a source point / line
(a river's spring, a coast, a vent). No numba here: the kernels draw the positions themselves,
from each particle's own random stream, out of the arrays ``kernel_arrays`` prepares.

Grid coordinates: (column, row) with cell centres at integers; metres are column·dx, row·dy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.grid import Grid

RAIN = 0
SOURCE = 1


@dataclass(frozen=True)
class Emission:
    """How many particles start per iteration, and where.

    Attributes:
        kind: ``"rain"`` (uniform over the domain, or weighted by ``mask``) or ``"source"``
            (uniformly along the polyline ``points``: one point, or a line).
        count: particles per iteration (≥ 1).
        mask: rain only: float or bool [ny, nx] weights (≥ 0) of the cells; None = every valid
            cell alike. Nodata cells never emit.
        points: source only: float[k, 2] (column, row) grid coordinates of a point (k = 1) or
            of the vertices of a line.
        spread: source only: particles start uniformly within this distance (m) of the line.
        velocity: initial velocity (east, north, up) in m/s.
    """

    kind: str
    count: int
    mask: np.ndarray | None = None
    points: np.ndarray | None = None
    spread: float = 0.0
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @classmethod
    def rain(cls, count: int, mask: np.ndarray | None = None,
             velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Emission:
        """Rain: ``count`` particles per iteration, uniform over the (masked) domain."""
        return cls("rain", count, mask=mask, velocity=velocity)

    @classmethod
    def source(cls, count: int, points: np.ndarray | tuple[float, float], spread: float = 0.0,
               velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Emission:
        """A source: ``count`` particles per iteration along a point or a line (grid coordinates)."""
        return cls("source", count, points=np.atleast_2d(np.asarray(points, dtype=np.float64)),
                   spread=spread, velocity=velocity)

    def validate(self, grid: Grid) -> None:
        """Raise ValueError (one sentence) for an emission that cannot start a particle."""
        if self.kind not in ("rain", "source"):
            raise ValueError(f"emission kind must be 'rain' or 'source', got {self.kind!r}")
        if int(self.count) != self.count or self.count < 1:
            raise ValueError(f"the particle count per iteration must be an integer ≥ 1, got {self.count}")
        if len(self.velocity) != 3 or not np.isfinite(self.velocity).all():
            raise ValueError("the initial velocity must be 3 finite numbers (east, north, up) in m/s")
        if self.kind == "rain":
            if self.mask is None:
                return
            weights = np.asarray(self.mask, dtype=np.float64)
            if weights.shape != grid.shape:
                raise ValueError(f"the rain mask has shape {weights.shape}, the grid has {grid.shape}")
            inside = weights[grid.valid]
            if not (np.isfinite(inside).all() and (inside >= 0).all() and inside.sum() > 0):
                raise ValueError("the rain mask must be finite, ≥ 0 and positive somewhere in the domain")
            return
        pts = self.points
        if pts is None or pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 1 or not np.isfinite(pts).all():
            raise ValueError("a source needs finite (column, row) points of shape (k, 2)")
        ny, nx = grid.shape
        if (pts[:, 0] < -0.5).any() or (pts[:, 0] > nx - 0.5).any() or (pts[:, 1] < -0.5).any() \
                or (pts[:, 1] > ny - 0.5).any():
            raise ValueError(f"source points must lie on the grid (columns -0.5..{nx - 0.5}, "
                             f"rows -0.5..{ny - 0.5})")
        if not (np.isfinite(self.spread) and self.spread >= 0):
            raise ValueError(f"the source spread must be ≥ 0 m, got {self.spread}")

    def kernel_arrays(self, grid: Grid) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(kind code, cumulative weights, cell indices, vertices in metres float[k, 2],
        initial velocity float[3] in kernel axes (x east, y south, z up)).

        Rain: cumulative weights over the emitting cells (normalised to end at 1) and their
        flat indices. Source: cumulative lengths of the segments (normalised; a single 0 for a
        point) and no cells.
        """
        ve, vn, vu = (float(v) for v in self.velocity)
        v0 = np.array([ve, -vn, vu])
        if self.kind == "rain":
            weights = np.ones(grid.shape) if self.mask is None else np.asarray(self.mask, dtype=np.float64)
            weights = np.where(grid.valid, weights, 0.0).ravel()
            cells = np.flatnonzero(weights > 0)
            cdf = np.cumsum(weights[cells])
            return RAIN, cdf / cdf[-1], cells.astype(np.int64), np.zeros((1, 2)), v0
        metres = self.points * np.array([grid.dx, grid.dy])
        lengths = np.hypot(*np.diff(metres, axis=0).T) if len(metres) > 1 else np.zeros(0)
        total = lengths.sum()
        cdf = np.cumsum(lengths) / total if total > 0 else np.zeros(1)
        return SOURCE, cdf, np.zeros(0, np.int64), np.ascontiguousarray(metres), v0
