"""The Halfar dome (Halfar 1981; Bueler et al. 2005, J. Glaciol. 51(173), Eq. 9–10): the
similarity solution of the shallow-ice equation for n = 3 on a flat bed without mass balance,

    H(t, r) = H₀ (t₀/t)^(1/9) · [1 − ((t₀/t)^(1/18) · r/R₀)^(4/3)]^(3/7),
    t₀ = (7/4)³ · R₀⁴ / (18 Γ H₀⁷),   Γ = 2A(ρg)³/5,

at mountain scale (H₀ = 300 m, R₀ = 5 km), run through the coupled stepper with SIA velocities,
a frozen bed and explicit transport (sub-stepped at the diffusion limit)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from unerode_cli.glacier import blatter, coupled
from unerode_cli.grid import Grid

A, RHO, G = 1e-16, 910.0, 9.81
H0, R0 = 300.0, 5000.0
GAMMA = 2.0 * A * (RHO * G) ** 3 / 5.0
T0 = (7.0 / 4.0) ** 3 * R0**4 / (18.0 * GAMMA * H0**7)  # ≈ 30 y


def halfar(t: float, r: np.ndarray) -> np.ndarray:
    """Halfar thickness (m) at time t (y, the dome being (H₀, R₀) at t₀) and radius r (m)."""
    ratio = T0 / t
    inside = np.clip(1.0 - (ratio ** (1.0 / 18.0) * r / R0) ** (4.0 / 3.0), 0.0, None)
    return H0 * ratio ** (1.0 / 9.0) * inside ** (3.0 / 7.0)


def test_central_thickness_after_five_t0():
    """From the dome at t₀ to t₀ + 5t₀: the centre thins from 300 m to 300·6^(−1/9) = 245.84 m.
    Measured: 0.1 % from the formula, the profile within 3.7 m of it, the volume to rounding."""
    n, dx = 81, 200.0
    y, x = (np.mgrid[0:n, 0:n] - (n - 1) / 2) * dx
    r = np.hypot(x, y)
    grid = Grid.full((n, n), dx)
    params = coupled.CoupledParams(flow=blatter.FlowParams(glen_a=A, rho=RHO, gravity=G, sliding_c=math.inf),
                                   iceflow="sia", transport="explicit", beta=0.0, erosion=False)
    state = coupled.GlacierState(np.zeros((n, n)), halfar(T0, r), T0)
    end = 6.0 * T0
    result = coupled.run(state, grid, params, 0.0, [end])
    centre = result.state.thickness[n // 2, n // 2]
    assert halfar(end, np.zeros(1))[0] == pytest.approx(245.84, abs=0.01)
    assert centre == pytest.approx(halfar(end, np.zeros(1))[0], rel=0.03)
    # volume is conserved by the closed dome (it stays far from the edges), and so is its shape
    assert result.volumes[-1] == pytest.approx(result.volumes[0], rel=1e-9)
    profile = result.state.thickness[n // 2, n // 2:]
    expected = halfar(end, r[n // 2, n // 2:])
    assert np.abs(profile - expected)[expected > 50].max() < 0.05 * H0
