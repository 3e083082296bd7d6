"""Mass balance M = min(p_max, β(s − E)) (001 Eq. 2)."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.glacier.massbalance import mass_balance


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
