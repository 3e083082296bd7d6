"""The downstream K_d follows sea level in 000 Table 1's direction: high (≈ 3) at high sea level,
where interglacials deposit, low (≈ 0.1) at the glacial lowstand, where rivers incise and the
"high erosion rate prevents deposition" (000 §5.1.1, §5.2); the timeline records it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tests.cli import test_climate_run
from tests.cli.test_climate_run import read_timeline
from tests.conftest import run_cli

from unerode_cli.climate.phases import GLACIAL, INTERGLACIAL, classify
from unerode_cli.climate.schedule import DOWNSTREAM_K_D, Schedule


def test_k_d_is_high_at_high_sea_level_and_low_at_the_lowstand():
    schedule = Schedule()
    assert schedule.downstream_k_d(0.0) == pytest.approx(3.0)
    assert schedule.downstream_k_d(-150.0) == pytest.approx(0.1)
    assert schedule.downstream_k_d(-75.0) == pytest.approx(1.55)
    sea = np.linspace(-200.0, 10.0, 43)
    k_d = np.array([schedule.downstream_k_d(s) for s in sea])
    assert np.all(np.diff(k_d) >= 0.0) and k_d[0] == pytest.approx(0.1) and k_d[-1] == pytest.approx(3.0)
    interglacial, glacial = schedule.values(INTERGLACIAL, 0.0), schedule.values(GLACIAL, -120.0)
    assert interglacial[DOWNSTREAM_K_D] > glacial[DOWNSTREAM_K_D]


def test_along_the_last_glacial_cycle_the_lowstand_has_the_lowest_k_d(spratt):
    ages = np.arange(0.0, 131.0)
    sea = spratt.at(ages)
    k_d = np.array([Schedule().downstream_k_d(s) for s in sea])
    assert int(np.argmin(k_d)) == int(np.argmin(sea))
    assert k_d[20] == pytest.approx(3.0 - 2.9 * 125.36 / 150.0, abs=1e-6)  # LGM: 0.58
    interglacial = classify(ages, sea) == INTERGLACIAL
    assert k_d[interglacial].min() > k_d[~interglacial].mean()


#: The fixture of a 30 × 16 ramp of 30 m cells, 4.5–23 m high, tilted towards the south edge.
ramp = test_climate_run.ramp


def sea_table(path: Path) -> Path:
    """Sea level 0 m at 10–20 ka, falling linearly to −150 m at 25 ka and staying there to 40 ka."""
    ages = np.arange(10.0, 41.0)
    sea = -150.0 * np.clip((ages - 20.0) / 5.0, 0.0, 1.0)
    path.write_text("".join(f"{a:g} {s:g}\n" for a, s in zip(ages, sea, strict=True)))
    return path


@pytest.mark.parametrize("region", [(), ("--downstream-below", "10")])
def test_timeline_holds_the_downstream_k_d_of_each_step(tmp_path: Path, ramp: Path, region):
    out = tmp_path / "past.tif"
    result = run_cli("climate-run", ramp, out, "--chronology", sea_table(tmp_path / "sea.txt"),
                     "--chronology-kind", "sea-level", "--from", 10, "--to", 30, "--dt", 1000,
                     "--process", "fluvial", "--outlets", "S", *region)
    assert result.returncode == 0, result.stderr
    by_age = {round(float(r["age_ka"])): r for r in read_timeline(tmp_path / "past_timeline.csv")}
    assert float(by_age[12]["downstream_k_d"]) == pytest.approx(3.0)  # middle age 11.5 ka: 0 m
    assert float(by_age[30]["downstream_k_d"]) == pytest.approx(0.1)  # 29.5 ka: −150 m
    assert float(by_age[23]["downstream_k_d"]) == pytest.approx(3.0 - 2.9 * 75.0 / 150.0)  # 22.5 ka


def test_timeline_has_no_downstream_k_d_without_k_d(tmp_path: Path, ramp: Path):
    out = tmp_path / "past.tif"
    result = run_cli("climate-run", ramp, out, "--chronology", sea_table(tmp_path / "sea.txt"),
                     "--chronology-kind", "sea-level", "--from", 10, "--to", 12, "--dt", 1000,
                     "--process", "thermal", "--outlets", "S")
    assert result.returncode == 0, result.stderr
    rows = read_timeline(tmp_path / "past_timeline.csv")
    assert "k_th" in rows[0] and "downstream_k_d" not in rows[0]
