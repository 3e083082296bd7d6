"""Glacial erosion of the bed by the sliding ice (001 §6.1), rates in m/y (≤ 0).

    abrasion:  ∂z/∂t = −k_e·|u_s|^l                                  (001 §6.1, Herman et al. 2015)
    quarrying: ∂z/∂t = −k_q·|u_s|·Q(u_s, ∇z)                         (001 §6.1, Egholm et al. 2012)
    Q = ½·(erf(−(u_s·∇z) / (0.4·|u_s|)) + 1)

u_s: basal sliding velocity (m/y), from the bottom level of the flow lattice
(``FlowSolution.basal_velocity``). Q → 1 where the ice slides down a bed slope steeper than
~0.4 (lee sides), ½ on flat beds, → 0 up an adverse slope. As 001 says, ∇z is taken
"downward in the x and y directions": along each axis, the one-sided difference towards the
lower of the two neighbours (0 in a local minimum along that axis). Units: k_e in
m^(1−l)·y^(l−1), k_q dimensionless, so both rates are in m/y.

Over-deepenings (not in 001): where the bed rises along the sliding direction more steeply than
ζ = ``adverse_slope_ratio`` times the ice surface falls, neither process erodes
(``adverse_slope_erodes``). Alley et al. (2003, Nature 424, "Stabilizing feedbacks in
glacier-bed erosion") found that water climbing an adverse bed slope steeper than 1.2–1.7 times
the surface slope supercools and freezes on: debris-laden ice accretes and the bed stops being
cut, which caps how deep a basin gets. 001's abrasion has no such limit, and the lattice's
terrain-following columns do not stop the ice sliding at the bottom of a one-cell pit, whose
walls steepen the ice surface into it, which speeds the ice, which deepens the pit. On
Grindelwald at 92 m through the last glacial cycle (from 115 ka, 50-year steps) the cells beside
the held east edge, where the Aar's ice leaves the map, were cut at ~3 m/y under ice sliding at
4.3 km/y: at 16.5 ka 29 cells lay more than 2 km below the DEM, the deepest 12.5 km, and the run
diverged at 15.3 ka. The default ζ = 1.5 is the middle of Alley's range.
"""

from __future__ import annotations

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.processes.parameters import ParamSpec

PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("k_e", "m^(1-l)·y^(l-1)", 1.3e-7, "abrasion coefficient k_e (001 §6.1; 001 Table 1: "
              "1.3e-7 to 1.1e-6)", minimum=0.0, raster=True),
    ParamSpec("abrasion_exponent", "1", 2.02, "abrasion exponent l (001 Table 1: 2.02)", minimum=0.0,
              symbol="l"),
    ParamSpec("k_q", "1", 3.2e-5, "quarrying coefficient k_q (001 §6.1; 001 Table 1: 3.2e-5 to 2.6e-4)",
              minimum=0.0, raster=True),
    ParamSpec("adverse_slope_ratio", "1", 1.5, "no erosion where the bed rises along the sliding ice "
              "more steeply than this times the ice surface falls (Alley et al. 2003: 1.2–1.7)",
              minimum=0.0),
)


def _differences(z: np.ndarray, axis: int, boundary: str, past_edge: float) -> tuple[np.ndarray, np.ndarray]:
    """(z[i+1] − z[i], z[i] − z[i−1]) along ``axis`` (m): wrapped where ``boundary`` is
    ``"periodic"``; where it is ``"open"``, ``past_edge`` stands for the difference to the missing
    neighbour (``+past_edge`` ahead of the last cell, ``−past_edge`` behind the first)."""
    if boundary == "periodic":
        return np.roll(z, -1, axis=axis) - z, z - np.roll(z, 1, axis=axis)
    if boundary != "open":
        raise ValueError(f"boundary must be 'periodic' or 'open', got {boundary!r}")
    edge = np.diff(z, axis=axis)
    ahead = np.pad(edge, [(0, 1) if a == axis else (0, 0) for a in (0, 1)], constant_values=past_edge)
    behind = np.pad(edge, [(1, 0) if a == axis else (0, 0) for a in (0, 1)], constant_values=-past_edge)
    return ahead, behind


def downward_gradient(z: np.ndarray, grid: Grid, boundary: str = "open") -> tuple[np.ndarray, np.ndarray]:
    """(∂z/∂x, ∂z/∂y) (m/m) taken towards the lower neighbour along each axis (001 §6.1, §6.2).

    Along x: if the steeper descent is towards i+1, (z[i+1] − z[i])/dx, if towards i−1,
    (z[i] − z[i−1])/dx, and 0 where both neighbours are higher. ``boundary``: ``"periodic"``
    wraps; ``"open"`` uses the one neighbour at an edge.
    """
    z = np.asarray(z, dtype=np.float64)
    out = []
    for axis, step in ((1, grid.dx), (0, grid.dy)):
        fwd, bwd = _differences(z, axis, boundary, np.inf)  # no neighbour: never lower
        drop_fwd, drop_bwd = -fwd, bwd  # descent towards i+1 and towards i−1 (m)
        g = np.where(drop_fwd >= drop_bwd, fwd, bwd)
        out.append(np.where(np.maximum(drop_fwd, drop_bwd) > 0, g, 0.0) / step)
    return out[0], out[1]


def quarrying_focus(ub: np.ndarray, vb: np.ndarray, zx: np.ndarray, zy: np.ndarray) -> np.ndarray:
    """Q = ½·(erf(−(u_s·∇z)/(0.4·|u_s|)) + 1) (001 §6.1); ½ where the ice does not slide."""
    from scipy.special import erf

    speed = np.hypot(ub, vb)
    arg = -(ub * zx + vb * zy) / (0.4 * np.where(speed > 0, speed, 1.0))
    return 0.5 * (erf(np.where(speed > 0, arg, 0.0)) + 1.0)


def slope_along(z: np.ndarray, ub: np.ndarray, vb: np.ndarray, grid: Grid,
                boundary: str = "open") -> np.ndarray:
    """dz/ds (m/m) along the direction of (ub, vb), each axis's derivative taken towards the
    downstream neighbour (> 0: z rises where the ice goes); 0 where (ub, vb) = 0, and along an
    axis whose downstream neighbour is past an open edge."""
    z = np.asarray(z, dtype=np.float64)
    speed = np.hypot(ub, vb)
    total = np.zeros(z.shape)
    for axis, velocity, size in ((1, ub, grid.dx), (0, vb, grid.dy)):
        ahead, behind = _differences(z, axis, boundary, 0.0)
        total += np.where(velocity >= 0, ahead, behind) * velocity / size
    return np.divide(total, speed, out=np.zeros(z.shape), where=speed > 0)


def adverse_slope_erodes(bed: np.ndarray, surface: np.ndarray, ub: np.ndarray, vb: np.ndarray,
                         grid: Grid, ratio: float, boundary: str = "open") -> np.ndarray:
    """bool[ny, nx]: False where the bed rises along the sliding direction by more than
    ``ratio`` times the ice surface falls (Alley et al. 2003; module docstring), True elsewhere."""
    rise = slope_along(bed, ub, vb, grid, boundary)
    fall = -slope_along(surface, ub, vb, grid, boundary)
    return rise <= ratio * np.maximum(fall, 0.0)


def erosion_rates(
    bed: np.ndarray,
    ub: np.ndarray,
    vb: np.ndarray,
    grid: Grid,
    k_e: float | np.ndarray = 1.3e-7,
    abrasion_exponent: float = 2.02,
    k_q: float | np.ndarray = 3.2e-5,
    boundary: str = "open",
    *,
    surface: np.ndarray | None = None,
    adverse_slope_ratio: float = 1.5,
) -> tuple[np.ndarray, np.ndarray]:
    """Abrasion and quarrying rates (m/y, ≤ 0), float64[ny, nx] each (001 §6.1).

    Args:
        bed: bedrock elevation z (m).
        ub, vb: basal sliding velocity along x and y (m/y); 0 where there is no ice.
        grid: cell sizes (m).
        k_e: abrasion coefficient (m^(1−l)·y^(l−1)); abrasion_exponent: l.
        k_q: quarrying coefficient (dimensionless).
        boundary: edges of the bed gradient, ``"periodic"`` or ``"open"``.
        surface: the ice surface b + H (m): no erosion on adverse bed slopes steeper than
            ``adverse_slope_ratio`` (ζ) times its fall (``adverse_slope_erodes``); None: 001's
            rates everywhere.
    """
    for spec, value in zip(PARAMETERS, (k_e, abrasion_exponent, k_q, adverse_slope_ratio), strict=True):
        spec.check(value)
    speed = np.hypot(ub, vb)
    zx, zy = downward_gradient(bed, grid, boundary)
    abrasion = -np.asarray(k_e) * speed**abrasion_exponent
    quarrying = -np.asarray(k_q) * speed * quarrying_focus(ub, vb, zx, zy)
    if surface is not None:
        erodes = adverse_slope_erodes(bed, surface, ub, vb, grid, adverse_slope_ratio, boundary)
        abrasion, quarrying = np.where(erodes, abrasion, 0.0), np.where(erodes, quarrying, 0.0)
    return abrasion, quarrying
