"""--crs, --cell-size (convert: --input-cell-size) and --nodata as a user gives them: a CRS-less
EXR gets the CRS and grid asked for in every output, a declared nodata value is nodata, and
contradicting or unparsable values are refused with exit code 2 in one sentence."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
import rasterio
from affine import Affine
from pyproj import CRS
from typer.testing import CliRunner

from unerode_cli.cli.app import app

ROWS, COLS = 12, 10


def _invoke(folder: Path, *args: str):
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        return CliRunner().invoke(app, list(args))
    finally:
        os.chdir(cwd)


def _bare_exr(path: Path) -> np.ndarray:
    """An EXR as Houdini writes it: one float channel, no georeferencing (a tilted surface, m)."""
    r, c = np.indices((ROWS, COLS))
    z = (100.0 + 2.0 * (ROWS - r) + 0.5 * np.sin(c)).astype(np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(header, {"Y": z}).write(str(path))
    return z


def test_a_crs_and_cell_size_given_to_a_bare_exr_reach_the_outputs(tmp_path: Path) -> None:
    z = _bare_exr(tmp_path / "h.exr")
    expected = Affine(30.0, 0.0, 0.0, 0.0, -30.0, ROWS * 30.0)
    converted = _invoke(tmp_path, "convert", "h.exr", "c.tif", "--crs", "EPSG:32632",
                        "--input-cell-size", "30")
    assert converted.exit_code == 0, converted.output
    eroded = _invoke(tmp_path, "erode", "h.exr", "e.tif", "--crs", "EPSG:32632", "--cell-size", "30",
                     "--dt", "100", "--steps", "1")
    assert eroded.exit_code == 0, eroded.output
    for name in ("c.tif", "e.tif"):
        with rasterio.open(tmp_path / name) as src:
            assert CRS.from_user_input(src.crs.to_wkt()) == CRS.from_epsg(32632)
            assert src.transform.almost_equals(expected)
    with rasterio.open(tmp_path / "c.tif") as src:
        np.testing.assert_array_equal(src.read(1), z)


def test_nodata_declared_for_an_input_is_nodata_in_the_output(tmp_path: Path) -> None:
    z = _bare_exr(tmp_path / "h.exr")
    value = float(z[3, 4])
    result = _invoke(tmp_path, "convert", "h.exr", "c.tif", "--nodata", repr(value), "--input-cell-size", "5")
    assert result.exit_code == 0, result.output
    with rasterio.open(tmp_path / "c.tif") as src:
        assert src.nodata == value
        masked = src.read(1, masked=True)
    assert int(masked.mask.sum()) == int((z == np.float32(value)).sum()) >= 1


@pytest.mark.parametrize(("args", "phrase"), [
    (("--crs", "EPSG:123456789"), "pyproj"),
    (("--cell-size", "0"), "> 0"),
    (("--cell-size", "-1"), "> 0"),
    (("--crs", "EPSG:4326"), "already has a CRS"),
    (("--cell-size", "10"), "already has a geotransform"),
])
def test_refusals_are_one_sentence_and_exit_2(tmp_path: Path, args: tuple[str, ...], phrase: str) -> None:
    with rasterio.open(tmp_path / "in.tif", "w", driver="GTiff", height=ROWS, width=COLS, count=1,
                       dtype="float32", crs="EPSG:32632",
                       transform=Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)) as dst:
        dst.write(np.full((ROWS, COLS), 100.0, dtype=np.float32), 1)
    result = _invoke(tmp_path, "info", "in.tif", *args)
    assert result.exit_code == 2
    message = result.stderr if hasattr(result, "stderr") else result.output
    lines = [line for line in message.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].rstrip().endswith(".") and phrase in lines[0], message


def test_the_same_crs_as_the_input_is_accepted(tmp_path: Path) -> None:
    with rasterio.open(tmp_path / "in.tif", "w", driver="GTiff", height=ROWS, width=COLS, count=1,
                       dtype="float32", crs="EPSG:32632",
                       transform=Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)) as dst:
        dst.write(np.full((ROWS, COLS), 100.0, dtype=np.float32), 1)
    assert _invoke(tmp_path, "info", "in.tif", "--crs", "EPSG:32632", "--cell-size", "30").exit_code == 0
