"""Ice transport: ∂H/∂t = M − ∇·(H·ū) (001 Eq. 1), explicit and conservative.

One step is forward Euler on finite volumes (``transport_kernels``): upwind face fluxes with a
minmod slope limiter, then H ← max(0, H + dt·(M − ∇·(Hū))), since Eq. 1 "only holds when
h > 0" (001 §3.1). With M = 0 the flux form conserves the ice volume exactly on a periodic or
closed domain (what leaves a cell enters its neighbour) and H stays ≥ 0 without the clamp as
long as dt respects the CFL condition below.

CFL (001 §5): dt ≤ c / (max|u|/dx + max|v|/dy), which is 001's c·dx/|ū| for flow along an
axis, with c = 0.1 as 001 found. Each face then moves at most a fraction c of the limited
upwind thickness (≤ 3/2·H), so a cell loses at most 3c·H ≤ H per step: H ≥ 0 for c ≤ 1/3.

The numba kernels are imported on first use.
"""

from __future__ import annotations

import math

import numpy as np

from unerode_cli.grid import Grid

#: 001 §5: "we found that c = 0.1 suppressed all instability in the ice model".
CFL = 0.1
_MODES = {"periodic": 0, "closed": 1, "open": 2}
#: Ice thinner than this (m) at the end of a step melts out where the mass balance is negative.
MELT_OUT_THICKNESS = 0.01


def max_stable_dt(u_mean: np.ndarray, v_mean: np.ndarray, grid: Grid, c: float = CFL) -> float:
    """Largest stable explicit step (y): c / (max|ū|/dx + max|v̄|/dy); ``inf`` for still ice."""
    rate = float(np.max(np.abs(u_mean))) / grid.dx + float(np.max(np.abs(v_mean))) / grid.dy
    return math.inf if rate == 0.0 else c / rate


def flux_divergence(thickness: np.ndarray, u_mean: np.ndarray, v_mean: np.ndarray, grid: Grid,
                    boundary: str = "closed") -> np.ndarray:
    """∇·(H·ū) (m/y), float64[ny, nx], for H (m) and the column-mean velocity (m/y) at the nodes.

    ``boundary``: ``"periodic"``, ``"closed"`` (no flux through the domain edges) or ``"open"``
    (ice leaves through the edges, none enters).
    """
    from unerode_cli.glacier import transport_kernels as tk

    if boundary not in _MODES:
        raise ValueError(f"boundary must be one of {sorted(_MODES)}, got {boundary!r}")
    h, u, v = (np.ascontiguousarray(a, dtype=np.float64) for a in (thickness, u_mean, v_mean))
    if not (h.shape == u.shape == v.shape == grid.shape):
        raise ValueError(f"thickness and velocities must have the grid's shape {grid.shape}")
    return tk.flux_divergence(h, u, v, grid.dx, grid.dy, _MODES[boundary])


def step(thickness: np.ndarray, u_mean: np.ndarray, v_mean: np.ndarray, mass_balance: float | np.ndarray,
         grid: Grid, dt: float, boundary: str = "closed") -> np.ndarray:
    """H(t + dt) = max(0, H + dt·(M − ∇·(H·ū))) (001 Eq. 1), float64[ny, nx] (m), then ``melt_out``.

    Args:
        thickness: H ≥ 0 (m); not modified.
        u_mean, v_mean: column-mean ice velocity ū at the nodes (m/y).
        mass_balance: M (m/y of ice), scalar or raster (``massbalance.mass_balance``).
        grid: cell sizes (m).
        dt: time step (y), 0 ≤ dt; keep it ≤ ``max_stable_dt`` (not enforced here).
        boundary: ``"periodic"``, ``"closed"`` or ``"open"`` (see ``flux_divergence``).
    """
    if not (dt >= 0 and math.isfinite(dt)):
        raise ValueError(f"the time step must be finite and ≥ 0, got {dt} y")
    div = flux_divergence(thickness, u_mean, v_mean, grid, boundary)
    return melt_out(np.maximum(0.0, np.asarray(thickness, dtype=np.float64) + dt * (mass_balance - div)),
                    mass_balance)


def melt_out(thickness: np.ndarray, mass_balance: float | np.ndarray) -> np.ndarray:
    """H (m) with the ice thinner than ``MELT_OUT_THICKNESS`` set to 0 where M < 0 (m/y),
    float64[ny, nx].

    The coarse levels of a multi-scale step (``multiscale``) spread each level's change over 2^i
    cells, ice-free ground beyond the glacier included, and leave films there (on Grindelwald
    after 2000 y at ELA 2900 m: 16 % of the cells under less than 1 cm of ice, 19 m³ in all, down
    to 1e-21 m): ice that Eq. 1 would not put there and that the next step's melt halves rather
    than removes, so it decays geometrically. Below the equilibrium line such ice melts within a
    year (1 cm where the surface is 1 m below it, β = 0.01/y), so there it is melted out at the
    step's end. Where M ≥ 0 nothing melts: thin ice there is snow that stays, or ice that only
    the flow moves (with M = 0 the transport keeps the volume). The threshold is far below the
    thinnest glacier ice of the model (1 m, ``lakes.ICE_FREE_BELOW``), so glaciers and their
    tongues keep their ice."""
    thin = (thickness < MELT_OUT_THICKNESS) & (np.asarray(mass_balance) < 0.0)
    return np.where(thin, 0.0, thickness)

