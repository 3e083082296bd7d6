"""Wind abrasion (002 §5.1, Eq. 8): W_a = k_a ‖v‖ (−n·v)₊ on the surface particles.

The wind model. 002 takes the local wind v from a divergence-free SPH simulation of the air
around the rock, on the GPU. Here v is the free wind U·d (speed U, direction d) times the
*exposure* e of the particle: the share of ``rays`` rays cast upwind from the particle, within
a cone of half-angle ``cone_angle`` around −d, that leave the grid (or run ``ray_length``)
without entering a filled cell of the occupancy grid or the ground. So

    W_a = k_a · e² · U² · (−n·d)₊   (dimensionless; Eq. 1 multiplies it by E in 1/year).

Why rays: they keep what Eq. 8 needs from a wind field, its direction dependence and the
shelter behind obstacles (a leeward face gets nothing since (−n·d)₊ = 0, a face in another
rock's lee gets e < 1), at a cost that grows with the surface only, not with the volume of air
as SPH or a grid flow solver would, and without a flow solve per frame on two CPU cores.
What rays leave out: the speed-up around edges and the recirculation in a wake. The cone is
the spread of directions of gusts; its pattern is turned about the wind axis by a
golden-angle step every frame, so the shelter of small obstacles is averaged over frames.

Units: k_a in s²/m² (002 Table 1 writes m⁻²s⁻², which does not make W_a dimensionless, as
Eq. 1 needs with E in 1/year), U in m/s, lengths in m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numba
import numpy as np

from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.surface import filled_cells

#: The golden angle (rad) between successive rays of the cone's spiral, and the fraction of a
#: turn the pattern turns each frame (1/φ).
GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))
TURN_PER_FRAME = (math.sqrt(5.0) - 1.0) / 2.0


#: The wind models of abrasion: rays cast upwind (this module) or the flow around the rock.
WIND_MODELS = ("rays", "flow")


@dataclass(frozen=True)
class WindParams:
    """The wind of abrasion (002 §5.1).

    Attributes:
        azimuth: direction the wind comes from, degrees clockwise from north (270: a west
            wind, blowing east along +x).
        elevation: angle (degrees) above the horizon of the direction the wind comes from
            (positive: the wind blows downward).
        direction: optional vector (x east, y north, z up) the wind blows toward; when given,
            it replaces ``azimuth`` and ``elevation``.
        speed: free wind speed U (m/s).
        cone_angle: half-angle (degrees) of the cone of rays around the upwind direction.
        rays: rays cast per surface particle.
        ray_length: how far upwind (m) an obstacle shelters a particle; ``inf``: up to the
            grid's edge.
        model: ``"rays"`` (this module: exposure by rays cast upwind) or ``"flow"`` (the local
            wind of a lattice Boltzmann flow around the rock, ``wind_flow``).
        rose: prevailing winds, pairs (azimuth in degrees, weight > 0); when given, the wind
            blows from each azimuth (at ``elevation`` and ``speed``) for its share of the time,
            weight/Σ weights, and abrasion is the time-weighted sum (``abrasion_rate``), so a
            rock is cut from every side the rose names. ``azimuth`` and ``direction`` are then
            not used.
    """

    azimuth: float = 270.0
    elevation: float = 0.0
    direction: tuple[float, float, float] | None = None
    speed: float = 10.0
    cone_angle: float = 10.0
    rays: int = 16
    ray_length: float = math.inf
    rose: tuple[tuple[float, float], ...] = ()
    model: str = "rays"

    def __post_init__(self) -> None:
        if self.model not in WIND_MODELS:
            raise ValueError(f"the wind model must be one of {', '.join(WIND_MODELS)}, not '{self.model}'")
        for azimuth, weight in self.rose:
            if not (math.isfinite(azimuth) and math.isfinite(weight) and weight > 0.0):
                raise ValueError(f"a wind rose entry needs a finite azimuth and a weight > 0, not "
                                 f"({azimuth}, {weight})")
        if not (math.isfinite(self.speed) and self.speed >= 0.0):
            raise ValueError(f"the wind speed must be a finite number ≥ 0 m/s, not {self.speed}")
        if not 0.0 <= self.cone_angle < 90.0:
            raise ValueError(f"the wind cone's half-angle must lie in [0, 90) degrees, not {self.cone_angle}")
        if self.rays < 1:
            raise ValueError(f"the wind needs at least one ray per particle, not {self.rays}")
        if not self.ray_length > 0.0:
            raise ValueError(f"the wind's ray length must be positive (m), not {self.ray_length}")
        if not -90.0 <= self.elevation <= 90.0:
            raise ValueError(f"the wind's elevation must lie in [-90, 90] degrees, not {self.elevation}")
        if self.direction is not None and not np.linalg.norm(self.direction) > 0.0:
            raise ValueError("the wind's direction must be a nonzero vector")

    @property
    def blowing(self) -> np.ndarray:
        """Unit vector (x east, y north, z up) the wind blows toward."""
        if self.direction is not None:
            d = np.asarray(self.direction, dtype=np.float64)
            return d / np.linalg.norm(d)
        a, e = math.radians(self.azimuth), math.radians(self.elevation)
        return -np.array([math.sin(a) * math.cos(e), math.cos(a) * math.cos(e), math.sin(e)])


def prevailing(params: WindParams) -> list[tuple[WindParams, float]]:
    """The single winds of ``params`` and their shares of the time (summing to 1): the rose's
    azimuths, or the one wind."""
    if not params.rose:
        return [(params, 1.0)]
    total = sum(weight for _, weight in params.rose)
    return [(replace(params, azimuth=azimuth, direction=None, rose=()), weight / total)
            for azimuth, weight in params.rose]


def cone_rays(params: WindParams, seed: int, frame: int) -> np.ndarray:
    """Unit vectors ``(rays, 3)`` pointing upwind: a spiral of equal solid angles in the cone of
    half-angle ``params.cone_angle`` around −d, turned about the axis by (seed + frame)/φ turns."""
    axis = -params.blowing
    helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    r = np.arange(params.rays)
    cos_t = 1.0 - (1.0 - math.cos(math.radians(params.cone_angle))) * (r + 0.5) / params.rays
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t**2))
    turn = 2.0 * math.pi * (((seed + frame) * TURN_PER_FRAME) % 1.0)
    psi = r * GOLDEN_ANGLE + turn
    return (cos_t[:, None] * axis + sin_t[:, None] * (np.cos(psi)[:, None] * u + np.sin(psi)[:, None] * v))


def exposure(positions: np.ndarray, which: np.ndarray, grid: Grid3D, rays: np.ndarray,
             ray_length: float = math.inf) -> np.ndarray:
    """Share of the ``rays`` (unit vectors ``(M, 3)``) from each particle ``which`` (``bool (N,)``)
    that leave the grid, or run ``ray_length`` (m), before entering a filled cell of ``grid``'s
    occupancy or the ground (below the grid); ``(N,)`` in [0, 1], 0 for the others. Cells
    within one cell size of the particle (its own face) do not shelter it."""
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    out = np.zeros(positions.shape[0])
    index = np.flatnonzero(which)
    out[index] = _exposure_of(positions, index, grid, filled_cells(positions, grid), rays, ray_length)
    return out


def _exposure_of(positions: np.ndarray, index: np.ndarray, grid: Grid3D, filled: np.ndarray,
                 rays: np.ndarray, ray_length: float) -> np.ndarray:
    """``exposure`` of the particles ``index``, ``(len(index),)``; ``filled``: the filled cells
    of ``grid`` (``filled_cells``)."""
    out = np.empty(index.size)
    _exposure(positions, index, filled, np.asarray(grid.origin, dtype=np.float64), grid.h,
              np.ascontiguousarray(rays, dtype=np.float64), float(ray_length), out)
    return out


def abrasion_rate(positions: np.ndarray, normals: np.ndarray, surface: np.ndarray, grid: Grid3D,
                  k_a: np.ndarray, params: WindParams, seed: int, frame: int) -> np.ndarray:
    """Wind abrasion W_a = k_a‖v‖(−n·v)₊ (002 Eq. 8) with v = e·U·d (module docstring), ``(N,)``;
    for a wind rose, Σ_i s_i·W_a(d_i) over its winds d_i and their shares of the time s_i.

    Args:
        positions: particle positions ``(N, 3)`` (m).
        normals: unit outward normals ``(N, 3)`` (``surface.normals``).
        surface: which particles are on the surface, ``bool (N,)``; the others get 0.
        grid: the occupancy grid whose filled cells shelter (the surface grid).
        k_a: abrasion coefficient per particle ``(N,)`` (s²/m²).
        params: the wind.
        seed, frame: turn the cone's pattern (``cone_rays``).

    Returns W_a, dimensionless (a rate once multiplied by E, 1/year, in Eq. 1).
    """
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    filled = filled_cells(positions, grid)
    rate = np.zeros(len(normals))
    for wind, share in prevailing(params):
        rate += share * _one_wind(positions, normals, surface, grid, filled, k_a, wind, seed, frame)
    return rate


def _one_wind(positions: np.ndarray, normals: np.ndarray, surface: np.ndarray, grid: Grid3D,
              filled: np.ndarray, k_a: np.ndarray, params: WindParams, seed: int, frame: int) -> np.ndarray:
    """``abrasion_rate`` of one wind (no rose), computed on the surface particles only;
    ``filled``: ``filled_cells`` of the positions on ``grid``."""
    rate = np.zeros(len(normals))
    index = np.flatnonzero(surface)
    facing = np.maximum(0.0, -(np.asarray(normals, dtype=np.float64)[index] @ params.blowing))
    k = np.asarray(k_a, dtype=np.float64)[index]
    which = (facing > 0.0) & (k != 0.0)
    if params.speed == 0.0 or not which.any():
        return rate
    index, facing, k = index[which], facing[which], k[which]
    e = _exposure_of(positions, index, grid, filled, cone_rays(params, seed, frame), params.ray_length)
    rate[index] = k * (e * params.speed) ** 2 * facing
    return rate


@numba.njit(cache=True, inline="always")
def _first_crossing(f, u, h):
    """(step, distance to the first cell wall (m), distance between walls (m)) along one axis
    of a ray at ``f`` (cells, fractional) with direction component ``u``."""
    if u > 0.0:
        return 1, (math.floor(f) + 1.0 - f) * h / u, h / u
    if u < 0.0:
        return -1, (f - math.floor(f)) * h / -u, h / -u
    return 0, math.inf, math.inf


@numba.njit(cache=True)
def _unobstructed(occupancy, origin, h, x, y, z, ux, uy, uz, length):
    """Whether the ray from (x, y, z) (m) along the unit vector u leaves the grid or runs
    ``length`` (m) without entering a filled cell or the ground (Amanatides & Woo's cell walk).
    Cells entered within one cell size of the start do not count: they are the particle's own
    face, which a ray leaving a flat face at a slant grazes."""
    nx, ny, nz = occupancy.shape
    fx, fy, fz = (x - origin[0]) / h, (y - origin[1]) / h, (z - origin[2]) / h
    i, j, k = int(math.floor(fx)), int(math.floor(fy)), int(math.floor(fz))
    si, tx, dx = _first_crossing(fx, ux, h)
    sj, ty, dy = _first_crossing(fy, uy, h)
    sk, tz, dz = _first_crossing(fz, uz, h)
    while True:
        if tx <= ty and tx <= tz:
            t = tx
            i += si
            tx += dx
        elif ty <= tz:
            t = ty
            j += sj
            ty += dy
        else:
            t = tz
            k += sk
            tz += dz
        if t > length:
            return True
        if k < 0:
            if t >= h:
                return False
        elif i < 0 or j < 0 or i >= nx or j >= ny or k >= nz:
            return True
        elif occupancy[i, j, k] > 0 and t >= h:
            return False


@numba.njit(cache=True, parallel=True)
def _exposure(positions, index, occupancy, origin, h, rays, length, out):
    """Share of the ``rays`` that are unobstructed from each particle ``index[t]``, into ``out[t]``."""
    m = rays.shape[0]
    for t in numba.prange(index.size):
        p = index[t]
        open_rays = 0
        for r in range(m):
            if _unobstructed(occupancy, origin, h, positions[p, 0], positions[p, 1], positions[p, 2],
                             rays[r, 0], rays[r, 1], rays[r, 2], length):
                open_rays += 1
        out[t] = open_rays / m
