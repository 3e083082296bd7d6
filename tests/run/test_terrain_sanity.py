"""A DEM that cannot be metres of a real terrain (elevations beyond the Earth's, or more than a
quarter of its cells steeper than 70°) is refused before an erosion run, unless ``--force``
(run/terrain_sanity.py). The reference is the Earth itself: the real DEMs of ``../shared/data``
(Alps, Ötztal, Patagonia, Big Tujunga, Mandakini) all pass with at most 0.85 % of their cells
steeper than 70°, and each of them in millimetres (× 1000) is refused, 98 % of its cells or more
steeper than 70°."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from affine import Affine
from tests.conftest import SAMPLE_DEMS, SHARED_DATA, write_geotiff
from tests.refusals import assert_refused, cli

from unerode_cli.io.rasters import read_terrain
from unerode_cli.run.terrain_sanity import HIGHEST_M, LOWEST_M, cliff_share, implausible

REAL_DEMS = ["alps_grindelwald/dem.tif", "alps_oetztal/srtm_oetztal.tif",
             "patagonia_exploradores/AST_L1A_00303182012144228_Z.tif",
             "sangabriel_bigtujunga/bigtujunga.tif", "himalaya_mandakini/Mandakini.bil"]


@pytest.mark.parametrize("name", REAL_DEMS)
def test_real_dems_pass_and_the_same_in_millimetres_do_not(name: str) -> None:
    path = SHARED_DATA / "dem" / name
    if not path.exists():
        pytest.skip(f"{path} is missing")
    terrain = read_terrain(path)
    assert implausible(terrain) == ""
    assert cliff_share(terrain.elevation, terrain.dx, terrain.dy) <= 0.0085      # measured 0–0.84 %
    millimetres = dataclasses.replace(terrain, elevation=terrain.elevation * 1000.0)
    assert "beyond the Earth's" in implausible(millimetres)
    assert cliff_share(millimetres.elevation, terrain.dx, terrain.dy) >= 0.98    # measured 99.9–100 %


def test_the_synthetic_samples_pass() -> None:
    shares = {}
    for path in sorted([*SAMPLE_DEMS.glob("*.tif"), *SAMPLE_DEMS.glob("*.exr")]):
        terrain = read_terrain(path)
        assert implausible(terrain) == "", path
        shares[path.stem] = cliff_share(terrain.elevation, terrain.dx, terrain.dy)
    # measured: coast 17.65 %, valley 12.01 % (synth at 2000 m of relief), eroded and fractal 0
    assert shares == pytest.approx({"coast_wgs84_30m": 0.1765, "eroded_utm32n_30m": 0.0,
                                    "fractal_30m": 0.0, "valley_utm32n_30m": 0.1201}, abs=0.001)


def tilted(shape: tuple[int, int], degrees: np.ndarray, dy: float) -> np.ndarray:
    """Elevations (m) of rows falling southwards at ``degrees`` (one angle per row) on rows
    ``dy`` metres apart."""
    drops = np.tan(np.radians(degrees)) * dy
    z = 3000.0 - np.concatenate([[0.0], np.cumsum(0.5 * (drops[1:] + drops[:-1]))])
    return np.repeat(z[:, None], shape[1], axis=1)


@pytest.mark.parametrize("steep_rows, refused", [(24, False), (26, True)])
def test_a_quarter_of_cliffs_is_the_limit(steep_rows: int, refused: bool) -> None:
    terrain = read_terrain(SAMPLE_DEMS / "eroded_utm32n_30m.tif")
    shape = (100, 8)
    degrees = np.where(np.arange(shape[0]) < steep_rows, 75.0, 30.0)
    z = tilted(shape, degrees, terrain.dy)
    steep = dataclasses.replace(terrain, elevation=z, transform=Affine(30.0, 0, 0, 0, -30.0, 0))
    # the rows next to the change of slope are between the two: 24 or 25 of 100 rows steeper than 70°
    assert cliff_share(z, terrain.dx, terrain.dy) == pytest.approx(steep_rows / 100.0, abs=0.011)
    said = implausible(steep)
    assert bool(said) == refused
    if refused:
        assert "steeper than 70°" in said and "30 × 30 m" in said


def test_nodata_cells_and_their_neighbours_have_no_slope() -> None:
    z = tilted((20, 20), np.full(20, 80.0), 30.0)
    z[:, :12] = np.nan                # 8 columns valid, the first of them beside nodata
    z[5, 15] = np.nan
    # every defined slope is 80°: one share, whatever the holes
    assert cliff_share(z, 30.0, 30.0) == 1.0
    flat = np.where(np.isfinite(z), 100.0, np.nan)
    assert cliff_share(flat, 30.0, 30.0) == 0.0
    assert cliff_share(np.full((1, 9), 5.0), 30.0, 30.0) == 0.0    # no slope on a single row


def test_geographic_cells_are_measured_in_metres(tmp_path: Path) -> None:
    # 1 arc-second cells at 46° N: 21.52 m east-west, 30.87 m north-south; slopes of 60° there
    # would be over 89.99° on cells taken as 1/3600 "metres"
    second = 1.0 / 3600.0
    transform = Affine(second, 0.0, 8.0, 0.0, -second, 46.01)
    z = tilted((64, 64), np.full(64, 60.0), 30.87).astype(np.float32)
    terrain = read_terrain(write_geotiff(tmp_path / "g.tif", z, transform, crs="EPSG:4326"))
    assert (terrain.dx, terrain.dy) == pytest.approx((21.52, 30.87), abs=0.01)
    assert cliff_share(terrain.elevation, terrain.dx, terrain.dy) == 0.0
    assert implausible(terrain) == ""
    assert cliff_share(terrain.elevation, second, second) == 1.0


@pytest.mark.parametrize("low, high, refused", [(LOWEST_M, HIGHEST_M, False), (LOWEST_M - 1, 0.0, True),
                                                (0.0, HIGHEST_M + 1, True)])
def test_the_range_is_the_earths(low: float, high: float, refused: bool) -> None:
    terrain = read_terrain(SAMPLE_DEMS / "eroded_utm32n_30m.tif")
    z = np.full(terrain.shape, 0.5 * (low + high))
    z[0, 0], z[-1, -1] = low, high
    assert bool(implausible(dataclasses.replace(terrain, elevation=z))) == refused


@pytest.fixture
def millimetres(tmp_path: Path) -> Path:
    terrain = read_terrain(SAMPLE_DEMS / "eroded_utm32n_30m.tif")
    z = (terrain.elevation[:48, :48] * 1000.0).astype(np.float32)
    write_geotiff(tmp_path / "mm.tif", z)
    return tmp_path


@pytest.fixture
def cliffs(tmp_path: Path) -> Path:
    """The sample's first 48 × 48 cells, their height above the lowest × 10 (0–4300 m, within the
    Earth's range): 93.7 % of the cells steeper than 70°."""
    terrain = read_terrain(SAMPLE_DEMS / "eroded_utm32n_30m.tif")
    z = terrain.elevation[:48, :48]
    z = (z - np.nanmin(z)) * 10.0
    assert cliff_share(z, terrain.dx, terrain.dy) == pytest.approx(0.937, abs=0.001)
    assert LOWEST_M < np.nanmin(z) and np.nanmax(z) < HIGHEST_M
    write_geotiff(tmp_path / "cliffs.tif", z.astype(np.float32))
    return tmp_path


@pytest.mark.parametrize("args", [
    ("erode", "mm.tif", "out.tif", "--duration", "1000"),
    ("glaciate", "mm.tif", "out.tif", "--duration", "100", "--ela", "1500"),
    ("climate-run", "mm.tif", "out.tif", "--chronology", str(SHARED_DATA / "lr04" / "LR04stack.txt"),
     "--to", "2"),
])
def test_a_dem_in_millimetres_is_refused_naming_convert(millimetres: Path, args: tuple[str, ...]) -> None:
    if "climate-run" in args and not (SHARED_DATA / "lr04" / "LR04stack.txt").exists():
        pytest.skip("LR04 is missing")
    sentence = assert_refused(millimetres, *args, phrase="does not look like elevations in metres")
    assert "--z-scale" in sentence and "--force" in sentence


@pytest.mark.parametrize("args", [
    ("erode", "cliffs.tif", "out.tif", "--duration", "1000"),
    ("unerode", "cliffs.tif", "out.tif", "--duration", "1000"),
    ("glaciate", "cliffs.tif", "out.tif", "--duration", "100", "--ela", "1500"),
])
def test_a_dem_of_cliffs_is_refused_naming_convert(cliffs: Path, args: tuple[str, ...]) -> None:
    sentence = assert_refused(cliffs, *args, phrase="does not look like elevations in metres", seconds=20.0)
    assert "steeper than 70°" in sentence and "--z-scale" in sentence and "--force" in sentence


def test_force_runs_cliffs_as_they_are(cliffs: Path) -> None:
    code, stderr = cli(cliffs, "erode", "cliffs.tif", "out.tif", "--duration", "1000", "--force", "-q")
    assert code == 0, stderr
    assert (cliffs / "out.tif").exists()


def test_force_runs_it_as_it_is(millimetres: Path) -> None:
    code, stderr = cli(millimetres, "erode", "mm.tif", "out.tif", "--duration", "1000", "--force", "-q")
    assert code == 0, stderr
    assert (millimetres / "out.tif").exists()
