"""Hillshade preview of a heightfield: shading blended with an elevation colour ramp."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import Colormap, LightSource, ListedColormap, Normalize  # noqa: E402

#: Fraction of matplotlib's "terrain" colour map that is water (blues); the rest is land.
TERRAIN_WATER_FRACTION = 0.22


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
    slopes — hence shading — are true to the ground.
    """
    valid = np.isfinite(elevation)
    if not valid.any():
        raise ValueError("the heightfield has no valid cell to preview")
    lo, hi = float(np.nanmin(elevation)), float(np.nanmax(elevation))
    norm = Normalize(lo, hi if hi > lo else lo + 1.0)
    filled = np.where(valid, elevation, lo)
    colour_map = sea_land_colormap(lo, hi) if cmap == "sea-land" else plt.get_cmap(cmap)
    shaded = LightSource(azdeg=315, altdeg=45).shade(
        filled, cmap=colour_map, norm=norm, blend_mode="soft",
        vert_exag=vertical_exaggeration, dx=dx, dy=dy,
    )
    shaded[..., 3] = valid
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
    """
    valid = np.isfinite(elevation) & np.isfinite(field)
    if not valid.any():
        raise ValueError("the field has no valid cell to preview")
    filled = np.where(np.isfinite(elevation), elevation, np.nanmin(elevation))
    shade = LightSource(azdeg=315, altdeg=45).hillshade(filled, dx=dx, dy=dy)
    values = np.where(valid, field, np.nan)
    if log:
        values = np.log10(np.where(values > 0, values, np.nan))
        label = f"log10 {label}"
    ny, nx = field.shape
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
