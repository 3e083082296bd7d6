"""The particle preview's depth buffer: an upper surface hides what lies below it, and a near
particle wins over a far one at a pixel, whatever the order of the particles."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.path import Path as Polygon

from unerode_cli.viz.particles_preview import (
    VIEW_ELEVATION,
    render_particles,
    save_particles_preview,
    view_of,
)

LOWER, UPPER, NEAR, FAR = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 1.0)
FRAME = (0.5, 0.5, 0.5)


def _layer(z: float, n: int = 24) -> np.ndarray:
    i, j = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    return np.column_stack([i.ravel(), j.ravel(), np.full(n * n, z)])


def _colour_share(image: np.ndarray, inside: np.ndarray, colour: tuple[float, float, float]) -> float:
    return float(np.all(np.isclose(image[inside], colour), axis=1).mean())


@pytest.mark.parametrize("upper_first", [False, True])
def test_an_upper_layer_hides_the_layer_below_it(upper_first: bool) -> None:
    """Two horizontal layers of particles one spacing apart horizontally and three apart
    vertically, seen from 25° above: inside the upper layer's projected footprint (one spacing
    in from its edges) every pixel shows the upper layer."""
    assert VIEW_ELEVATION == 25.0
    lower, upper = _layer(0.0), _layer(3.0)
    positions = np.vstack([upper, lower] if upper_first else [lower, upper])
    colours = np.array([UPPER] * len(upper) + [LOWER] * len(lower) if upper_first
                       else [LOWER] * len(lower) + [UPPER] * len(upper))
    image, view = render_particles(positions, colours, spacing=1.0, width=300)
    corners = np.array([[1.0, 1.0, 3.0], [22.0, 1.0, 3.0], [22.0, 22.0, 3.0], [1.0, 22.0, 3.0]])
    row, col, _ = view.pixels(corners)
    rows, cols = np.mgrid[0:view.shape[0], 0:view.shape[1]]
    inside = Polygon(np.column_stack([col, row])).contains_points(
        np.column_stack([cols.ravel(), rows.ravel()])).reshape(view.shape)
    assert inside.sum() > 5000                      # the footprint covers a good part of the image
    assert _colour_share(image, inside, LOWER) < 0.01
    assert _colour_share(image, inside, UPPER) > 0.99
    assert _colour_share(image, ~inside, LOWER) > 0.05  # the lower layer shows beyond the upper one


@pytest.mark.parametrize("shift", [0.0, 0.25, -0.25, 0.5, -0.5])
@pytest.mark.parametrize("near_first", [False, True])
def test_a_near_particle_wins_over_a_far_one(shift: float, near_first: bool) -> None:
    """A far particle behind a near one (along the view, moved sideways by ``shift`` spacings, so
    that its disc overlaps the near one's) never shows where the near particle's disc is."""
    axes = view_of(np.zeros((1, 3)), 1.0)
    near = np.array([0.37, 0.21, 0.13])
    far = near + 5.0 * axes.toward + shift * axes.right
    frame = [near + 6.0 * (axes.right + axes.up), near - 6.0 * (axes.right + axes.up)]  # the image's extent
    positions = np.array([near, far, *frame] if near_first else [far, near, *frame])
    colours = np.array([NEAR, FAR, FRAME, FRAME] if near_first else [FAR, NEAR, FRAME, FRAME])
    image, view = render_particles(positions, colours, 1.0, width=60)
    alone, _ = render_particles(np.array([near, *frame]), np.array([NEAR, FRAME, FRAME]), 1.0, width=60)
    near_disc = np.isclose(alone, NEAR).all(axis=2)
    assert alone.shape == image.shape and near_disc.sum() > 20
    row, col, depth = view.pixels(np.array([near, far]))
    assert depth[1] == pytest.approx(depth[0] + 5.0)
    assert np.isclose(image[near_disc], NEAR).all()     # the near disc is whole
    assert np.allclose(image[row[1], col[1]], NEAR)
    shows_far = np.isclose(image, FAR).all(axis=2).sum()
    assert (shows_far > 0) == (shift != 0.0)


def test_the_preview_is_a_png(tmp_path) -> None:
    positions = np.vstack([_layer(0.0, 8), _layer(2.0, 8)])
    normals = np.tile([0.0, 0.0, 1.0], (len(positions), 1))
    layer = np.repeat([0, 1], 64)
    save_particles_preview(positions, normals, layer, tmp_path / "p.png", "layer", 1.0, categorical=True)
    assert (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
