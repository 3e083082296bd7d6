"""Bad input: exit code 2, one sentence on stderr, no traceback, no output left behind."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from affine import Affine
from tests.conftest import run_cli, write_geotiff


def assert_refused(result, output: Path | None = None, mentions: str = "") -> None:
    assert result.returncode == 2, result.stderr
    lines = [line for line in result.stderr.strip().splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ")
    assert "Traceback" not in result.stderr
    assert mentions.lower() in lines[0].lower()
    if output is not None:
        assert not output.exists()
        assert not list(output.parent.glob(f".{output.stem}.*"))  # no temporary leftovers


def test_missing_file(tmp_path: Path) -> None:
    out = tmp_path / "out.tif"
    assert_refused(run_cli("convert", tmp_path / "nope.tif", out), out, "does not exist")


def test_not_a_raster(tmp_path: Path) -> None:
    text = tmp_path / "notes.tif"
    text.write_text("this is not a raster\n")
    out = tmp_path / "out.tif"
    assert_refused(run_cli("convert", text, out), out, "not a raster")


def test_existing_output_without_overwrite(tmp_path: Path, small_dem: Path) -> None:
    out = tmp_path / "out.tif"
    out.write_bytes(b"precious")
    assert_refused(run_cli("convert", small_dem, out), None, "--overwrite")
    assert out.read_bytes() == b"precious"


def test_output_is_input_even_with_overwrite(small_dem: Path) -> None:
    before = small_dem.read_bytes()
    assert_refused(run_cli("convert", small_dem, small_dem, "--overwrite"), None, "input")
    assert small_dem.read_bytes() == before


def test_rotated_transform(tmp_path: Path) -> None:
    dem = write_geotiff(tmp_path / "rot.tif", np.ones((5, 5), np.float32),
                        transform=Affine(30.0, 5.0, 0.0, 5.0, -30.0, 0.0))
    out = tmp_path / "out.exr"
    assert_refused(run_cli("convert", dem, out), out, "rotated")


def test_exr_without_float_channel(tmp_path: Path) -> None:
    exr = tmp_path / "ids.exr"
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION},
                 {"id": np.zeros((4, 4), np.uint32)}).write(str(exr))
    out = tmp_path / "out.tif"
    assert_refused(run_cli("convert", exr, out), out, "float channel")


def test_bad_band(small_dem: Path, tmp_path: Path) -> None:
    out = tmp_path / "out.tif"
    assert_refused(run_cli("convert", small_dem, out, "--band", 3), out, "band 3")


@pytest.mark.parametrize("args", [["--co", "NOEQUALS"], ["--z-scale", "-1"]])
def test_bad_options(small_dem: Path, tmp_path: Path, args: list[str]) -> None:
    out = tmp_path / "out.tif"
    assert_refused(run_cli("convert", small_dem, out, *args), out)


def test_runtime_failure_is_exit_1_without_traceback(tmp_path: Path, small_dem: Path) -> None:
    """An unexpected failure (here: an unknown GDAL creation option value) is not exit 2."""
    out = tmp_path / "out.tif"
    result = run_cli("convert", small_dem, out, "--co", "BLOCKXSIZE=7")
    assert result.returncode in (1, 2)
    assert "Traceback" not in result.stderr
    assert not out.exists()
