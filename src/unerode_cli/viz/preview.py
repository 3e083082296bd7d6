"""Hillshade preview of a heightfield: shading blended with an elevation colour ramp."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import Colormap, LightSource, ListedColormap, Normalize  # noqa: E402

#: Fraction of matplotlib's "terrain" colour map that is water (blues); the rest is land.
TERRAIN_WATER_FRACTION = 0.22

#: Most cells per side that a preview shades: the figures are 7 in wide at 110 dpi (≈770 px),
#: so about twice that many cells already show every pixel's detail.
PREVIEW_MAX_CELLS = 2048


def preview_factor(shape: tuple[int, ...], max_cells: int = PREVIEW_MAX_CELLS) -> int:
    """The smallest integer block size ``factor`` (≥ 1) such that both sides of a raster of
    ``shape`` (rows, columns) are at most ``max_cells`` after :func:`decimate` (which keeps
    ``ceil(n / factor)`` cells per side of ``n``)."""
    if max_cells < 1:
        raise ValueError(f"max_cells must be at least 1, not {max_cells}")
    return max([1, *(math.ceil(n / max_cells) for n in shape)])


def decimate(
    values: np.ndarray, factor: int, how: str = "mean", nodata_from: np.ndarray | None = None,
) -> np.ndarray:
    """Reduce a 2-D float raster (NaN = nodata) by non-overlapping ``factor`` × ``factor`` blocks.

    Returns a float64 array of shape ``(ceil(ny / factor), ceil(nx / factor))``; the last row and
    column of blocks may be partial. ``how`` is ``"mean"`` (mean of the block's valid cells) or
    ``"max"`` (largest valid cell); a block with no valid cell gives NaN. Cells where
    ``nodata_from`` (same shape, optional) is NaN count as nodata too. With ``factor`` 1 the
    input itself is returned (or a copy with NaN where ``nodata_from`` is NaN).

    The input is read in strips of ``factor`` rows, so the temporaries hold about
    ``factor`` × ``nx`` cells each, never the whole raster.
    """
    if how not in ("mean", "max"):
        raise ValueError(f"how must be 'mean' or 'max', not {how!r}")
    if factor < 1 or int(factor) != factor:
        raise ValueError(f"factor must be a positive integer, not {factor}")
    if values.ndim != 2 or (nodata_from is not None and nodata_from.shape != values.shape):
        raise ValueError("decimate takes a 2-D raster (and a nodata_from of the same shape)")
    factor = int(factor)
    if factor == 1:
        return values if nodata_from is None else np.where(np.isnan(nodata_from), np.nan, values)
    ny, nx = values.shape
    my, mx = -(-ny // factor), -(-nx // factor)
    out = np.empty((my, mx))
    strip = np.full((factor, mx * factor), np.nan)  # padded with NaN past the last column
    reduce = np.nanmean if how == "mean" else np.nanmax
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN blocks: NaN, as documented
        for i in range(my):
            rows = slice(i * factor, min((i + 1) * factor, ny))
            n = rows.stop - rows.start
            strip[:n, :nx] = values[rows]
            if n < factor:
                strip[n:] = np.nan
            if nodata_from is not None:
                strip[:n, :nx][np.isnan(nodata_from[rows])] = np.nan
            out[i] = reduce(strip.reshape(factor, mx, factor), axis=(0, 2))
    return out


def save_preview(
    elevation: np.ndarray,
    dx: float,
    dy: float,
    path: Path,
    title: str = "",
    cmap: str = "sea-land",
    vertical_exaggeration: float = 1.0,
    dpi: int = 110,
    label: str = "elevation (m)",
) -> None:
    """Save a PNG: hillshade (sun from the north-west, 45°) soft-blended with ``cmap``,
    nodata (NaN) transparent, and a colour bar named ``label`` (a raster in metres that is not an
    elevation, e.g. an ice thickness, says so there).

    The default ``"sea-land"`` colour map shows elevations below 0 m in blues and land in the
    greens-to-white of matplotlib's "terrain", so that low land never looks like sea; any
    other matplotlib colour map name is used as it is.

    ``elevation`` is in metres (row 0 = north), ``dx``/``dy`` the cell sizes in metres so that
    slopes — hence shading — are true to the ground. A raster with more than
    :data:`PREVIEW_MAX_CELLS` cells on a side is first reduced by block means
    (:func:`preview_factor`, :func:`decimate`) and shaded with cells ``factor`` times larger;
    the colour range and the axes (km) stay those of the full raster.
    """
    shaded, norm, colour_map = shaded_relief(elevation, dx, dy, cmap, vertical_exaggeration)
    ny, nx = elevation.shape
    aspect = (ny * dy) / (nx * dx)
    width = 7.0
    fig, ax = plt.subplots(figsize=(width, max(2.5, min(12.0, width * aspect * 0.85 + 0.6))))
    ax.imshow(shaded, extent=(0, nx * dx / 1000.0, 0, ny * dy / 1000.0), interpolation="bilinear")
    ax.set_xlabel("x (km)")
    ax.set_ylabel("y (km)")
    if title:
        ax.set_title(title, fontsize=10)
    bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=colour_map), ax=ax, shrink=0.85)
    bar.set_label(label)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def shaded_relief(elevation: np.ndarray, dx: float, dy: float, cmap: str = "sea-land",
                  vertical_exaggeration: float = 1.0) -> tuple[np.ndarray, Normalize, Colormap]:
    """(RGBA float[my, mx, 4], its Normalize, its colour map): the hillshade of ``elevation``
    (float[ny, nx] m, NaN = nodata, cells ``dx`` × ``dy`` m; sun from the north-west, 45° high)
    soft-blended with ``cmap`` over the raster's full elevation range, nodata transparent. A
    raster of more than :data:`PREVIEW_MAX_CELLS` cells a side is first reduced by block means
    (:func:`preview_factor`, :func:`decimate`) and shaded with cells that many times larger.
    ValueError when no cell is valid."""
    factor = preview_factor(elevation.shape)
    small = decimate(elevation, factor, "mean")
    valid = np.isfinite(small)
    if not valid.any():
        raise ValueError("the heightfield has no valid cell to preview")
    lo, hi = float(np.nanmin(elevation)), float(np.nanmax(elevation))
    norm = Normalize(lo, hi if hi > lo else lo + 1.0)
    colour_map = sea_land_colormap(lo, hi) if cmap == "sea-land" else plt.get_cmap(cmap)
    shaded = LightSource(azdeg=315, altdeg=45).shade(
        np.where(valid, small, lo), cmap=colour_map, norm=norm, blend_mode="soft",
        vert_exag=vertical_exaggeration, dx=dx * factor, dy=dy * factor,
    )
    shaded[..., 3] = valid
    return shaded, norm, colour_map


def sea_land_colormap(lo: float, hi: float, levels: int = 256) -> Colormap:
    """Matplotlib's "terrain" split at 0 m: its water blues for [lo, 0), its land colours for
    [0, hi], each stretched over its share of the elevation range."""
    terrain = plt.get_cmap("terrain")
    sea_share = float(np.clip(-lo / (hi - lo), 0.0, 1.0)) if hi > lo else 0.0
    n_sea = int(round(levels * sea_share))
    sea = terrain(np.linspace(0.0, TERRAIN_WATER_FRACTION, n_sea))
    land = terrain(np.linspace(TERRAIN_WATER_FRACTION + 0.03, 1.0, levels - n_sea))
    return ListedColormap(np.vstack([sea, land]), name="sea-land")


def save_field_preview(
    field: np.ndarray,
    elevation: np.ndarray,
    dx: float,
    dy: float,
    path: Path,
    label: str,
    title: str = "",
    log: bool = False,
    cmap: str = "Blues",
    diverging: bool = False,
    dpi: int = 110,
) -> None:
    """Save a PNG of ``field`` (e.g. discharge, m³/y) over a grey hillshade of ``elevation``.

    With ``log`` the colours follow log10 of the positive values (drainage networks span many
    orders of magnitude); with ``diverging`` the colours are red-white-blue, centred on 0 with
    a symmetric range (for signed changes). The colour bar is labelled ``label`` (with unit).

    ``field`` and ``elevation`` (m) share one shape (row 0 = north); ``dx``/``dy`` are the cell
    sizes in metres. A raster with more than :data:`PREVIEW_MAX_CELLS` cells on a side is first
    reduced by blocks (:func:`preview_factor`, :func:`decimate`): the elevation by its mean and
    shaded with cells ``factor`` times larger, the field by its maximum with ``log`` (a
    one-cell river stays visible) and by its mean otherwise, over the cells with an elevation.
    The axes (km) stay those of the full raster.
    """
    factor = preview_factor(field.shape)
    elevation_full = elevation
    elevation = decimate(elevation_full, factor, "mean")
    if factor > 1:
        field = decimate(field, factor, "max" if log else "mean", nodata_from=elevation_full)
    valid = np.isfinite(elevation) & np.isfinite(field)
    if not valid.any():
        raise ValueError("the field has no valid cell to preview")
    filled = np.where(np.isfinite(elevation), elevation, np.nanmin(elevation))
    shade = LightSource(azdeg=315, altdeg=45).hillshade(filled, dx=dx * factor, dy=dy * factor)
    values = np.where(valid, field, np.nan)
    if log:
        values = np.log10(np.where(values > 0, values, np.nan))
        label = f"log10 {label}"
    ny, nx = elevation_full.shape
    extent = (0, nx * dx / 1000.0, 0, ny * dy / 1000.0)
    fig, ax = plt.subplots(figsize=(7.0, max(2.5, min(12.0, 7.0 * ny * dy / (nx * dx) * 0.85 + 0.6))))
    ax.imshow(np.where(np.isfinite(elevation), shade, np.nan), cmap="gray", extent=extent)
    style: dict = {"cmap": cmap}
    if diverging:
        bound = float(np.nanpercentile(np.abs(values), 99.5)) or 1.0
        style = {"cmap": "RdBu", "vmin": -bound, "vmax": bound}
    image = ax.imshow(values, extent=extent, alpha=0.85, interpolation="nearest", **style)
    ax.set_xlabel("x (km)")
    ax.set_ylabel("y (km)")
    if title:
        ax.set_title(title, fontsize=10)
    fig.colorbar(image, ax=ax, shrink=0.85).set_label(label)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
