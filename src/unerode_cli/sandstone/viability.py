"""Fabric interlocking and viability (002 §3.2, Eq. 1–2).

Sign convention: stresses are tension positive; the *compressive stress* is −tr σ (Pa,
compression positive). 002 Eq. 2 switches to the interlocked erodibility k_s "if trace(σ_c) > I",
which only makes sense with compression counted positive: the rock interlocks where −tr σ > I.

Eq. 1 is integrated with forward Euler over a frame of Δt years, on surface particles only:
b ← b − E·(W + F)·Δt, with W = W_a + W_d the wind rates (002 Eq. 7) and F the fluvial rate
(002 Eq. 14; zero until fluvial erosion runs), all dimensionless, and E in 1/y. A particle whose
viability reaches 0 is eroded.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, parallel=True)
def erodibility(layer: np.ndarray, factor: np.ndarray, stress: np.ndarray, k_w: np.ndarray,
                k_s: np.ndarray, threshold: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """E (1/y) of every particle and whether it is interlocked (002 Eq. 2): k_s where the
    compressive stress ``stress`` (−tr σ, Pa) exceeds its layer's ``threshold`` I (Pa), else k_w;
    times the particle's erodibility ``factor`` (paint, noise). ``k_w``, ``k_s`` and ``threshold``
    are per layer, indexed by ``layer``."""
    n = layer.shape[0]
    rate = np.empty(n)
    interlocked = np.empty(n, dtype=np.bool_)
    for p in numba.prange(n):
        locked = stress[p] > threshold[layer[p]]
        interlocked[p] = locked
        rate[p] = factor[p] * (k_s[layer[p]] if locked else k_w[layer[p]])
    return rate, interlocked


@numba.njit(cache=True, parallel=True)
def erode(viability: np.ndarray, surface: np.ndarray, rate: np.ndarray, wind: np.ndarray,
          fluvial: np.ndarray, dt: float) -> np.ndarray:
    """b ← b − E·(W + F)·Δt on surface particles (002 Eq. 1), in place; returns which particles
    are eroded: those that lost viability this frame and are left with b ≤ 0 (so a deposit of
    viability 0, 002 Table 1, stays where nothing erodes it). ``rate`` E in 1/y, ``wind`` W and
    ``fluvial`` F dimensionless, ``dt`` in years."""
    n = viability.shape[0]
    eroded = np.zeros(n, dtype=np.bool_)
    for p in numba.prange(n):
        loss = rate[p] * (wind[p] + fluvial[p]) * dt
        if surface[p] and loss > 0.0:
            viability[p] -= loss
            eroded[p] = viability[p] <= 0.0
    return eroded
