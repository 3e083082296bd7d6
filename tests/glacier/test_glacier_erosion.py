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
