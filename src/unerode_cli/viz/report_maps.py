"""Maps of a report in the coordinates of the raster's CRS: shaded relief and fields over a
grey hillshade, their axes the eastings and northings (or longitudes and latitudes) of the
cells, not kilometres from the corner."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

from unerode_cli.viz.preview import decimate, preview_factor, shaded_relief

#: Width of a report map (inches) and its resolution (dots per inch): 576 px, two maps side by
#: side on a 1400 px page.
WIDTH_IN, DPI = 6.4, 90


@dataclass(frozen=True)
class MapFrame:
    """Where a raster lies: ``extent`` (left, right, bottom, top) of its cells' outer edges in
    CRS units (from the affine transform), the axis labels (with unit and CRS name) and
    ``aspect``, the drawn length of one y unit over one x unit (1 for a projected CRS,
    1 / cos(latitude) for degrees)."""

    extent: tuple[float, float, float, float]
    xlabel: str = "x"
    ylabel: str = "y"
    aspect: float = 1.0


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _figure(plt, frame: MapFrame):
    """A figure whose map keeps the aspect of the frame (CRS units of equal length on x and y)."""
    left, right, bottom, top = frame.extent
    aspect = frame.aspect * abs(top - bottom) / max(abs(right - left), 1e-12)
    return plt.subplots(figsize=(WIDTH_IN, max(2.8, min(11.0, WIDTH_IN * aspect * 0.82 + 0.9))))


def _axes(ax, frame: MapFrame, title: str) -> None:
    """CRS coordinates in plain numbers (no offset, no powers of ten), at most 5 ticks."""
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(5))
    ax.yaxis.set_major_locator(MaxNLocator(6))
    ax.ticklabel_format(style="plain", useOffset=False)
    ax.set_xlabel(frame.xlabel, fontsize=8.5)
    ax.set_ylabel(frame.ylabel, fontsize=8.5)
    ax.tick_params(labelsize=8)
    if title:
        ax.set_title(title, fontsize=9.5)


def _save(plt, fig, path: Path | BinaryIO) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=DPI, format="png")
    plt.close(fig)


def save_relief_map(elevation: np.ndarray, dx: float, dy: float, frame: MapFrame,
                    path: Path | BinaryIO, title: str = "", label: str = "elevation (m)") -> None:
    """Write a PNG of ``elevation`` (float[ny, nx] m, row 0 = north, NaN = nodata, cells
    ``dx`` × ``dy`` m): hillshade (sun from the north-west, 45° high) soft-blended with the
    sea-land colours of :func:`~unerode_cli.viz.preview.sea_land_colormap`, on the axes of
    ``frame``. Rasters of more than 2048 cells a side are first reduced by block means."""
    plt = _pyplot()
    shaded, norm, colours = shaded_relief(elevation, dx, dy)
    fig, ax = _figure(plt, frame)
    ax.imshow(shaded, extent=frame.extent, interpolation="bilinear", aspect=frame.aspect)
    _axes(ax, frame, title)
    bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=colours), ax=ax, shrink=0.85)
    bar.set_label(label, fontsize=8.5)
    _save(plt, fig, path)


def save_field_map(field: np.ndarray, elevation: np.ndarray, dx: float, dy: float, frame: MapFrame,
                   path: Path | BinaryIO, label: str, title: str = "", cmap: str = "magma_r",
                   diverging: bool = False) -> None:
    """Write a PNG of ``field`` (float[ny, nx], e.g. a spread or a change in m) over a grey
    hillshade of ``elevation`` (m, same shape), on the axes of ``frame``. With ``diverging``
    the colours are blue-white-red centred on 0 with a symmetric range (the 99.5th percentile
    of |field|): red where the field is positive (e.g. a past surface above today's)."""
    from matplotlib.colors import LightSource

    plt = _pyplot()
    factor = preview_factor(field.shape)
    relief = decimate(elevation, factor, "mean")
    values = decimate(field, factor, "mean", nodata_from=elevation) if factor > 1 else field
    valid = np.isfinite(relief) & np.isfinite(values)
    if not valid.any():
        raise ValueError("the field has no valid cell to map")
    shade = LightSource(azdeg=315, altdeg=45).hillshade(
        np.where(np.isfinite(relief), relief, np.nanmin(relief)), dx=dx * factor, dy=dy * factor)
    fig, ax = _figure(plt, frame)
    ax.imshow(np.where(np.isfinite(relief), shade, np.nan), cmap="gray", extent=frame.extent,
              aspect=frame.aspect)
    shown = np.where(valid, values, np.nan)
    style: dict = {"cmap": cmap}
    if diverging:
        bound = float(np.nanpercentile(np.abs(shown), 99.5)) or 1.0
        style = {"cmap": "RdBu_r", "vmin": -bound, "vmax": bound}
    image = ax.imshow(shown, extent=frame.extent, alpha=0.85, interpolation="nearest", aspect=frame.aspect,
                      **style)
    _axes(ax, frame, title)
    fig.colorbar(image, ax=ax, shrink=0.85).set_label(label, fontsize=8.5)
    _save(plt, fig, path)
