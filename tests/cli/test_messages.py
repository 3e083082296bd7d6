"""What the commands say: bad values refused in one sentence that names the right thing, notes
for what is changed silently, the same -q/-v in every command, and help that fits 80 columns."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from tests.cli.test_bad_input import assert_refused
from tests.conftest import run_cli, write_geotiff

from unerode_cli.cli.commands import COMMANDS
from unerode_cli.io.observation_files import INCISION_COLUMNS, TERRACE_COLUMNS

CHRONOLOGY = "".join(f"{age} {3.2 + 0.02 * age:.3f}\n" for age in range(0, 41))


@pytest.fixture
def dem(tmp_path: Path) -> Path:
    """16 × 16 cells of 30 m tilted towards the south edge."""
    rows, cols = np.indices((16, 16))
    z = 10.0 + 0.6 * (15 - rows) + 0.3 * np.sin(cols * 0.9)
    return write_geotiff(tmp_path / "dem.tif", z.astype(np.float32))


@pytest.fixture
def chronology(tmp_path: Path) -> Path:
    path = tmp_path / "d18o.txt"
    path.write_text(CHRONOLOGY)
    return path


def all_nodata(tmp_path: Path) -> Path:
    return write_geotiff(tmp_path / "nodata.tif", np.full((8, 8), -9999.0, np.float32), nodata=-9999.0)


def one_cell(tmp_path: Path) -> Path:
    return write_geotiff(tmp_path / "one.tif", np.ones((1, 1), np.float32))


def notes(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("note: ")]


# item 6: crashes on malformed or non-finite numbers are bad input (one sentence, exit 2)

CLIMATE = ["climate-run", "{dem}", "{out}", "--chronology", "{chronology}", "--to", "2",
           "--process", "fluvial"]


@pytest.mark.parametrize(("args", "mentions"), [
    (CLIMATE + ["--to", "nan"], "'--to': must be a finite number (ka), got 'nan'"),
    (CLIMATE + ["--from", "inf"], "'--from': must be a finite number (ka), got 'inf'"),
    (CLIMATE + ["--snapshots", "abc"], "expected ages in ka separated by commas, got 'abc'"),
    (CLIMATE + ["--d18o-to-sea", "garbage"], "expected SLOPE,INTERCEPT"),
    (CLIMATE + ["--downstream-below", "nan"], "'--downstream-below': must be a finite number (m)"),
    (CLIMATE + ["--dt", "1e300"], "longer than the span 0–2 ka"),
    (["erode", "{dem}", "{out}", "--duration", "1000", "--snapshot-every", "nan"], "'--snapshot-every'"),
    (["erode", "{dem}", "{out}", "--steps", "1", "--dt", "inf"], "'--dt': must be a finite number"),
    (["flow", "{dem}", "{out}", "--sea-level", "nan"], "'--sea-level'"),
    (["particle-erode", "{dem}", "{out}", "--spread", "-1"], "'--spread': must be ≥ 0 m"),
    (["glaciate", "{dem}", "{out}", "--ela", "100", "--duration", "10", "--dt", "nan"], "'--dt'"),
    (["synth", "{out}", "--size", "16", "--relief", "nan"], "'--relief'"),
    (["preview", "{dem}", "{png}", "--exaggeration", "0"], "'--exaggeration': must be > 0"),
    (["convert", "{dem}", "{out}", "--z-scale", "inf"], "'--z-scale'"),
    (["compare-terraces", "--present", "{dem}", "--snapshots", "{dem}", "--out", "{png}",
      "--auto-river", "--observations", "{png}", "--fail-above", "nan"], "'--fail-above'"),
])
def test_malformed_or_non_finite_numbers_are_bad_input(tmp_path: Path, dem: Path, chronology: Path,
                                                      args: list[str], mentions: str) -> None:
    out, png = tmp_path / "out.tif", tmp_path / "out.png"
    filled = [a.format(dem=dem, out=out, png=png, chronology=chronology) for a in args]
    assert_refused(run_cli(*filled), out, mentions)


@pytest.mark.parametrize("make_dem", [all_nodata, one_cell])
@pytest.mark.parametrize("command", ["diff", "preview"])
def test_diff_and_preview_of_a_dem_without_slope(tmp_path: Path, make_dem, command: str) -> None:
    bad, png = make_dem(tmp_path), tmp_path / "p.png"
    out = tmp_path / "d.tif"
    args = ["diff", bad, bad, out, "--preview", png] if command == "diff" else ["preview", bad, png]
    mentions = "no valid cell" if make_dem is all_nodata else "a preview needs at least 2 × 2"
    assert_refused(run_cli(*args), png, mentions)
    assert not out.exists()


# item 7: messages that name the right thing

@pytest.mark.parametrize("command", ["flow", "climate-run", "compare-terraces"])
def test_an_all_nodata_dem_has_no_valid_cell(tmp_path: Path, chronology: Path, command: str) -> None:
    bad, out = all_nodata(tmp_path), tmp_path / "out.tif"
    args = {
        "flow": ["flow", bad, out],
        "climate-run": ["climate-run", bad, out, "--chronology", chronology, "--to", 2],
        "compare-terraces": ["compare-terraces", "--present", bad, "--snapshots", bad, "--out",
                             tmp_path / "report", "--auto-river", "--incision", tmp_path / "i.csv"],
    }[command]
    assert_refused(run_cli(*args), out, f"{bad} has no valid cell")


def test_a_params_group_of_a_process_not_run_is_refused(tmp_path: Path, dem: Path) -> None:
    params = tmp_path / "params.yaml"
    params.write_text("fluvial:\n  K: 2.0e-5\nthermal:\n  k_th: 0.008\n")
    out = tmp_path / "out.tif"
    assert_refused(run_cli("erode", dem, out, "--steps", 1, "--params", params), out,
                   "groups parameters under 'thermal', which is not a process of this run (fluvial)")


def test_a_source_that_is_neither_points_nor_a_file_says_what_source_takes(tmp_path: Path,
                                                                          dem: Path) -> None:
    out = tmp_path / "out.tif"
    assert_refused(run_cli("particle-erode", dem, out, "--source", "abc"), out,
                   "--source takes X,Y points in the DEM's CRS (repeat it for a line) or a GeoJSON/WKT "
                   "line file, and 'abc' is neither")


def test_receivers_cannot_be_written_to_exr(tmp_path: Path, dem: Path) -> None:
    out = tmp_path / "dirs.exr"
    assert_refused(run_cli("flow", dem, out, "--what", "receivers"), out, "uint8 D8 codes")


# item 12: what was changed silently is refused or said

@pytest.mark.parametrize(("text", "mentions"), [
    ("K: 1.0e-5\nk: 2.0e-5\n", "gives k twice, as 'K' and as 'k'"),
    ("uplift: 0\nfluvial:\n  U: 1.0e-5\n", "gives uplift twice, as 'uplift' and as 'fluvial.U'"),
    ("K: 1.0e-5\nK_d: 1\nK: 2.0e-5\n", "gives the key 'K' twice (line 3)"),
])
def test_a_parameter_given_twice_in_params_is_refused(tmp_path: Path, dem: Path, text: str,
                                                      mentions: str) -> None:
    params = tmp_path / "params.yaml"
    params.write_text(text)
    out = tmp_path / "out.tif"
    assert_refused(run_cli("erode", dem, out, "--steps", 1, "--params", params), out, mentions)


def test_a_materials_table_without_critical_stress_gets_a_note(tmp_path: Path, dem: Path) -> None:
    layers = tmp_path / "layers.tif"
    with rasterio.open(dem) as src:
        profile = {**src.profile, "count": 2, "dtype": "float32", "nodata": None}
    with rasterio.open(layers, "w", **profile) as dst:
        dst.write(np.ones((2, 16, 16), np.float32))
    materials = tmp_path / "materials.csv"
    materials.write_text("name,erodibility\nrock,0.05\nsoil,1.0\n")
    result = run_cli("particle-erode", dem, tmp_path / "out.tif", "--particles", 20, "--iterations", 1,
                     "--layers", layers, "--materials", materials)
    assert result.returncode == 0, result.stderr
    assert notes(result.stderr) == [f"note: the materials table {materials} has no critical_stress "
                                    "column: every material detaches from τ_c = 0 Pa."]


def test_nodata_in_the_rain_mask_gets_a_note(tmp_path: Path, dem: Path) -> None:
    weights = np.ones((16, 16), np.float32)
    weights[2, 3] = weights[4, 5] = -9999.0
    mask = write_geotiff(tmp_path / "mask.tif", weights, nodata=-9999.0)
    result = run_cli("particle-erode", dem, tmp_path / "out.tif", "--particles", 20, "--iterations", 1,
                     "--rain-mask", mask)
    assert result.returncode == 0, result.stderr
    assert notes(result.stderr) == [f"note: the rain mask {mask} has 2 nodata cell(s) inside the DEM; "
                                    "no rain starts there (weight 0)."]


# item 13: -q, -qq, -v, -vv mean the same in every command

VERBOSITY_RUNS = {
    # each run gives at least one note: an unsorted chronology, sub-steps, no --source
    "climate-run": ["climate-run", "{dem}", "{out}", "--chronology", "{unsorted}", "--to", "2",
                    "--process", "fluvial"],
    "erode": ["erode", "{dem}", "{out}", "--steps", "2", "--dt", "1e6", "--K", "1e-3",
              "--scheme", "explicit"],
    "particle-erode": ["particle-erode", "{dem}", "{out}", "--particles", "20", "--iterations", "2",
                       "--emission", "source"],
}


@pytest.mark.parametrize("command", sorted(VERBOSITY_RUNS))
def test_quiet_and_verbose_mean_the_same_in_every_command(tmp_path: Path, dem: Path,
                                                          command: str) -> None:
    unsorted = tmp_path / "unsorted.txt"
    unsorted.write_text("".join(reversed(CHRONOLOGY.splitlines(keepends=True))))
    said = {}
    for flags in ("", "-q", "-qq", "-v", "-vv"):
        args = [a.format(dem=dem, out=tmp_path / "out.tif", unsorted=unsorted)
                for a in VERBOSITY_RUNS[command]]
        result = run_cli(*args, "--overwrite", *([flags] if flags else []))
        assert result.returncode == 0, result.stderr
        said[flags] = result.stderr.splitlines()
    assert notes("\n".join(said[""]))
    assert len(said["-q"]) == 1 and said["-q"][0].startswith(f"{command}: ")  # the summary, no note
    assert said["-qq"] == []                                        # all but errors
    steps = [line for line in said["-v"] if re.match(rf"{command} \d+/2", line)]
    assert len(steps) == 2 and not any(line.endswith(" s)") for line in steps)
    if command in ("erode", "climate-run"):
        # the rate of a grid's steps, in cells per second
        assert all(re.search(r"\[[\d.,]+ M?cells/s\]", line) for line in steps), steps
    timed = [line for line in said["-vv"] if re.match(rf"{command} \d+/2.* \(\d+\.\d+ s\)$", line)]
    assert len(timed) == 2


def test_max_steps_zero_is_refused(tmp_path: Path, dem: Path, chronology: Path) -> None:
    out = tmp_path / "out.tif"
    assert_refused(run_cli("climate-run", dem, out, "--chronology", chronology, "--to", 2,
                           "--max-steps", 0), out, "'--max-steps'")


# item 14: help and units

def help_text(*command: str, columns: int) -> str:
    env = {**os.environ, "COLUMNS": str(columns)}
    result = subprocess.run([sys.executable, "-m", "unerode_cli", *command, "--help"],
                            capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    return result.stdout


@pytest.mark.parametrize("command", [*COMMANDS, "pipeline run"])
def test_help_keeps_every_option_name_whole_at_80_columns(command: str) -> None:
    text = help_text(*command.split(), columns=80)
    assert re.findall(r"--[\w-]*…", text) == []


def test_compare_terraces_help_names_every_csv_column() -> None:
    text = " ".join(help_text("compare-terraces", columns=200).split())
    for column in (*TERRACE_COLUMNS, *INCISION_COLUMNS):
        assert column in text


def test_a_dimensionless_bound_has_no_unit(tmp_path: Path, dem: Path) -> None:
    out = tmp_path / "out.tif"
    result = run_cli("erode", dem, out, "--steps", 1, "--n", 0.1)
    assert_refused(result, out, "parameter n must be ≥ 0.5, got 0.1")
