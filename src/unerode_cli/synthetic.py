"""Reproducible synthetic heightfields (metres): spectral fractal noise and a mountain range
with ridges, valleys and a coastline. Pure NumPy; the same seed gives the same terrain."""

from __future__ import annotations

import numpy as np

KINDS = ("fractal", "mountain")


def fractal(shape: tuple[int, int], rng: np.random.Generator, beta: float = 3.2) -> np.ndarray:
    """Gaussian random field with power spectrum ∝ k^−β, normalised to [0, 1].

    β = 2H + 2 for a surface of Hurst exponent H; β ≈ 3.2 (H ≈ 0.6) resembles real relief.
    """
    ny, nx = shape
    ky = np.fft.fftfreq(ny)[:, None]
    kx = np.fft.rfftfreq(nx)[None, :]
    k = np.hypot(kx, ky)
    k[0, 0] = np.inf
    amplitude = k ** (-beta / 2.0)
    spectrum = amplitude * (rng.standard_normal(k.shape) + 1j * rng.standard_normal(k.shape))
    field = np.fft.irfft2(spectrum, s=shape)
    return _unit(field)


def mountain(shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """A range draining south to a sea edge, normalised so that the sea floor is < 0 < land.

    Ridged multifractal noise (octaves of (1 − |n|)², each weighted by the coarser one)
    gives sharp crests and V-shaped valleys; an envelope rising from the south edge to the
    north third puts a coastline along the south, made irregular by low-frequency noise.
    Returned values are relative (about −0.1 … 1); scale them by a relief in metres.
    """
    ny, nx = shape
    ridges = np.zeros(shape)
    weight = np.ones(shape)
    for octave in range(6):
        band = 2.0 * fractal(shape, rng, beta=3.6) - 1.0
        ridge = (1.0 - np.abs(band)) ** 2 * weight
        weight = np.clip(ridge * 2.0, 0.0, 1.0)
        ridges += ridge * 0.5**octave
    ridges = _unit(ridges)
    y = np.linspace(0.0, 1.0, ny)[:, None]  # 0 at the north edge, 1 at the south edge
    coast_wobble = 0.12 * (fractal((1, nx), rng, beta=5.0)[0] - 0.5)
    coast = 0.85 + coast_wobble[None, :]
    envelope = np.clip((coast - y) / 0.6, 0.0, 1.0) ** 0.8
    land = envelope * (0.1 + 0.9 * ridges**1.5)
    sea_floor = -0.1 * np.clip((y - coast) / 0.15, 0.0, 1.0)
    return land + sea_floor - 0.002 * (y > coast)


def synthesize(kind: str, shape: tuple[int, int], relief: float, seed: int) -> np.ndarray:
    """Elevations (m) of a synthetic terrain of ``kind`` with ``relief`` metres of land relief."""
    rng = np.random.default_rng(seed)
    if kind == "fractal":
        return relief * fractal(shape, rng)
    if kind == "mountain":
        return relief * mountain(shape, rng)
    raise ValueError(f"unknown synthetic terrain kind {kind!r}; choose one of {', '.join(KINDS)}")


def _unit(field: np.ndarray) -> np.ndarray:
    lo, hi = field.min(), field.max()
    return (field - lo) / (hi - lo) if hi > lo else np.zeros_like(field)
