"""An ensemble whose members write plain rasters (``unerode … past_5ka.tif`` and a change map, no
snapshot age tag): every raster is summarised, and the report shows its maps on the CRS's axes,
the past minus the present DEM, the spread of the past heights at the terrace, the best and
median members' profiles, a link to every member's, and the parameter-pair matrix; in headless
Chromium the page fits a 1400 px window (every table whole) and an 800 px one (wide tables
scroll in their box), every image decodes and no ``${`` is left."""

from __future__ import annotations

import csv
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import rasterio
from tests.conftest import run_cli
from tests.ensemble.case import small_dem
from tests.ensemble.html_check import check_page
from tests.ensemble.summary_check import assert_summaries_match_members

from unerode_cli.ensemble.summary import SPREAD, median_position, value_spread
from unerode_cli.io.rasters import read_terrain
from unerode_cli.jobs.report.maps import map_frame
from unerode_cli.jobs.report.spec_values import SpecValues
from unerode_cli.viz.ensemble_plots import axis_positions

CHROMIUM = Path("/usr/bin/chromium")
SPEC = """\
version: 1
vars:
  conf: .
steps:
  - name: past
    run: unerode
    args: [dem.tif, past_5ka.tif]
    options:
      process: fluvial
      dt: 1000
      duration: 5000
      change-map: change.tif
  - name: compare
    run: compare-terraces
    options:
      present: dem.tif
      snapshots: [past_5ka.tif]
      observations: terraces.csv
      auto-river: true
      sea-level: 0
      out: report
sweep:
  past.K: {log-uniform: [1.0e-5, 4.0e-5]}
  past.K-d: {uniform: [0.5, 2.0]}
  past.params: ["${conf}/dry.yaml", "${conf}/wet.yaml"]
"""
#: Images of the page: change.tif (median, spread), past_5ka.tif (median, spread, median and
#: best member minus the present), the terrace spread plot, the best and the median member's
#: profiles, the pair matrix and the 3 scatter plots.
IMAGES = 2 + 4 + 3 + 1 + 3


@pytest.fixture(scope="module")
def plain_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("plain_ensemble")
    small_dem(folder / "dem.tif")
    (folder / "terraces.csv").write_text("name,age_ka,height_above_river_m\nyoung,5,3\n")
    (folder / "dry.yaml").write_text("p: 0.6\n")
    (folder / "wet.yaml").write_text("p: 1.2\n")
    (folder / "spec.yaml").write_text(SPEC)
    out = folder / "out"
    result = run_cli("ensemble", folder / "spec.yaml", out, "--members", "2", "--workers", "2", "--report")
    assert result.returncode == 0, result.stderr
    assert "ensemble: 4 of 4 member(s) finished; 10 summary raster(s)" in result.stderr
    return out


def members(out: Path) -> list[dict[str, str]]:
    with (out / "members.csv").open(newline="") as handle:
        return list(csv.DictReader(handle))


def test_every_raster_the_members_write_is_summarised(plain_run: Path) -> None:
    for stem in ("past_5ka", "change"):
        assert_summaries_match_members(plain_run, stem, 4)


def test_the_report_shows_every_summary_the_terrace_spread_and_the_profiles(plain_run: Path) -> None:
    out = plain_run
    text = (out / "report.html").read_text(encoding="utf-8")
    page = check_page(text, out)
    assert "${" not in text
    assert len(page.images) == IMAGES
    for heading in ("change.tif (no age), 4 members", "past_5ka.tif (no age), 4 members", "Terrace fits",
                    "Parameters against scores"):
        assert heading in page.headings
    rows = members(out)
    ranking = next(t for t in page.tables if t[0][:3] == ["rank", "member", "status"])
    params = ranking[0].index("past.params")
    for shown, row in zip(ranking[1:], rows, strict=True):    # ${conf}/dry.yaml, resolved
        assert Path(shown[params]) == (out.parent / Path(row["past.params"]).name).resolve()
    simulated = [json.loads((out / r["folder"] / "report" / "summary.json").read_text())
                 ["terraces"]["rows"][0]["simulated_m"] for r in rows]
    spread = next(t for t in page.tables if t[0][:2] == ["terrace", "age (ka)"])
    assert spread[1][0] == "young" and float(spread[1][2]) == 3.0
    assert float(spread[1][4]) == pytest.approx(float(np.median(simulated)), rel=1e-5)
    assert float(spread[1][6]) == pytest.approx(float(np.percentile(simulated, 95)), rel=1e-5)
    assert float(spread[1][10]) == pytest.approx(simulated[0], rel=1e-5)    # the best member's
    best, middle = rows[0], rows[median_position(len(rows))]
    for row in (best, middle):
        assert (out / row["folder"] / "report" / "profiles.png").read_bytes() in page.images
    linked = {p.relative_to(out.resolve()).as_posix() for p in page.links}
    assert linked == {f"{r['folder']}/report/{name}" for r in rows
                      for name in ("profiles.png", "terraces.csv")}


def test_map_frames_are_the_rasters_bounds_in_its_crs(plain_run: Path) -> None:
    path = plain_run / "summary" / "past_5ka_p50.tif"
    frame = map_frame(read_terrain(path))
    with rasterio.open(path) as src:
        bounds = src.bounds
    assert frame.extent == pytest.approx((bounds.left, bounds.right, bounds.bottom, bounds.top), abs=1e-6)
    assert frame.xlabel.startswith("easting (m)") and "EPSG:32632" in frame.xlabel
    assert frame.ylabel == "northing (m)"


def test_spec_values_resolve_references_and_paths(tmp_path: Path) -> None:
    (tmp_path / "spec.yaml").write_text("version: 1\nvars:\n  data: ../shared\n  conf: .\n"
                                        "sweep:\n  a.K: {log-uniform: [1.0e-5, 4.0e-5]}\n  a.p: [x.yaml]\n")
    (tmp_path / "x.yaml").write_text("p: 1\n")
    run = tmp_path / "out"
    values = SpecValues.of({"spec": str(tmp_path / "spec.yaml"), "vars": {"conf": str(run)}}, run)
    assert values.shown("${data}/sea.txt") == (tmp_path.parent / "shared" / "sea.txt").as_posix()
    assert values.shown("${conf}/a/b.tif") == "a/b.tif"            # inside the run folder: relative
    assert values.shown("x.yaml") == (tmp_path / "x.yaml").as_posix()
    assert values.shown("thermal,fluvial") == "thermal,fluvial" and values.shown("2e-05") == "2e-05"
    assert values.log_keys() == frozenset({"a.K"})


def test_spread_of_one_value_per_member_and_category_positions() -> None:
    values = [3.0, None, 1.0, float("nan"), 2.0, 10.0]
    spread = value_spread(values)
    known = np.array([3.0, 1.0, 2.0, 10.0])
    assert tuple(k for k in spread if k != "members") == SPREAD and spread["members"] == 4
    assert spread["p50"] == pytest.approx(np.median(known)) and spread["std"] == pytest.approx(known.std())
    assert spread["p95"] == pytest.approx(np.percentile(known, 95)) and spread["max"] == 10.0
    assert value_spread([None, float("nan")]) is None
    assert [median_position(n) for n in (1, 2, 3, 4, 5)] == [0, 0, 1, 1, 2]
    positions, categories = axis_positions(["b", "a", "b", "a", "a"])
    assert categories == ["a", "b"]
    np.testing.assert_allclose(positions, [0.7, -0.3, 1.3, 0.0, 0.3], atol=1e-12)


# ---------------------------------------------------------------------------------------------
# The page in a browser

#: Measures the page once it has loaded and writes them, as JSON, in <pre id="measured">.
MEASURE = """<script>
function measure() {
  const images = Array.from(document.images);
  const tables = Array.from(document.querySelectorAll("table"));
  const boxes = Array.from(document.querySelectorAll(".table-wrap"));
  const result = {
    viewport: window.innerWidth, scrollWidth: document.documentElement.scrollWidth,
    images: images.length, decoded: images.filter(i => i.complete && i.naturalWidth > 0).length,
    tableRight: Math.max(0, ...tables.map(t => t.getBoundingClientRect().right)),
    boxRight: Math.max(0, ...boxes.map(b => b.getBoundingClientRect().right)),
    scrolledBoxes: boxes.filter(b => b.scrollWidth > b.clientWidth).length,
    widestImage: Math.max(0, ...images.map(i => i.getBoundingClientRect().right)),
    unexpanded: document.body.innerText.includes("${"),
  };
  const pre = document.createElement("pre");
  pre.id = "measured";
  pre.textContent = JSON.stringify(result);
  document.body.appendChild(pre);
}
window.addEventListener("load", () => setTimeout(measure, 0));
</script>"""


def measured(page: Path, width: int, profile: Path) -> dict:
    """The page's measures in headless Chromium at ``width`` × 900 px."""
    probe = page.with_name(f"probe_{width}.html")
    text = page.read_text(encoding="utf-8")
    probe.write_text(text.replace("</body>", f"{MEASURE}</body>"), encoding="utf-8")
    try:
        result = subprocess.run(
            [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={profile}", f"--window-size={width},900", "--virtual-time-budget=10000",
             "--dump-dom", probe.as_uri()], capture_output=True, text=True, timeout=120)
    finally:
        probe.unlink()
    found = re.search(r'<pre id="measured">(.*?)</pre>', result.stdout)
    assert found, f"chromium gave no measures (exit {result.returncode}): {result.stderr[-500:]}"
    return json.loads(found.group(1))


@pytest.mark.skipif(not CHROMIUM.exists(), reason="no headless browser at /usr/bin/chromium "
                    "(apt-get install chromium)")
@pytest.mark.parametrize("width", [1400, 800])
def test_the_page_fits_the_window_in_chromium(plain_run: Path, tmp_path: Path, width: int) -> None:
    shown = measured(plain_run / "report.html", width, tmp_path / "profile")
    shutil.rmtree(tmp_path / "profile", ignore_errors=True)
    assert shown["viewport"] == width
    assert shown["scrollWidth"] <= width                 # nothing wider than the window
    assert shown["boxRight"] <= width and shown["widestImage"] <= width
    if width >= 1400:                                   # every table whole, none to scroll
        assert shown["tableRight"] <= width and shown["scrolledBoxes"] == 0
    assert shown["images"] == IMAGES and shown["decoded"] == IMAGES
    assert shown["unexpanded"] is False
