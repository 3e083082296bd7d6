"""Glacial abrasion and quarrying (001 §6.1) on analytic cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from unerode_cli.glacier import erosion
from unerode_cli.grid import Grid


def test_uniform_sliding_on_a_flat_bed():
    grid = Grid.full((6, 7), 50.0)
    ub, vb = np.full((6, 7), 30.0), np.full((6, 7), 40.0)  # |u| = 50 m/y
    abrasion, quarrying = erosion.erosion_rates(np.zeros((6, 7)), ub, vb, grid, k_e=1e-6,
                                                abrasion_exponent=2.02, k_q=1e-4)
    np.testing.assert_allclose(abrasion, -1e-6 * 50.0**2.02, rtol=1e-12)
    np.testing.assert_allclose(quarrying, -1e-4 * 50.0 * 0.5, rtol=1e-12)  # Q = ½ on a flat bed


@pytest.mark.parametrize(("bed_slope", "expected_q"), [(-0.4, 0.5 * (math.erf(1.0) + 1.0)),
                                                        (0.4, 0.5 * (math.erf(-1.0) + 1.0))])
def test_quarrying_focus_on_lee_and_stoss_slopes(bed_slope, expected_q):
    """Ice sliding along +x down (lee) or up (stoss) a plane of slope ∓0.4: Q = ½(erf(±1) + 1)."""
    grid = Grid.full((5, 9), 20.0)
    x = np.arange(9) * 20.0
    bed = np.broadcast_to(bed_slope * x, (5, 9))
    ub, vb = np.full((5, 9), 25.0), np.zeros((5, 9))
    _, quarrying = erosion.erosion_rates(bed, ub, vb, grid, k_q=2e-4, boundary="open")
    np.testing.assert_allclose(quarrying[:, 1:-1], -2e-4 * 25.0 * expected_q, rtol=1e-12)
    edge = quarrying[:, -1] if bed_slope < 0 else quarrying[:, 0]  # no lower neighbour: flat
    np.testing.assert_allclose(edge, -2e-4 * 25.0 * 0.5, rtol=1e-12)
    assert expected_q == pytest.approx(0.9214 if bed_slope < 0 else 0.0786, abs=1e-4)


def test_downward_gradient_picks_the_lower_neighbour():
    grid = Grid.full((1, 5), 10.0)
    z = np.array([[5.0, 3.0, 4.0, 0.0, 2.0]])
    gx, gy = erosion.downward_gradient(z, grid, "open")
    # col 0: only neighbour 3 is lower → (3−5)/10; col 1: local minimum → 0;
    # col 2: drops 1 to the west and 4 to the east → east; col 3: minimum; col 4: west neighbour lower
    np.testing.assert_allclose(gx, [[-0.2, 0.0, -0.4, 0.0, 0.2]])
    assert not gy.any()


def test_no_sliding_no_erosion():
    grid = Grid.full((3, 3), 10.0)
    zero = np.zeros((3, 3))
    abrasion, quarrying = erosion.erosion_rates(np.eye(3), zero, zero, grid)
    assert not abrasion.any() and not quarrying.any()


def test_slope_along_the_flow_is_the_downstream_difference():
    """dz/ds along (u, v) from the downstream neighbour of each axis: a plane rising 0.03 along x
    and 0.04 along y gives (0.03·u + 0.04·v)/|u| whichever the signs, and 0 on an open edge's
    downstream side."""
    grid = Grid.full((5, 6), 10.0)
    yy, xx = np.mgrid[0:5, 0:6] * 10.0
    plane = 0.03 * xx + 0.04 * yy
    for u, v in ((3.0, 4.0), (-3.0, 4.0), (3.0, -4.0), (-6.0, 0.0)):
        ub, vb = np.full((5, 6), u), np.full((5, 6), v)
        along = erosion.slope_along(plane, ub, vb, grid)
        expected = (0.03 * u + 0.04 * v) / np.hypot(u, v)
        np.testing.assert_allclose(along[1:-1, 1:-1], expected, rtol=1e-12)
    edge = erosion.slope_along(plane, np.full((5, 6), 2.0), np.zeros((5, 6)), grid)
    np.testing.assert_allclose(edge[:, -1], 0.0)
    np.testing.assert_allclose(erosion.slope_along(plane, np.zeros((5, 6)), np.zeros((5, 6)), grid), 0.0)


def test_no_erosion_on_adverse_bed_slopes_steeper_than_zeta_times_the_surface_fall():
    """Ice sliding along +x at 100 m/y under a surface falling 0.02: the bed rising 0.025
    (1.25 × the surface's fall) is still cut at ζ = 1.5, a rise of 0.035 (1.75 ×) is not, nor
    is the bottom of a one-cell pit; a falling bed is cut as 001 says."""
    grid = Grid.full((3, 12), 50.0)
    x = np.arange(12) * 50.0
    surface = np.tile(3000.0 - 0.02 * x, (3, 1))
    ub, vb = np.full((3, 12), 100.0), np.zeros((3, 12))
    plain = erosion.erosion_rates(np.tile(2000.0 - 0.05 * x, (3, 1)), ub, vb, grid)
    for rise, cut in ((0.025, True), (0.035, False)):
        bed = np.tile(2000.0 + rise * x, (3, 1))
        abrasion, quarrying = erosion.erosion_rates(bed, ub, vb, grid, surface=surface,
                                                    adverse_slope_ratio=1.5)
        expected = -1.3e-7 * 100.0**2.02 if cut else 0.0
        np.testing.assert_allclose(abrasion[:, :-1], expected, rtol=1e-12)
        assert (quarrying[:, :-1] < 0).all() == cut and (quarrying[:, :-1] == 0).all() != cut
    falling = np.tile(2000.0 - 0.05 * x, (3, 1))
    kept = erosion.erosion_rates(falling, ub, vb, grid, surface=surface)
    np.testing.assert_allclose(kept[0], plain[0], rtol=0, atol=0)
    np.testing.assert_allclose(kept[1], plain[1], rtol=0, atol=0)
    pit = falling.copy()
    pit[:, 5] -= 300.0
    abrasion, _ = erosion.erosion_rates(pit, ub, vb, grid, surface=surface)
    assert (abrasion[:, 5] == 0.0).all() and (abrasion[:, 4] < 0.0).all() and (abrasion[:, 6] < 0.0).all()
