"""A sweep axis of sea-level curves that cannot change any member is refused before any member
runs (exit 2, one sentence with the numbers), unless --allow-inert-axes: then a warning, a
record in ensemble.json, and members that are bit-identical — the independent proof that the
axis was inert. The case is the Tautavel one on an inland crop of the sample valley (the sea
never reaches it) with the two curves of the case study, Spratt & Lisiecki 2016 and Bintanja
& van de Wal 2008."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
import rasterio
from tests.cli.test_bad_input import assert_refused
from tests.conftest import SAMPLE_DEMS, SHARED_DATA, run_cli, write_geotiff
from tests.ensemble.case import SEA_LEVELS, needs_data

from unerode_cli.climate.sea_influence import CurveForcing, sea_influence

UPLIFT = 2.5e-5          # m/y, the Tautavel uplift of 000 §6.3.1


def inland_crop(path: Path) -> np.ndarray:
    """The northern half of the 256² sample valley (rows 0–127), every 4th cell: 32 × 64
    cells of 120 m, all above 150 m (the sea of the sample valley lies in its southern rows)."""
    with rasterio.open(SAMPLE_DEMS / "valley_utm32n_30m.tif") as src:
        data = src.read(1)[:128:4, ::4].copy()
        transform = src.transform @ src.transform.scale(4, 4)
        crs = src.crs.to_string()
    write_geotiff(path, data, transform=transform, crs=crs)
    return data.astype(np.float64)


def write_spec(folder: Path, to_ka: int, dt: int, snapshots: str, extend: bool = False) -> Path:
    """The Tautavel climate-run (thermal, fluvial, uplift, downstream K_d below 100 m) on the
    inland crop, with the two sea-level curves swept."""
    folder.mkdir(parents=True, exist_ok=True)
    outputs = ", ".join(f"past_{age}ka.tif" for age in snapshots.split(","))
    spec = folder / "spec.yaml"
    spec.write_text(f"""version: 1
vars:
  data: {SHARED_DATA}
steps:
  - name: past
    run: climate-run
    args: [dem.tif, past.tif]
    options:
      chronology: "${{data}}/lr04/LR04stack.txt"
      to: {to_ka}
      dt: {dt}
      snapshots: "{snapshots}"
      process: thermal,fluvial
      uplift: {UPLIFT}
      downstream-below: 100{chr(10) + '      sea-level-extend: d18o' if extend else ''}
    outputs: [{outputs}]
sweep:
  past.sea-level: [{SEA_LEVELS['spratt']}, {SEA_LEVELS['bintanja']}]
""")
    return spec


def highest_sea(to_ka: float, dt: int) -> float:
    """The highest sea level (m) of the two tables at the run's ages (start, step middles and
    ends), read with NumPy alone."""
    ages = np.arange(0.0, to_ka + 1e-9, dt / 2000.0)
    rows = [line for line in SEA_LEVELS["spratt"].read_text(encoding="latin-1").splitlines()
            if line.strip() and not line.startswith("#")][1:]
    spratt = np.array([[float(v) for v in row.split("\t")[:9:5]] for row in rows])
    bintanja = np.genfromtxt(SEA_LEVELS["bintanja"], delimiter=",", names=True)
    age_b = bintanja[bintanja.dtype.names[0]]
    sea_b = bintanja["Sealevel_Corrected"]
    order = np.argsort(spratt[:, 0])
    # Spratt's table is anchored to 0 m at 0 ka by the reader (its column is shifted)
    sea_s = np.interp(ages, spratt[order, 0], spratt[order, 1]) - np.interp(0.0, spratt[order, 0],
                                                                              spratt[order, 1])
    return float(max(sea_s.max(), np.interp(ages, np.sort(age_b), sea_b[np.argsort(age_b)]).max()))


def read(path: Path) -> np.ndarray:
    with rasterio.open(path) as src:
        return src.read(1)


def test_the_three_ways_a_curve_acts() -> None:
    mid = np.array([1.0, 3.0, 5.0])
    phases = np.array(["interglacial", "glacial", "glacial"])
    a = CurveForcing("a", np.array([0.0, -50.0, -90.0, -120.0]), phases)
    b = CurveForcing("b", np.array([0.0, -40.0, -95.0, -110.0]), phases)
    c = CurveForcing("c", a.sea_m, np.array(["interglacial", "end-of-glacial", "glacial"]))
    inert = sea_influence([a, b], mid, lowest_cell_m=10.0, uplift_m=9.0, downstream_cells=0)
    assert inert.inert and inert.lowest_ground_m == pytest.approx(1.0) and inert.highest_sea_m == 0.0
    # 1 m lower ground (more uplift) and the sea's 0 m reaches it: outlets at or below sea level
    assert sea_influence([a, b], mid, 10.0, 10.0, 0).reaches
    assert not sea_influence([a, b], mid, 10.0, 10.0, 0, sea_outlets=False).reaches
    assert sea_influence([a, b], mid, 10.0, 0.0, 3).kd_differs         # K_d follows the curves
    assert not sea_influence([a, a], mid, 10.0, 0.0, 3).kd_differs
    phased = sea_influence([a, c], mid, 10.0, 0.0, 0)
    assert not phased.inert and phased.phase_steps_differing == 1 and phased.first_phase_difference_ka == 3.0


@pytest.mark.skipif(not needs_data, reason="needs ../shared/data (LR04, sea-level curves)")
def test_an_inert_sea_level_axis_is_refused_with_its_numbers(tmp_path: Path) -> None:
    crop = inland_crop(tmp_path / "dem.tif")
    spec = write_spec(tmp_path, 60, 5000, "10")
    started = time.monotonic()
    result = run_cli("ensemble", spec, tmp_path / "out")
    assert_refused(result, None, "sweep 'past.sea-level' cannot change any member's result")
    assert time.monotonic() - started < 30
    assert not (tmp_path / "out").exists()
    line = result.stderr.strip()
    lowest = crop.min() - UPLIFT * 60_000.0
    print(line)
    assert f"lowest ground {lowest:.1f} m" in line                        # 157.5 − 1.5 m
    assert f"{UPLIFT * 60_000.0:.1f} m of uplift" in line
    assert f"highest sea level of the curves over the run {highest_sea(60, 5000):.1f} m" in line
    assert "no cell is in the downstream region" in line and "--allow-inert-axes" in line


@pytest.mark.slow
@pytest.mark.skipif(not needs_data, reason="needs ../shared/data (LR04, sea-level curves)")
def test_an_allowed_inert_axis_is_recorded_and_its_members_are_identical(tmp_path: Path) -> None:
    crop = inland_crop(tmp_path / "dem.tif")
    spec = write_spec(tmp_path, 60, 5000, "10")
    out = tmp_path / "out"
    result = run_cli("ensemble", spec, out, "--allow-inert-axes", "--workers", "1")
    assert result.returncode == 0, result.stderr
    lines = result.stderr.splitlines()
    warning = next(i for i, line in enumerate(lines) if line.startswith("warning: sweep 'past.sea-level'"))
    assert warning < next(i for i, line in enumerate(lines) if line.startswith("local cluster"))
    record = json.loads((out / "ensemble.json").read_text())["inert_axes"]
    assert [axis["key"] for axis in record] == ["past.sea-level"]
    assert record[0]["lowest_ground_m"] == pytest.approx(crop.min() - 1.5, abs=1e-3)
    assert record[0]["highest_sea_level_m"] == pytest.approx(highest_sea(60, 5000), abs=1e-3)
    for name in ("past.tif", "past_10ka.tif"):   # the two curves gave the same members, bit for bit
        np.testing.assert_array_equal(read(out / "members/0000" / name), read(out / "members/0001" / name))


@pytest.mark.slow
@pytest.mark.skipif(not needs_data, reason="needs ../shared/data (LR04, sea-level curves)")
def test_curves_that_differ_only_in_their_phases_run_with_a_note(tmp_path: Path) -> None:
    """Back to 820 ka (Spratt continued with LR04 δ18O): the sea still never reaches the crop,
    but the curves classify a step differently, so the axis runs, and the note's first age
    of difference splits the members' snapshots into identical and different."""
    inland_crop(tmp_path / "dem.tif")
    spec = write_spec(tmp_path, 820, 20000, "240,260", extend=True)
    out = tmp_path / "out"
    result = run_cli("ensemble", spec, out, "--workers", "1")
    assert result.returncode == 0, result.stderr
    note = next(line for line in result.stderr.splitlines()
                if line.startswith("note: sweep 'past.sea-level'"))
    assert "only through the climate phases" in note and "the first at 250 ka" in note
    assert "inert_axes" not in json.loads((out / "ensemble.json").read_text())
    first, second = out / "members/0000", out / "members/0001"
    np.testing.assert_array_equal(read(first / "past_240ka.tif"), read(second / "past_240ka.tif"))
    assert np.abs(read(first / "past_260ka.tif") - read(second / "past_260ka.tif")).max() > 0.01
