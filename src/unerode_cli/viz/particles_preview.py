"""A rendered view of a particle rock (sandstone): an orthographic view from the south-south-west
and above, each particle a small disc shaded by its normal and coloured by a property."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import BoundaryNorm, ListedColormap, Normalize  # noqa: E402

#: Where the camera looks from: azimuth (degrees clockwise from north) and elevation (degrees).
VIEW_AZIMUTH = 200.0
VIEW_ELEVATION = 25.0
#: Light from the north-west and above (a unit vector towards the light, x east, y north, z up).
LIGHT = np.array([-0.5, 0.5, 0.7]) / math.sqrt(0.99)


def save_particles_preview(positions: np.ndarray, normals: np.ndarray, values: np.ndarray, path: Path,
                           label: str, spacing: float, title: str = "", categorical: bool = False,
                           width: int = 900) -> None:
    """Save a PNG of the particles ``(N, 3)`` (m) coloured by ``values`` (N,) with a colour bar
    named ``label``; ``categorical`` values (layer indices) get one colour each. ``spacing`` (m)
    sizes the discs. Unit ``normals`` shade the surface (zero normals: unshaded)."""
    a, e = math.radians(VIEW_AZIMUTH), math.radians(VIEW_ELEVATION)
    toward = -np.array([math.sin(a) * math.cos(e), math.cos(a) * math.cos(e), math.sin(e)])
    right = np.cross(toward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, toward)
    u, v, depth = positions @ right, positions @ up, positions @ toward
    if len(positions) == 0:
        u = v = depth = np.zeros(1)
    span = max(float(np.ptp(u)), float(np.ptp(v)), spacing)
    pixel = span / width
    nx = int(np.ptp(u) / pixel) + 8
    ny = int(np.ptp(v) / pixel) + 8
    col = ((u - u.min()) / pixel).astype(np.int64) + 4
    row = ny - 1 - (((v - v.min()) / pixel).astype(np.int64) + 4)
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
    image = np.ones((ny, nx, 3))
    order = np.argsort(-depth, kind="stable")  # far first: nearer particles are drawn over them
    radius = max(1, int(round(0.6 * spacing / pixel)))
    for di in range(-radius, radius + 1):
        for dj in range(-radius, radius + 1):
            if di * di + dj * dj <= radius * radius:
                r = np.clip(row[order] + di, 0, ny - 1)
                c = np.clip(col[order] + dj, 0, nx - 1)
                image[r, c] = colour[order]
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
