"""Hillshade preview of a heightfield: shading blended with an elevation colour ramp."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LightSource, Normalize  # noqa: E402


def save_preview(
    elevation: np.ndarray,
    dx: float,
    dy: float,
    path: Path,
    title: str = "",
    cmap: str = "terrain",
    vertical_exaggeration: float = 1.0,
    dpi: int = 110,
) -> None:
    """Save a PNG: hillshade (sun from the north-west, 45°) soft-blended with ``cmap``,
    nodata (NaN) transparent, and a colour bar in metres.

    ``elevation`` is in metres (row 0 = north), ``dx``/``dy`` the cell sizes in metres so that
    slopes — hence shading — are true to the ground.
    """
    valid = np.isfinite(elevation)
    if not valid.any():
        raise ValueError("the heightfield has no valid cell to preview")
    lo, hi = float(np.nanmin(elevation)), float(np.nanmax(elevation))
    norm = Normalize(lo, hi if hi > lo else lo + 1.0)
    filled = np.where(valid, elevation, lo)
    shaded = LightSource(azdeg=315, altdeg=45).shade(
        filled, cmap=plt.get_cmap(cmap), norm=norm, blend_mode="soft",
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
    bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.85)
    bar.set_label("elevation (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
