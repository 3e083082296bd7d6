"""Shallow-ice approximation (SIA): the fast baseline of the ice flow (001 §3.1).

With no sliding, the vertically integrated flux is q = −D·∇s with the diffusivity

    D = 2A·(ρg)^n·H^(n+2)·|∇s|^(n−1) / (n+2)                     (m²/y)

so ū = −D·∇s/H (mean over the column) and u_s = (n+2)/(n+1)·ū at the surface, i.e.
u_s = −2A/(n+1)·(ρg)^n·H^(n+1)·|∇s|^(n−1)·∇s. A is Glen's rate factor in Pa^(−n)·y^(−1)
(see ``blatter`` for the convention), so velocities are in m/y.

∇s is the centred difference of the surface at the nodes (one-sided at open edges), plus the
background inclination −tan(α) along +x. An explicit diffusion step is stable for
dt ≤ c / (2·D_max·(1/dx² + 1/dy²)), which is c·dx²/(4·D_max) for dx = dy (``max_stable_dt``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from unerode_cli.grid import Grid


@dataclass(frozen=True)
class SIAFlow:
    """SIA velocities and diffusivity at the nodes, float64[ny, nx] each.

    Attributes:
        diffusivity: D (m²/y).
        u_mean, v_mean: column-mean velocity ū (m/y).
        u_surface, v_surface: surface velocity (m/y).
    """

    diffusivity: np.ndarray
    u_mean: np.ndarray
    v_mean: np.ndarray
    u_surface: np.ndarray
    v_surface: np.ndarray


def surface_gradient(surface: np.ndarray, grid: Grid, boundary: str, background_slope: float = 0.0):
    """(∂s/∂x, ∂s/∂y) at the nodes, centred differences (m/m); ``boundary`` is ``"periodic"``
    (wraps) or ``"open"`` (one-sided at the edges); ``background_slope`` in radians along +x."""
    s = np.asarray(surface, dtype=np.float64)
    if boundary == "periodic":
        sx = (np.roll(s, -1, axis=1) - np.roll(s, 1, axis=1)) / (2.0 * grid.dx)
        sy = (np.roll(s, -1, axis=0) - np.roll(s, 1, axis=0)) / (2.0 * grid.dy)
    elif boundary == "open":
        sy, sx = (np.gradient(s, grid.dy, grid.dx) if min(s.shape) > 1
                  else (np.zeros_like(s), np.zeros_like(s)))
    else:
        raise ValueError(f"boundary must be 'periodic' or 'open', got {boundary!r}")
    return sx - math.tan(background_slope), sy


def velocity(
    bed: np.ndarray,
    thickness: np.ndarray,
    grid: Grid,
    glen_a: float,
    glen_n: float = 3.0,
    rho: float = 910.0,
    gravity: float = 9.81,
    *,
    boundary: str = "open",
    background_slope: float = 0.0,
) -> SIAFlow:
    """SIA diffusivity and velocities (no sliding) for bed b and thickness H (m).

    Args:
        bed, thickness: float[ny, nx] (m); H ≥ 0.
        grid: cell sizes (m).
        glen_a: A (Pa^(−n)/y); glen_n: n; rho: ρ (kg/m³); gravity: g (m/s²).
        boundary: ``"periodic"`` or ``"open"`` (for ∇s).
        background_slope: uniform inclination along +x (radians), as in ``blatter.solve``.
    """
    h = np.asarray(thickness, dtype=np.float64)
    if np.any(h < 0):
        raise ValueError("the ice thickness must be ≥ 0")
    sx, sy = surface_gradient(np.asarray(bed, dtype=np.float64) + h, grid, boundary, background_slope)
    slope = np.hypot(sx, sy)
    factor = 2.0 * glen_a * (rho * gravity) ** glen_n * slope ** (glen_n - 1.0)
    d = factor * h ** (glen_n + 2.0) / (glen_n + 2.0)
    mean = -factor * h ** (glen_n + 1.0) / (glen_n + 2.0)
    surf = -factor * h ** (glen_n + 1.0) / (glen_n + 1.0)
    return SIAFlow(d, mean * sx, mean * sy, surf * sx, surf * sy)


def max_stable_dt(diffusivity: np.ndarray, grid: Grid, c: float = 0.5) -> float:
    """Largest explicit diffusion step (y): c / (2·D_max·(1/dx² + 1/dy²)), = c·dx²/(4·D_max)
    for dx = dy; c ≤ 1 is the safety factor (the linear FTCS limit is c = 1; the nonlinear SIA
    needs some margin). ``inf`` where D is 0 everywhere."""
    d_max = float(np.max(diffusivity)) if np.size(diffusivity) else 0.0
    if d_max <= 0.0:
        return math.inf
    return c / (2.0 * d_max * (1.0 / grid.dx**2 + 1.0 / grid.dy**2))
