"""Mass balance M = min(p_max, β(s − E)) (001 Eq. 2)."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.glacier.massbalance import mass_balance, surface_slope


def test_linear_below_the_cap_and_capped_above():
    s = np.array([[1000.0, 1500.0, 1600.0, 2000.0, 3000.0]])
    m = mass_balance(s, ela=1500.0, beta=0.01, p_max=2.0)
    np.testing.assert_allclose(m, [[-5.0, 0.0, 1.0, 2.0, 2.0]], rtol=0, atol=1e-12)


def test_raster_equilibrium_line():
    s = np.full((2, 2), 1800.0)
    ela = np.array([[1500.0, 1700.0], [1800.0, 2100.0]])
    np.testing.assert_allclose(mass_balance(s, ela, beta=0.005, p_max=1.0), [[1.0, 0.5], [0.0, -1.5]])


def test_rejects_bad_input():
    with pytest.raises(ValueError, match="shape"):
        mass_balance(np.zeros((2, 2)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="≥ 0"):
        mass_balance(np.zeros((2, 2)), 0.0, beta=-1.0)


def test_snow_slides_off_steep_faces():
    """Accumulation times the share of snow that stays: all up to 30°, half at 40°, none from
    50° on; ablation is not touched."""
    surface = np.array([[3000.0, 3000.0, 3000.0, 3000.0, 1000.0]])
    slope = np.array([[20.0, 30.0, 40.0, 60.0, 60.0]])
    m = mass_balance(surface, 1500.0, 0.01, 2.0, slope, (30.0, 50.0))
    np.testing.assert_allclose(m, [[2.0, 2.0, 1.0, 0.0, -5.0]], rtol=1e-12)
    # 90° and 90°: 001 Eq. 2 as printed
    np.testing.assert_allclose(mass_balance(surface, 1500.0, 0.01, 2.0, slope, (90.0, 90.0)),
                               mass_balance(surface, 1500.0, 0.01, 2.0), rtol=0)


def test_surface_slope_of_a_plane():
    rows, cols = np.mgrid[0:8, 0:9].astype(float)
    plane = 50.0 * cols * np.tan(np.radians(35.0))   # 50 m cells, 35° towards the east
    np.testing.assert_allclose(surface_slope(plane, 50.0, 40.0), 35.0, rtol=1e-12)
