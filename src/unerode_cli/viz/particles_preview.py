"""A rendered view of a particle rock (sandstone): an orthographic view from the south-south-west
and above, each particle a small disc shaded by its normal and coloured by a property.

The discs are drawn with a depth buffer: each pixel shows the nearest particle whose disc
covers it, so a surface hides what lies behind it whatever the order of the particles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import BoundaryNorm, ListedColormap, Normalize  # noqa: E402

#: Where the camera looks from: azimuth (degrees clockwise from north) and elevation (degrees).
VIEW_AZIMUTH = 200.0
VIEW_ELEVATION = 25.0
#: Light from azimuth 240° (west-south-west, on the camera's side) and 45° above the horizon, so
#: the faces the camera sees are lit unequally (a unit vector towards the light, x east, y north,
#: z up).
LIGHT = np.array([math.sin(math.radians(240.0)), math.cos(math.radians(240.0)), 1.0]) * math.sqrt(0.5)
#: Radius of a particle's disc, in particle spacings.
DISC_RADIUS = 0.75


@dataclass(frozen=True)
class View:
    """The orthographic view of a preview: unit screen axes ``right`` and ``up`` and the
    viewing direction ``toward`` (x east, y north, z up), the screen coordinates (m) of pixel
    column 0 and of the bottom row (``u0``, ``v0``), the pixel size (m) and the image's
    ``shape`` (rows, columns)."""

    right: np.ndarray
    up: np.ndarray
    toward: np.ndarray
    u0: float
    v0: float
    pixel: float
    shape: tuple[int, int]

    def pixels(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Row, column (int64, pixel whose square holds the point) and depth (m along
        ``toward``: larger is farther) of ``points`` ``(N, 3)`` (m)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        col = np.floor((points @ self.right - self.u0) / self.pixel).astype(np.int64)
        row = self.shape[0] - 1 - np.floor((points @ self.up - self.v0) / self.pixel).astype(np.int64)
        return row, col, points @ self.toward


def view_of(positions: np.ndarray, spacing: float, width: int = 900) -> View:
    """The view that fits ``positions`` ``(N, 3)`` (m) in about ``width`` pixels across their
    larger screen extent (at least one ``spacing``, m), with a margin of a disc's radius."""
    a, e = math.radians(VIEW_AZIMUTH), math.radians(VIEW_ELEVATION)
    toward = -np.array([math.sin(a) * math.cos(e), math.cos(a) * math.cos(e), math.sin(e)])
    right = np.cross(toward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, toward)
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    u, v = positions @ right, positions @ up
    if len(positions) == 0:
        u = v = np.zeros(1)
    span = max(float(np.ptp(u)), float(np.ptp(v)), spacing)
    pixel = span / width
    margin = _radius(spacing, pixel) + 3
    shape = (int(np.ptp(v) / pixel) + 2 * margin, int(np.ptp(u) / pixel) + 2 * margin)
    return View(right, up, toward, float(u.min()) - margin * pixel, float(v.min()) - margin * pixel, pixel,
                shape)


def render_particles(positions: np.ndarray, colours: np.ndarray, spacing: float,
                     width: int = 900) -> tuple[np.ndarray, View]:
    """The image ``(rows, columns, 3)`` (RGB in [0, 1], white where no particle is) of the
    particles ``(N, 3)`` (m), each a disc of :data:`DISC_RADIUS` ``spacing`` (m) in its
    ``colours`` ``(N, 3)`` (RGB in [0, 1]), and the view it was drawn in.

    Depth buffer: the particles are ranked from the nearest (ties: by index) and every pixel
    takes the colour of the lowest-ranked particle whose disc covers it."""
    view = view_of(positions, spacing, width)
    ny, nx = view.shape
    image = np.ones((ny * nx, 3))
    if len(positions) == 0:
        return image.reshape(ny, nx, 3), view
    row, col, depth = view.pixels(positions)
    order = np.argsort(depth, kind="stable")              # nearest first
    row, col = row[order], col[order]
    rank = np.arange(len(order))
    nearest = np.full(ny * nx, len(order))
    radius = _radius(spacing, view.pixel)
    for di in range(-radius, radius + 1):
        for dj in range(-radius, radius + 1):
            if di * di + dj * dj <= radius * radius:
                r, c = row + di, col + dj
                inside = (r >= 0) & (r < ny) & (c >= 0) & (c < nx)
                np.minimum.at(nearest, r[inside] * nx + c[inside], rank[inside])
    drawn = nearest < len(order)
    image[drawn] = np.asarray(colours, dtype=np.float64)[order[nearest[drawn]]]
    return image.reshape(ny, nx, 3), view


def _radius(spacing: float, pixel: float) -> int:
    """A disc's radius in pixels (at least 1)."""
    return max(1, int(round(DISC_RADIUS * spacing / pixel)))


def save_particles_preview(positions: np.ndarray, normals: np.ndarray, values: np.ndarray, path: Path,
                           label: str, spacing: float, title: str = "", categorical: bool = False,
                           width: int = 900) -> None:
    """Save a PNG of the particles ``(N, 3)`` (m) coloured by ``values`` (N,) with a colour bar
    named ``label``; ``categorical`` values (layer indices) get one colour each. ``spacing`` (m)
    sizes the discs. Unit ``normals`` shade the surface (zero normals: unshaded)."""
    if categorical:
        levels = np.arange(int(values.max(initial=0)) + 2) - 0.5
        cmap = ListedColormap(plt.get_cmap("tab10")(np.arange(len(levels) - 1) % 10))
        norm: Normalize = BoundaryNorm(levels, cmap.N)
    else:
        cmap = plt.get_cmap("viridis")
        lo, hi = float(values.min(initial=0.0)), float(values.max(initial=1.0))
        norm = Normalize(lo, hi if hi > lo else lo + 1.0)
    shade = np.where(np.any(normals != 0.0, axis=1), 0.35 + 0.65 * np.clip(normals @ LIGHT, 0.0, 1.0), 0.8)
    colour = cmap(norm(values))[:, :3] * shade[:, None]
    image, view = render_particles(positions, colour, spacing, width)
    ny, nx = view.shape
    fig, ax = plt.subplots(figsize=(8.0, max(3.0, 8.0 * ny / nx)))
    ax.imshow(image, interpolation="nearest")
    ax.set_axis_off()
    if title:
        ax.set_title(title, fontsize=10)
    bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.8)
    bar.set_label(label)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
