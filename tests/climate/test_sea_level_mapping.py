"""Sea level from a table or from δ18O (000 §5.1–5.2, DESIGN §7): the LGM (~20 ka) lowstand of
−120 ± 20 m (a value no one here wrote: about −120 to −130 m in coral and model records)
comes out of the sea-level tables and out of LR04 δ18O through the fitted linear mapping."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.climate.chronology import Series
from unerode_cli.climate.sealevel import DEFAULT_MAPPING, SeaLevelMapping, fit_mapping, sea_level


def test_default_mapping_is_the_fit_of_lr04_to_spratt(lr04, spratt, bintanja):
    fitted = fit_mapping(lr04, spratt)
    rms = float(np.sqrt(np.mean((fitted(lr04.at(spratt.age_ka)) - spratt.value) ** 2)))
    other = fit_mapping(lr04, bintanja)
    ages = bintanja.age_ka
    rms_other = float(np.sqrt(np.mean((other(lr04.at(ages)) - bintanja.value) ** 2)))
    print(f"LR04 → Spratt 2016: sea = {fitted.intercept:.4f} m + {fitted.slope:.4f} m/‰ · δ18O, "
          f"RMS {rms:.2f} m; LR04 → Bintanja 2008: {other.intercept:.4f} m + {other.slope:.4f} m/‰, "
          f"RMS {rms_other:.2f} m")
    assert fitted.slope == pytest.approx(DEFAULT_MAPPING.slope, abs=1e-3)
    assert fitted.intercept == pytest.approx(DEFAULT_MAPPING.intercept, abs=1e-3)
    assert rms == pytest.approx(14.7, abs=0.1)
    # two independent reconstructions give close slopes (m of sea level per ‰ of δ18O)
    assert other.slope == pytest.approx(-70.0, abs=0.1)
    assert rms_other == pytest.approx(7.7, abs=0.1)
    assert abs(other.slope - fitted.slope) / abs(fitted.slope) < 0.1


def test_lgm_sea_level_from_tables_and_from_d18o(lr04, spratt, bintanja):
    from_spratt = sea_level(20.0, sea=spratt)
    from_bintanja = sea_level(20.0, sea=bintanja)
    from_d18o = sea_level(20.0, d18o=lr04)  # default mapping
    print(f"sea level at 20 ka: Spratt {from_spratt:.1f} m, Bintanja {from_bintanja:.1f} m, "
          f"LR04 mapped {from_d18o:.1f} m")
    for value in (from_spratt, from_bintanja, from_d18o):
        assert value == pytest.approx(-120.0, abs=20.0)
    # and present ≈ 0, MIS 5e (~125 ka) near or above −20 m
    assert sea_level(0.0, sea=spratt) == 0.0
    assert abs(sea_level(0.0, d18o=lr04)) < 5.0
    assert sea_level(125.0, d18o=lr04) > -20.0 and sea_level(125.0, sea=bintanja) > -20.0


def test_sea_level_prefers_the_table_and_takes_arrays(lr04, spratt):
    ages = np.array([0.0, 20.0, 125.0])
    np.testing.assert_array_equal(sea_level(ages, spratt, lr04), spratt.at(ages))
    mapping = SeaLevelMapping(slope=-50.0, intercept=150.0)
    np.testing.assert_allclose(sea_level(ages, None, lr04, mapping), 150.0 - 50.0 * lr04.at(ages))
    with pytest.raises(ValueError, match="neither was given"):
        sea_level(10.0)
    with pytest.raises(ValueError, match="outside the chronology"):
        sea_level(900.0, sea=spratt)


def test_mapping_inverse_and_fit_on_an_exact_line():
    d18o = Series(np.arange(0.0, 50.0), 3.0 + 0.04 * np.arange(50.0), "d18o", "‰")
    ages = np.arange(0.5, 40.0, 2.0)  # sea ages inside the δ18O range
    sea = Series(ages, 200.0 - 60.0 * d18o.at(ages), "sea", "m")
    fitted = fit_mapping(d18o, sea)
    assert fitted.slope == pytest.approx(-60.0, abs=1e-9)
    assert fitted.intercept == pytest.approx(200.0, abs=1e-9)
    assert fitted.d18o_for(fitted(4.2)) == pytest.approx(4.2)


def test_fit_refuses_disjoint_or_flat_series():
    d18o = Series(np.array([0.0, 1.0]), np.array([3.0, 3.0]))
    with pytest.raises(ValueError, match="share fewer than two"):
        fit_mapping(d18o, Series(np.array([5.0, 6.0]), np.array([0.0, -1.0])))
    with pytest.raises(ValueError, match="constant"):
        fit_mapping(d18o, Series(np.array([0.0, 1.0]), np.array([0.0, -1.0])))
    with pytest.raises(ValueError, match="finite slope"):
        SeaLevelMapping(float("nan"), 0.0)
