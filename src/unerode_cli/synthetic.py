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


#: Steepest median slope (degrees) of a synthetic terrain's land when no relief is given: about
#: that of real mountain ranges (the DEMs of ``../shared/data``: Grindelwald 26.9°, Ötztal 27.8°,
#: Mandakini 27.7°, Patagonia 25.8°, Big Tujunga 22.1°, from central differences).
MEDIAN_SLOPE_DEG = 30.0
#: Land relief (m) when no relief is given and the extent allows it at ``MEDIAN_SLOPE_DEG``.
DEFAULT_RELIEF_M = 2000.0


def shape_of(kind: str, shape: tuple[int, int], seed: int) -> np.ndarray:
    """Relative elevations of a synthetic terrain of ``kind`` (land relief 1: the fractal in
    [0, 1], the mountain range about −0.1 … 1); multiplied by a relief in metres, the terrain."""
    rng = np.random.default_rng(seed)
    if kind == "fractal":
        return fractal(shape, rng)
    if kind == "mountain":
        return mountain(shape, rng)
    raise ValueError(f"unknown synthetic terrain kind {kind!r}; choose one of {', '.join(KINDS)}")


def synthesize(kind: str, shape: tuple[int, int], relief: float, seed: int) -> np.ndarray:
    """Elevations (m) of a synthetic terrain of ``kind`` with ``relief`` metres of land relief."""
    return relief * shape_of(kind, shape, seed)


def relief_for_extent(relative: np.ndarray, dx: float, dy: float,
                      most: float = DEFAULT_RELIEF_M, median_slope_deg: float = MEDIAN_SLOPE_DEG) -> float:
    """The land relief (m) of ``relative`` (from :func:`shape_of`) on cells of ``dx`` × ``dy``
    metres: ``most``, or less where ``most`` would make the median slope of the land (cells
    above 0) steeper than ``median_slope_deg``.

    The slope is the central-difference gradient; a relief r scales it by r, so the relief of
    a median slope α is tan α ÷ (median gradient of ``relative`` per metre). A fractal's
    normalised gradient per cell falls as the grid grows (≈ n^−0.7 from 32 to 1024 cells), so a
    fixed relief is gentle on a large grid and a cliff on a small one (2000 m on 32 × 32 cells of
    30 m: a median of 78°)."""
    if min(relative.shape) < 2:
        return most
    gy, gx = np.gradient(relative, dy, dx)
    gradient = np.hypot(gx, gy, out=gx)[relative > 0.0]
    median = float(np.median(gradient)) if gradient.size else 0.0
    if not median > 0.0:
        return most
    return float(min(most, np.tan(np.radians(median_slope_deg)) / median))


def _unit(field: np.ndarray) -> np.ndarray:
    lo, hi = field.min(), field.max()
    return (field - lo) / (hi - lo) if hi > lo else np.zeros_like(field)
