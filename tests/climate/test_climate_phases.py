"""Climate phases (000 §5.1, Table 1) on the real chronologies: the Holocene is interglacial, the
LGM glacial, MIS 5e interglacial, the last deglaciation (Termination I) the end of a glacial —
from the Spratt 2016 and Bintanja 2008 sea-level curves and from LR04 δ18O mapped to sea level;
and the phases agree with the LR04 marine-isotope-stage boundaries (Lisiecki & Raymo 2005)."""

from __future__ import annotations

import numpy as np
import pytest
from tests.climate.conftest import MIS_BOUNDARIES

from unerode_cli.climate.phases import (
    END_OF_GLACIAL,
    GLACIAL,
    INTERGLACIAL,
    PhaseThresholds,
    classify,
    classify_d18o,
)
from unerode_cli.climate.sealevel import DEFAULT_MAPPING

AGES = np.arange(0.0, 799.0)  # 1 kyr steps (ka)


def mis_boundaries() -> dict[str, float]:
    """LR04 ages (ka) of the MIS boundaries, e.g. {"1/2": 14.0, "5/6": 130.0}."""
    out = {}
    for line in MIS_BOUNDARIES.read_text(encoding="latin-1").splitlines()[2:]:
        fields = line.split()
        if len(fields) == 2:
            out[fields[0]] = float(fields[1])
    return out


@pytest.fixture(scope="module", params=["spratt", "bintanja", "lr04"])
def phases(request) -> np.ndarray:
    """Phases every 1 kyr over 0–798 ka from each chronology (δ18O through the mapping)."""
    series = request.getfixturevalue(request.param)
    if request.param == "lr04":
        return classify_d18o(AGES, series.at(AGES))
    return classify(AGES, series.at(AGES))


def phase(phases: np.ndarray, age: float) -> str:
    return str(phases[int(np.flatnonzero(AGES == age)[0])])


def test_holocene_interglacial(phases):
    assert all(phase(phases, a) == INTERGLACIAL for a in range(0, 11))


def test_lgm_glacial(phases):
    assert all(phase(phases, a) == GLACIAL for a in range(19, 31))


def test_termination_one_end_of_glacial(phases):
    assert all(phase(phases, a) == END_OF_GLACIAL for a in range(12, 19))


def test_mis_5e_interglacial(phases):
    assert all(phase(phases, a) == INTERGLACIAL for a in (123, 124, 125, 126))


def test_interglacial_share_close_to_000_section_5_1(phases):
    """000 §5.1: ~80 kyr glacial then ~20 kyr interglacial per cycle."""
    share = {p: float(np.mean(phases == p)) for p in (GLACIAL, END_OF_GLACIAL, INTERGLACIAL)}
    print(share)
    assert 0.15 <= share[INTERGLACIAL] <= 0.30
    assert 0.04 <= share[END_OF_GLACIAL] <= 0.15
    assert share[GLACIAL] >= 0.6


def test_glacial_stages_are_mostly_glacial(phases):
    """The even marine isotope stages (cold) of LR04's boundary table, 0–800 ka: at least
    three quarters of each stage's ages are glacial or end of glacial."""
    b = mis_boundaries()
    stages = {2: ("1/2", "2/3"), 4: ("3/4", "4/5"), 6: ("5/6", "6/7"), 8: ("7/8", "8/9"),
              10: ("9/10", "10/11"), 12: ("11/12", "12/13"), 16: ("15/16", "16/17"),
              18: ("17/18", "18/19")}
    for stage, (young, old) in stages.items():
        inside = (AGES >= b[young]) & (AGES < b[old])
        cold = np.mean(phases[inside] != INTERGLACIAL)
        assert cold >= 0.75, f"MIS {stage}: {cold:.2f}"


@pytest.mark.parametrize("chronology", ["spratt", "bintanja"])
def test_end_of_glacial_at_each_major_termination(request, chronology):
    """Each glacial → interglacial MIS boundary of LR04 (Terminations I–V, and 15/16) has an
    end-of-glacial age within 3 kyr: the rule finds the terminations that LR04 dated."""
    series = request.getfixturevalue(chronology)
    phases = classify(AGES, series.at(AGES))
    b = mis_boundaries()
    for name in ("1/2", "5/6", "7/8", "9/10", "11/12", "15/16"):
        near = np.abs(AGES - b[name]) <= 3.0
        assert np.any(phases[near] == END_OF_GLACIAL), f"MIS {name} at {b[name]:g} ka"


def test_a_synthetic_cycle_follows_the_rule():
    """A sawtooth cycle: slow fall from 0 m (110 ka) to −120 m (20 ka), rise to 0 m at 10 ka."""
    ages = np.arange(0.0, 111.0)
    falling = -120.0 + 120.0 * (ages - 20) / 90
    sea = np.where(ages <= 10, 0.0, np.where(ages <= 20, -12.0 * (ages - 10), falling))
    phases = classify(ages, sea)
    # interglacial while sea ≥ −35 m: ages 0–12 (−24 m at 12 ka) and ≥ 84 ka (−34.7 m)
    assert set(phases[ages <= 12]) == {INTERGLACIAL}
    assert set(phases[(ages >= 13) & (ages <= 19)]) == {END_OF_GLACIAL}
    # 20 ka: centred rate (−108 + 119.3)/2 = 5.7 m/kyr rising → still the end of glacial
    assert phases[20] == END_OF_GLACIAL
    assert set(phases[(ages >= 21) & (ages < 84)]) == {GLACIAL}  # falling: never the end
    assert set(phases[ages >= 84]) == {INTERGLACIAL}
    # order does not matter
    shuffled = np.random.default_rng(1).permutation(ages.size)
    np.testing.assert_array_equal(classify(ages[shuffled], sea[shuffled]), phases[shuffled])


def test_a_rise_that_stalls_or_starts_too_early_is_glacial():
    ages = np.arange(0.0, 40.0)
    # rise from −120 m (30 ka) to 0 m (5 ka) at 4.8 m/kyr: only the last 10 kyr before the
    # onset (−35 m is reached at 12.7 ka → first interglacial sample 12 ka) is the end of glacial
    sea = np.clip(-120.0 + 4.8 * (30.0 - ages), -120.0, 0.0)
    phases = classify(ages, sea)
    onset = 12.0
    assert phases[int(onset)] == INTERGLACIAL and phases[int(onset) + 1] == END_OF_GLACIAL
    assert set(phases[(ages > onset) & (ages <= onset + 10)]) == {END_OF_GLACIAL}
    assert set(phases[ages > onset + 10]) == {GLACIAL}
    # a pause in the rise cuts the end of glacial: only the samples after the pause count
    paused = sea.copy()
    paused[17:20] = paused[17]
    phases = classify(ages, paused)
    assert phases[18] == GLACIAL and phases[21] == GLACIAL and phases[16] == END_OF_GLACIAL


def test_thresholds_configurable_and_checked():
    ages = np.arange(0.0, 30.0)
    sea = np.where(ages < 10, 0.0, -12.0 * (ages - 10)).clip(-120.0)
    strict = PhaseThresholds(interglacial_sea_level_m=-1.0, end_window_kyr=3.0)
    phases = classify(ages, sea, strict)
    assert set(phases[ages <= 10]) == {INTERGLACIAL}  # −1 m: only the flat top
    assert set(phases[(ages >= 11) & (ages <= 13)]) == {END_OF_GLACIAL}  # 3 kyr window
    assert set(phases[ages >= 14]) == {GLACIAL}
    with pytest.raises(ValueError, match="end_window_kyr must be > 0"):
        PhaseThresholds(end_window_kyr=0.0)
    with pytest.raises(ValueError, match="min_rise_rate_m_per_kyr must be ≥ 0"):
        PhaseThresholds(min_rise_rate_m_per_kyr=-1.0)
    with pytest.raises(ValueError, match="finite number"):
        PhaseThresholds(interglacial_sea_level_m=float("nan"))


def test_d18o_form_of_the_thresholds(lr04):
    t = PhaseThresholds()
    level = t.interglacial_d18o_permil()
    print(f"interglacial at δ18O ≤ {level:.3f} ‰; end of glacial when δ18O falls ≥ "
          f"{t.min_d18o_fall_rate_permil_per_kyr():.4f} ‰/kyr")
    assert DEFAULT_MAPPING(level) == pytest.approx(t.interglacial_sea_level_m)
    assert level == pytest.approx(3.756, abs=0.001)
    d18o = lr04.at(AGES)
    phases = classify_d18o(AGES, d18o)
    np.testing.assert_array_equal(phases == INTERGLACIAL, d18o <= level + 1e-12)


@pytest.mark.parametrize(
    ("ages", "sea", "pattern"),
    [
        (np.arange(3.0), np.zeros(2), "same length"),
        (np.zeros((2, 2)), np.zeros((2, 2)), "1-D"),
        (np.array([]), np.array([]), "at least one age"),
        (np.array([0.0, np.nan]), np.zeros(2), "finite"),
        (np.array([0.0, 1.0, 1.0]), np.zeros(3), "age 1 ka twice"),
    ],
)
def test_bad_input_is_refused(ages, sea, pattern):
    with pytest.raises(ValueError, match=pattern):
        classify(ages, sea)


def test_single_sample():
    assert classify(np.array([5.0]), np.array([-100.0]))[0] == GLACIAL
    assert classify(np.array([5.0]), np.array([0.0]))[0] == INTERGLACIAL
