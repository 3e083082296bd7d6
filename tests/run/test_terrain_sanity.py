"""A DEM that cannot be metres of a real terrain is refused before an erosion run, unless
``--force`` (run/terrain_sanity.py). The reference is the Earth itself: the real DEMs of
``../shared/data`` (Alps, Ötztal, Patagonia, Big Tujunga, Mandakini) all pass, and each of them
in millimetres (× 1000) is refused."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from tests.conftest import SAMPLE_DEMS, SHARED_DATA, write_geotiff
from tests.refusals import assert_refused, cli

from unerode_cli.io.rasters import read_terrain
from unerode_cli.run.terrain_sanity import HIGHEST_M, LOWEST_M, implausible

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
    millimetres = dataclasses.replace(terrain, elevation=terrain.elevation * 1000.0)
    assert "beyond the Earth's" in implausible(millimetres)


def test_the_synthetic_samples_pass() -> None:
    for path in sorted(SAMPLE_DEMS.glob("*.tif")):
        assert implausible(read_terrain(path)) == "", path


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


def test_force_runs_it_as_it_is(millimetres: Path) -> None:
    code, stderr = cli(millimetres, "erode", "mm.tif", "out.tif", "--duration", "1000", "--force", "-q")
    assert code == 0, stderr
    assert (millimetres / "out.tif").exists()
