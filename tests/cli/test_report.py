"""`unerode-cli report` and `climate-run --report`: one self-contained HTML page whose numbers
are those of the run's own files."""

from __future__ import annotations

import csv
import subprocess
from pathlib import Path

import pytest
from tests.cli.test_bad_input import assert_refused
from tests.conftest import SHARED_DATA, run_cli
from tests.ensemble.case import small_dem
from tests.ensemble.html_check import check_page

LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"
CHROMIUM = Path("/usr/bin/chromium")


@pytest.fixture(scope="module")
def climate_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not LR04.is_file():
        pytest.skip("needs ../shared/data/lr04")
    folder = tmp_path_factory.mktemp("report")
    dem = small_dem(folder / "dem.tif")
    result = run_cli("climate-run", dem, folder / "past.tif", "--chronology", LR04, "--to", "20",
                     "--dt", "5000", "--snapshots", "10", "--K", "2e-5", "--report")
    assert result.returncode == 0, result.stderr
    return folder


def test_climate_run_report_shows_every_snapshot_and_the_mass_budget(climate_folder: Path) -> None:
    page = check_page((climate_folder / "past_report.html").read_text(encoding="utf-8"))
    assert page.headings[:5] == ["unerode-cli report: past.tif", "climate-run past.tif",
                                 "Previews at each snapshot", "Chronology, timeline and mass budget",
                                 "Parameters and history"]
    assert len(page.images) == 4            # 2 previews (10 and 20 ka), chronology, timeline
    with (climate_folder / "past_timeline.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    budget = {row[0]: float(row[1]) for table in page.tables for row in table[1:]
              if table[0] == ["mass budget", "volume (m³)"]}
    eroded = sum(float(r["eroded_m3"]) for r in rows)
    deposited = sum(float(r["deposited_m3"]) for r in rows)
    assert budget["eroded"] == pytest.approx(eroded, rel=1e-5)
    assert budget["deposited"] == pytest.approx(deposited, rel=1e-5)
    parameters = {row[0]: row[1] for table in page.tables for row in table[1:]
                  if table[0] == ["parameter", "value"]}
    assert float(parameters["dt"]) == 5000.0 and float(parameters["k"]) == 2e-5


def test_report_of_a_folder_refuses_to_overwrite(climate_folder: Path) -> None:
    result = run_cli("report", climate_folder)
    assert result.returncode == 0, result.stderr
    page = check_page((climate_folder / "report.html").read_text(encoding="utf-8"))
    assert "climate-run past.tif" in page.headings
    assert_refused(run_cli("report", climate_folder), None, "--overwrite")
    assert run_cli("report", climate_folder, "--overwrite").returncode == 0


def test_a_folder_without_runs_is_refused(tmp_path: Path) -> None:
    assert_refused(run_cli("report", tmp_path), tmp_path / "report.html", "holds nothing unerode-cli wrote")
    assert_refused(run_cli("report", tmp_path / "none"), None, "does not exist")


@pytest.mark.skipif(not CHROMIUM.exists(), reason="no headless browser at /usr/bin/chromium")
def test_the_page_renders_in_a_headless_browser(climate_folder: Path, tmp_path: Path) -> None:
    page = climate_folder / "past_report.html"
    shot = tmp_path / "page.png"
    dom = subprocess.run([str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--dump-dom",
                          page.as_uri()], capture_output=True, text=True, timeout=120)
    assert dom.returncode == 0 and "Previews at each snapshot" in dom.stdout
    subprocess.run([str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", f"--screenshot={shot}",
                    "--window-size=1200,2000", page.as_uri()], capture_output=True, timeout=120, check=True)
    assert shot.stat().st_size > 10_000
