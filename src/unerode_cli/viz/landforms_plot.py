"""One PNG of the landform measures of a DEM: a map (hillshade, lakes, the trunk, its
cross-sections and tributary junctions), the cross-sections with their power-law fits, the
hypsometry before and after, and the shape exponent and tributary steps along the trunk."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class SectionCurve:
    """A cross-section to draw.

    Attributes:
        rows, cols: float64[k] cell coordinates of its samples (for the map).
        distance_m: float64[k] distance from the trunk (m).
        elevation_m: float64[k] sampled elevation (m).
        fitted_m: float64[k] fitted elevation z0 + a|x − x0|^b (m).
        floor_m: the fitted floor z0 (m), subtracted from both curves.
        chainage_m: where it crosses the trunk (m from the mouth).
        b: its shape exponent.
    """

    rows: np.ndarray
    cols: np.ndarray
    distance_m: np.ndarray
    elevation_m: np.ndarray
    fitted_m: np.ndarray
    floor_m: float
    chainage_m: float
    b: float


@dataclass(frozen=True)
class JunctionMark:
    """A tributary junction to draw: its trunk cell (row, col), chainage (m), step (m) and
    whether it counts as hanging."""

    row: int
    col: int
    chainage_m: float
    step_m: float
    hanging: bool


def _to_km(rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int], dx: float, dy: float):
    """Map coordinates (km; x east from the west edge, y north from the south edge) of cell
    coordinates, as drawn by ``imshow`` with the extent used below."""
    x = (np.asarray(cols, dtype=float) + 0.5) * dx / 1000.0
    y = (shape[0] - np.asarray(rows, dtype=float) - 0.5) * dy / 1000.0
    return x, y


def _section_colours(sections: list[SectionCurve]) -> list:
    """The colour of each cross-section: viridis at its chainage over the longest one."""
    import matplotlib.pyplot as plt

    colours = plt.get_cmap("viridis")
    longest = max([s.chainage_m for s in sections], default=1.0) or 1.0
    return [colours(section.chainage_m / longest) for section in sections]


def _draw_map(ax, elevation: np.ndarray, dx: float, dy: float, lake_depth: np.ndarray,
              trunk_rows: np.ndarray, trunk_cols: np.ndarray, sections: list[SectionCurve],
              junctions: list[JunctionMark]) -> None:
    """The map panel: hillshade of ``elevation`` (m; blank on NaN), lakes coloured by depth (m)
    with their colour bar, each cross-section coloured by its chainage (``_section_colours``), the
    trunk in red and the tributary junctions (filled and labelled with their step when hanging);
    axes in km (``_to_km``)."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import LightSource, ListedColormap

    ny, nx = elevation.shape
    valid = np.isfinite(elevation)
    extent = (0.0, nx * dx / 1000.0, 0.0, ny * dy / 1000.0)
    filled = np.where(valid, elevation, np.nanmin(elevation))
    shade = LightSource(azdeg=315, altdeg=45).hillshade(filled, dx=dx, dy=dy)
    ax.imshow(np.where(valid, shade, np.nan), cmap="gray", extent=extent)
    water = np.where(np.nan_to_num(lake_depth) > 0.0, lake_depth, np.nan)
    if np.isfinite(water).any():
        blues = ListedColormap(plt.get_cmap("Blues")(np.linspace(0.45, 1.0, 256)))  # shallow lakes show
        image = ax.imshow(water, cmap=blues, extent=extent, interpolation="nearest",
                          vmin=0.0, vmax=float(np.nanmax(water)))
        ax.figure.colorbar(image, ax=ax, shrink=0.7).set_label("lake depth (m)")
    for section, colour in zip(sections, _section_colours(sections), strict=True):
        x, y = _to_km(section.rows, section.cols, (ny, nx), dx, dy)
        ax.plot(x, y, color=colour, lw=1.0)
    x, y = _to_km(trunk_rows, trunk_cols, (ny, nx), dx, dy)
    ax.plot(x, y, color="red", lw=1.5, label="trunk")
    for mark in junctions:
        jx, jy = _to_km(np.array([mark.row]), np.array([mark.col]), (ny, nx), dx, dy)
        ax.plot(jx, jy, "o", ms=5, mfc="magenta" if mark.hanging else "none", mec="magenta")
        if mark.hanging:
            ax.annotate(f"{mark.step_m:.0f} m", (jx[0], jy[0]), fontsize=7, color="magenta",
                        xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("x (km)")
    ax.set_ylabel("y (km)")
    ax.set_title("trunk, cross-sections, tributaries (filled: hanging) and lakes", fontsize=9)


def _draw_sections(ax, sections: list[SectionCurve]) -> None:
    """The cross-sections panel: each section's elevation (solid) and fit (dashed), in m above
    its fitted floor, against the distance from the trunk (m)."""
    for section, colour in zip(sections, _section_colours(sections), strict=True):
        distance = section.distance_m
        ax.plot(distance, section.elevation_m - section.floor_m, color=colour, lw=1.0)
        ax.plot(distance, section.fitted_m - section.floor_m, color=colour, lw=0.8, ls="--")
    ax.set_xlabel("distance from the trunk (m)")
    ax.set_ylabel("height above the fitted floor (m)")
    ax.set_title("cross-sections (solid) and fits z0 + a|x − x0|^b (dashed), "
                 "colour: chainage", fontsize=9)
    ax.grid(alpha=0.3)


def _draw_hypsometry(ax, hypsometry_curves: list[tuple[str, np.ndarray, np.ndarray]]) -> None:
    """The hypsometry panel: elevation (m) against the share of the area (%) of each DEM."""
    for label, centres, fraction in hypsometry_curves:
        ax.plot(fraction * 100.0, centres, lw=1.6, label=label)
    ax.set_xlabel("share of the area (%)")
    ax.set_ylabel("elevation (m)")
    ax.set_xlim(left=0.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("hypsometry", fontsize=9)


def _draw_along_trunk(ax, sections: list[SectionCurve], junctions: list[JunctionMark]) -> None:
    """The along-trunk panel: the shape exponent b of each cross-section against its chainage
    (m; the U band 1.5–2.5 shaded) and, on a second axis, the tributary steps (m)."""
    ax.axhspan(1.5, 2.5, color="tab:blue", alpha=0.08)
    ax.plot([s.chainage_m for s in sections], [s.b for s in sections], "o-", color="tab:blue", ms=4)
    ax.set_xlabel("chainage along the trunk from its mouth (m)")
    ax.set_ylabel("shape exponent b (≈1 V, ≈2 U)", color="tab:blue")
    ax.grid(alpha=0.3)
    steps = ax.twinx()
    if junctions:
        where = [j.chainage_m for j in junctions]
        heights = [j.step_m for j in junctions]
        steps.vlines(where, 0.0, heights, color="magenta")
        steps.plot(where, heights, "v", color="magenta", ms=4)
    steps.set_ylabel("tributary step (m)", color="magenta")
    ax.set_title("U-shape exponent and tributary steps along the trunk", fontsize=9)


def save_landforms_plot(
    path: Path,
    elevation: np.ndarray,
    dx: float,
    dy: float,
    lake_depth: np.ndarray,
    trunk_rows: np.ndarray,
    trunk_cols: np.ndarray,
    sections: list[SectionCurve],
    junctions: list[JunctionMark],
    hypsometry_curves: list[tuple[str, np.ndarray, np.ndarray]],
    title: str = "",
) -> None:
    """Write the four-panel PNG (``_draw_map``, ``_draw_sections``, ``_draw_hypsometry``,
    ``_draw_along_trunk``).

    Args:
        path: the PNG to write.
        elevation: float64[ny, nx] DEM (m, NaN on nodata); ``dx``, ``dy`` cell sizes (m).
        lake_depth: float64[ny, nx] depth of the lakes to show (m; 0 or NaN elsewhere).
        trunk_rows, trunk_cols: cell coordinates of the trunk, mouth first.
        sections: the fitted cross-sections.
        junctions: the tributary junctions.
        hypsometry_curves: (label, bin centres in m, share of the area per bin) per DEM.
        title: the figure's title.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 10))
    ax_map, ax_sections, ax_hyps, ax_along = axes.ravel()
    _draw_map(ax_map, elevation, dx, dy, lake_depth, trunk_rows, trunk_cols, sections, junctions)
    _draw_sections(ax_sections, sections)
    _draw_hypsometry(ax_hyps, hypsometry_curves)
    _draw_along_trunk(ax_along, sections, junctions)
    if title:
        fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=100, format="png")
    plt.close(fig)
