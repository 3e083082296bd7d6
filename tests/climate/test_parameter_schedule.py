"""Parameter schedule (000 §5.2): K_th 0.002 → 0.008 and p 0.6 → 0.3 m/y in glacials, downstream
K_d 3 → 0.1 over a 150 m sea-level fall; overrides from a mapping; rasters scaled per phase; the
downstream region."""

from __future__ import annotations

import re

import numpy as np
import pytest

from unerode_cli.climate.phases import END_OF_GLACIAL, GLACIAL, INTERGLACIAL, classify
from unerode_cli.climate.schedule import DOWNSTREAM_K_D, DownstreamKd, Schedule, downstream_mask


def test_defaults_of_000_section_5_2():
    schedule = Schedule()
    assert schedule.values(INTERGLACIAL, 0.0) == {"k_th": 0.002, "precipitation": 0.6,
                                                  DOWNSTREAM_K_D: pytest.approx(3.0)}
    glacial = schedule.values(GLACIAL, -150.0)
    assert glacial == {"k_th": 0.008, "precipitation": 0.3, DOWNSTREAM_K_D: pytest.approx(0.1)}
    end = schedule.values(END_OF_GLACIAL, -75.0)
    assert end["k_th"] == pytest.approx(0.005) and end["precipitation"] == pytest.approx(0.45)
    assert "k_d" not in glacial  # k_d outside the downstream region keeps its ordinary value


def test_downstream_k_d_follows_sea_level_linearly_and_clamped():
    schedule = Schedule()
    assert schedule.downstream_k_d(0.0) == pytest.approx(3.0)
    assert schedule.downstream_k_d(-75.0) == pytest.approx(1.55)  # halfway
    assert schedule.downstream_k_d(-150.0) == pytest.approx(0.1)
    assert schedule.downstream_k_d(-120.0) == pytest.approx(3.0 - 2.9 * 0.8)
    assert schedule.downstream_k_d(+8.0) == pytest.approx(3.0)  # above present: clamped
    assert schedule.downstream_k_d(-400.0) == pytest.approx(0.1)
    np.testing.assert_allclose(DownstreamKd().at(np.array([0.0, -30.0, -300.0])), [3.0, 2.42, 0.1])
    with pytest.raises(ValueError, match="finite number"):
        schedule.downstream_k_d(float("nan"))


def test_schedule_along_the_last_glacial_cycle(spratt):
    """Along Spratt 2016 the scheduled K_th is 0.008 at the LGM and 0.002 in the Holocene, and
    the downstream K_d stays within 0.1–3 and is lowest at the lowest sea level."""
    ages = np.arange(0.0, 131.0)
    sea = spratt.at(ages)
    phases = classify(ages, sea)
    schedule = Schedule()
    k_th = np.array([schedule.values(p, s)["k_th"] for p, s in zip(phases, sea, strict=True)])
    k_d = np.array([schedule.downstream_k_d(s) for s in sea])
    assert k_th[20] == 0.008 and k_th[5] == 0.002 and k_th[15] == 0.005
    assert k_d.min() >= 0.1 and k_d.max() <= 3.0
    assert k_d[20] == pytest.approx(3.0 - 2.9 * 125.36 / 150.0, abs=1e-6)
    assert int(np.argmin(k_d)) == int(np.argmin(sea))


def test_overrides_and_new_parameters():
    schedule = Schedule.from_mapping({
        "glacial": {"k_th": 0.01, "K": 2e-5},
        "end-of-glacial": {"p": 0.4},
        "interglacial": None,
        "downstream_k_d": {"lowest": 5, "range_m": 100},
    })
    assert schedule.values(GLACIAL, 0.0)["k_th"] == 0.01
    assert schedule.values(GLACIAL, 0.0)["k"] == 2e-5  # the paper's symbol K → k
    assert schedule.values(GLACIAL, 0.0)["precipitation"] == 0.3  # default kept
    assert "k" not in schedule.values(INTERGLACIAL, 0.0)  # not set there: ordinary value
    assert schedule.values(END_OF_GLACIAL, 0.0)["precipitation"] == 0.4
    assert schedule.downstream_k_d(-50.0) == pytest.approx(3.0 + 2.0 * 0.5)
    assert schedule.downstream_k_d(-200.0) == pytest.approx(5.0)
    # round trip for provenance
    assert Schedule.from_mapping(schedule.to_mapping()) == schedule
    assert Schedule.from_mapping(None) == Schedule() == Schedule.from_mapping({})


def test_default_schedule_is_not_shared_between_instances():
    one = Schedule.from_mapping({"glacial": {"k_th": 0.02}})
    assert Schedule().values(GLACIAL, 0.0)["k_th"] == 0.008 and one.phases is not Schedule().phases


@pytest.mark.parametrize(
    ("mapping", "pattern"),
    [
        ({"glacal": {"k_th": 1}}, r"unknown schedule key 'glacal'; use glacial, end-of-glacial"),
        ({"glacial": 0.008}, r"schedule key 'glacial' must hold a mapping"),
        ({"glacial": {"k_th": "much"}}, r"schedule key glacial\.k_th must be a finite number, got 'much'"),
        ({"glacial": {"k_th": True}}, r"schedule key glacial\.k_th must be a finite number"),
        ({"glacial": {"k_th": float("inf")}}, r"glacial\.k_th must be a finite number"),
        ({"interglacial": {"p": -0.1}}, r"schedule key interglacial\.p must be ≥ 0, got -0\.1"),
        ({"glacial": {"not a name": 1}}, r"schedule key glacial\.'not a name' is not a parameter name"),
        ({"glacial": {"downstream_k_d": 1}}, r"glacial\.downstream_k_d is not per phase"),
        ({"downstream_k_d": 3}, r"schedule key 'downstream_k_d' must hold a mapping"),
        ({"downstream_k_d": {"highest": 3}}, r"unknown schedule key downstream_k_d\.highest"),
        ({"downstream_k_d": {"present": "x"}}, r"downstream_k_d\.present must be a finite number"),
        ({"downstream_k_d": {"range_m": 0}}, r"downstream_k_d\.range_m must be > 0 m, got 0"),
        ({"downstream_k_d": {"lowest": -1}}, r"downstream_k_d\.lowest must be ≥ 0 m/y, got -1"),
        ([1, 2], r"a schedule must be a mapping of phases to parameters, got list"),
    ],
)
def test_malformed_schedules_are_refused_in_one_sentence(mapping, pattern):
    with pytest.raises(ValueError, match=pattern) as info:
        Schedule.from_mapping(mapping)
    message = str(info.value)
    assert "\n" not in message and not re.search(r"[.!?]\s+[A-Z]", message)


def test_unknown_phase_is_refused():
    with pytest.raises(ValueError, match="unknown climate phase 'warm'"):
        Schedule().values("warm", 0.0)


def test_downstream_mask_below_a_level_or_given():
    h = np.array([[10.0, -5.0, np.nan], [0.0, 3.0, -20.0]])
    np.testing.assert_array_equal(downstream_mask(h, below_m=0.0),
                                  [[False, True, False], [False, False, True]])
    np.testing.assert_array_equal(downstream_mask(h, below_m=5.0),
                                  [[False, True, False], [True, True, True]])
    given = np.array([[1, 0, 0], [0, 0, 2]], dtype=np.uint8)
    out = downstream_mask(h, mask=given)
    assert out.dtype == bool and out.tolist() == [[True, False, False], [False, False, True]]
    with pytest.raises(ValueError, match="exactly one"):
        downstream_mask(h)
    with pytest.raises(ValueError, match="exactly one"):
        downstream_mask(h, below_m=0.0, mask=given)
    with pytest.raises(ValueError, match=r"mask has shape \(1, 3\), the elevation has \(2, 3\)"):
        downstream_mask(h, mask=np.ones((1, 3)))
    with pytest.raises(ValueError, match="finite number"):
        downstream_mask(h, below_m=float("nan"))


def test_a_raster_is_scaled_by_the_phase_relative_to_the_interglacial_and_a_number_replaced():
    schedule = Schedule()
    k_th = 0.002 * np.array([[1.0, 2.0]])  # a present-day map: 1 and 2 × the interglacial value
    rain = np.array([[0.6, 1.2]])
    ordinary = {"k_th": k_th, "precipitation": rain, "k": 2e-5, "k_d": 1.0}
    glacial = schedule.apply(GLACIAL, ordinary)
    np.testing.assert_allclose(glacial["k_th"], 4.0 * k_th, rtol=1e-12)  # 0.008 / 0.002
    np.testing.assert_allclose(glacial["precipitation"], 0.5 * rain, rtol=1e-12)  # 0.3 / 0.6
    assert glacial["k"] == 2e-5 and glacial["k_d"] == 1.0  # not scheduled: kept
    np.testing.assert_allclose(schedule.apply(END_OF_GLACIAL, ordinary)["k_th"], 2.5 * k_th, rtol=1e-12)
    np.testing.assert_array_equal(schedule.apply(INTERGLACIAL, ordinary)["k_th"], k_th)
    assert schedule.apply(GLACIAL, {"k_th": 0.004})["k_th"] == 0.008  # a number is replaced
    assert schedule.factor("k_th", GLACIAL) == pytest.approx(4.0)
    assert schedule.factor("k", GLACIAL) == 1.0


def test_k_and_u_maps_follow_a_schedule_that_sets_them():
    schedule = Schedule.from_mapping({"glacial": {"K": 4e-5, "U": -1e-4},
                                      "interglacial": {"K": 2e-5, "U": 2e-4}})
    k_map, u_map = np.array([[1e-5, 3e-5]]), np.array([[2e-4, 1e-4]])
    glacial = schedule.apply(GLACIAL, {"k": k_map, "uplift": u_map})
    np.testing.assert_allclose(glacial["k"], 2.0 * k_map, rtol=1e-12)
    np.testing.assert_allclose(glacial["uplift"], -0.5 * u_map, rtol=1e-12)
    np.testing.assert_array_equal(schedule.apply(END_OF_GLACIAL, {"k": k_map})["k"], k_map)


@pytest.mark.parametrize("interglacial", [None, 0.0])
def test_a_raster_without_an_interglacial_value_to_scale_from_is_refused(interglacial):
    mapping = {"glacial": {"K": 4e-5}}
    if interglacial is not None:
        mapping["interglacial"] = {"K": interglacial}
    schedule = Schedule.from_mapping(mapping)
    assert schedule.apply(GLACIAL, {"k": 1e-5})["k"] == 4e-5  # a number: replaced, fine
    with pytest.raises(ValueError, match=r"sets k for glacial but no non-zero value for interglacial"):
        schedule.apply(GLACIAL, {"k": np.array([[1e-5, 2e-5]])})
