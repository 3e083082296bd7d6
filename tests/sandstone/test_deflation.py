"""Wind deflation (002 Eq. 9–12): the closed form against its definition, a Rayleigh average."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from unerode_cli.sandstone.deflation import DeflationParams, deflation_rate, detachment_probability

PARAMS = DeflationParams(alpha=1.5e6, cohesion=1.0e6, friction=0.75)


def test_eq_12_gives_k_d_over_e_where_the_threshold_is_alpha_root_2():
    # μ_c + μ_f p = α√2  ⇒  W_d = k_d·exp(−1)
    p = (PARAMS.alpha * math.sqrt(2.0) - PARAMS.cohesion) / PARAMS.friction
    rate = deflation_rate(np.array([True]), np.array([3e-7]), np.array([p]), PARAMS)
    assert rate[0] == pytest.approx(3e-7 / math.e, rel=1e-12)


@pytest.mark.parametrize("threshold", [-2.0e6, 0.0, 0.4e6, 1.5e6, 3.0e6, 6.0e6])
def test_the_closed_form_is_the_rayleigh_average_of_detachment(threshold):
    alpha = PARAMS.alpha

    def rayleigh(f: float) -> float:  # 002 Eq. 11, on F ≥ 0
        return f / alpha**2 * math.exp(-f * f / (2.0 * alpha**2))

    # the density is negligible (e^-450) beyond 30 α
    numeric, _ = quad(rayleigh, max(threshold, 0.0), 30.0 * alpha, epsabs=1e-14, epsrel=1e-12, limit=200)
    assert detachment_probability(np.array(threshold), alpha) == pytest.approx(numeric, rel=1e-9, abs=1e-15)


def test_load_protects_tension_exposes_and_only_the_surface_deflates():
    compression = np.array([-4.0e6, 0.0, 1.0e6, 4.0e6, 4.0e6])
    on_surface = np.array([True, True, True, True, False])
    rate = deflation_rate(on_surface, np.full(5, 2e-7), compression, PARAMS)
    assert rate[0] == pytest.approx(2e-7, rel=1e-12)  # tension: every gust detaches
    assert rate[1] == pytest.approx(2e-7 * math.exp(-((1.0e6 / PARAMS.alpha) ** 2) / 2.0), rel=1e-12)
    assert rate[1] > rate[2] > rate[3] > 0.0
    assert rate[4] == 0.0


@pytest.mark.parametrize("field, value, named", [("alpha", 0.0, "alpha"), ("cohesion", -1.0, "mu_c"),
                                                 ("friction", math.nan, "mu_f")])
def test_bad_parameters_are_refused_in_one_sentence(field, value, named):
    with pytest.raises(ValueError, match=named):
        DeflationParams(**{field: value})
