"""Sizes estimated before allocating (issue 45, class 3): every command that allocates from a
size the user gives (a raster's declared cells, --cell-size, --bins, --layers, --particles,
--size, --spacing, --half-width) estimates the bytes first and refuses what does not fit (exit
2, the estimate and the free memory in GiB in one sentence), and a run of more time steps than
``stepping.MAX_STEPS`` is refused before any step, naming the count."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from tests.conftest import SHARED_DATA, write_geotiff
from tests.refusals import assert_refused, cli

from unerode_cli.errors import InputError
from unerode_cli.io import rasters
from unerode_cli.run import memory
from unerode_cli.run.job import Progress
from unerode_cli.run.stepping import MAX_STEPS, StepInfo, check_step_count, step_through

UTM = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    rng = np.random.default_rng(1)
    rows, cols = np.indices((32, 32))
    z = (500.0 + 10.0 * rows + rng.random((32, 32))).astype(np.float32)
    write_geotiff(tmp_path / "in.tif", z)
    return tmp_path


def huge_tif(path: Path, size: int = 200_000) -> Path:
    """A GeoTIFF declaring ``size``² float32 cells, no block written (a few MB on disk)."""
    profile = {"driver": "GTiff", "height": size, "width": size, "count": 1, "dtype": "float32",
               "crs": "EPSG:32632", "transform": UTM, "tiled": True, "blockxsize": 512, "blockysize": 512,
               "sparse_ok": True, "compress": "deflate", "bigtiff": "yes", "nodata": -9999.0}
    with rasterio.open(path, "w", **profile):
        pass
    return path


# --- the estimator ----------------------------------------------------------------------------

def test_check_fits_names_the_estimate_and_the_free_memory(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(memory.MEMORY_ENV, "2")
    assert memory.available_bytes() <= 2 * memory.GIB
    memory.check_fits(memory.GIB, "a thing", "make it smaller")
    with pytest.raises(InputError, match=r"a thing needs about 3\.0 GiB of memory, more than the 2\.0 GiB "
                                         r"available; make it smaller\."):
        memory.check_fits(3 * memory.GIB, "a thing", "make it smaller")
    with pytest.raises(InputError, match="memory"):
        memory.check_fits(float("nan"), "a thing", "make it smaller")


def test_a_bad_memory_cap_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(memory.MEMORY_ENV, "lots")
    with pytest.raises(InputError, match=memory.MEMORY_ENV):
        memory.available_bytes()


def test_available_memory_is_positive_without_a_cap(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(memory.MEMORY_ENV, raising=False)
    assert memory.available_bytes() > 0


def test_every_raster_read_is_checked(tmp_path: Path) -> None:
    """run.memory registers its check with io.rasters: a read is refused before any cell."""
    header = rasters.read_header(huge_tif(tmp_path / "huge.tif"))
    assert header.shape == (200_000, 200_000)
    assert header.read_bytes > 40e9 * 4
    with pytest.raises(InputError, match="memory"):
        rasters.read_terrain(tmp_path / "huge.tif")
    window = rasters.read_terrain(tmp_path / "huge.tif", window=(slice(10, 20), slice(5, 35)))
    assert window.shape == (10, 30)
    assert window.transform.c == UTM.c + 5 * 30.0 and window.transform.f == UTM.f - 10 * 30.0


# --- the step limit ---------------------------------------------------------------------------

def test_check_step_count() -> None:
    assert check_step_count(1000.0, "x") == 1000
    assert check_step_count(MAX_STEPS, "x") == MAX_STEPS
    for count in (MAX_STEPS + 1, 1e305, float("inf"), float("nan")):
        with pytest.raises(InputError, match="time steps, more than the limit"):
            check_step_count(count, "x")


class _Counting:
    def __init__(self) -> None:
        self.steps = 0

    def step(self, k: int) -> StepInfo:
        self.steps += 1
        return StepInfo()

    def state(self) -> dict:
        return {}

    def restore(self, state: dict) -> None:
        pass


def test_the_stepping_loop_refuses_an_absurd_count_before_any_step() -> None:
    stepper = _Counting()
    with pytest.raises(InputError, match="10,000,001"):
        step_through(stepper, MAX_STEPS + 1, Progress(), "erode")
    assert stepper.steps == 0


@pytest.mark.parametrize("args", [
    ("erode", "in.tif", "out.tif", "--duration", "1e308"),
    ("erode", "in.tif", "out.tif", "--steps", "1000000000000000"),
    ("erode", "in.tif", "out.tif", "--dt", "1e-300", "--duration", "1000"),
    ("unerode", "in.tif", "out.tif", "--duration", "1e308"),
    ("glaciate", "in.tif", "out.tif", "--ela", "150", "--duration", "1e308"),
    ("particle-erode", "in.tif", "out.tif", "--particles", "1", "--iterations", "1000000000000000"),
], ids=["erode-duration", "erode-steps", "erode-dt", "unerode-duration", "glaciate-duration",
        "particle-erode-iterations"])
def test_absurd_step_counts_are_refused_before_any_step(folder: Path, args: tuple[str, ...]) -> None:
    said = assert_refused(folder, *args, phrase="time steps, more than the limit of 10,000,000")
    assert re.search(r"\d", said.split(":")[-1])


# --- commands that allocate from user sizes ---------------------------------------------------

@pytest.mark.parametrize("command", [("info", "huge.tif"), ("hypsometry", "huge.tif", "--csv", "h.csv"),
                                     ("preview", "huge.tif", "p.png"), ("convert", "huge.tif", "out.tif")],
                         ids=["info", "hypsometry", "preview", "convert"])
def test_a_huge_declared_raster_is_refused(tmp_path: Path, command: tuple[str, ...]) -> None:
    huge_tif(tmp_path / "huge.tif")
    said = assert_refused(tmp_path, *command, phrase="memory")
    assert "200,000 × 200,000 cells" in said and "GiB" in said


def test_convert_crop_reads_only_its_window(tmp_path: Path) -> None:
    huge_tif(tmp_path / "huge.tif")
    code, stderr = cli(tmp_path, "convert", "huge.tif", "out.tif", "--crop", "500000,4999000,501000,5000000")
    assert code == 0, stderr
    with rasterio.open(tmp_path / "out.tif") as src:
        assert (src.height, src.width) == (33, 33)


@pytest.mark.parametrize("args, phrase", [
    (("convert", "in.tif", "out.tif", "--cell-size", "0.001"), "memory"),
    (("convert", "in.tif", "out.tif", "--cell-size", "1e-300"), "cell size"),
    (("hypsometry", "in.tif", "--bins", "100000000000", "--csv", "h.csv"), "memory"),
    (("glaciate", "in.tif", "out.tif", "--ela", "150", "--duration", "20", "--layers", "100000000"),
     "memory"),
    (("particle-erode", "in.tif", "out.tif", "--particles", "1000000000000000", "--iterations", "1"),
     "memory"),
    (("landforms", "in.tif", "--out", "lf", "--spacing", "1e-9"), "--spacing"),
    (("landforms", "in.tif", "--out", "lf", "--half-width", "1e300"), "memory"),
], ids=["convert-cell-size", "convert-cell-size-uncountable", "hypsometry-bins", "glaciate-layers",
        "particle-erode-particles", "landforms-spacing", "landforms-half-width"])
def test_absurd_sizes_are_refused(folder: Path, args: tuple[str, ...], phrase: str) -> None:
    assert_refused(folder, *args, phrase=phrase)


def test_synth_at_its_maximum_size_fits_or_is_refused(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(memory.MEMORY_ENV, "4")
    said = assert_refused(tmp_path, "synth", "out.tif", "--size", "16384", phrase="memory")
    assert "16,384 × 16,384" in said and "4.0 GiB available" in said


def test_ordinary_sizes_still_run(folder: Path) -> None:
    code, stderr = cli(folder, "convert", "in.tif", "out.tif", "--cell-size", "15")
    assert code == 0, stderr
    code, stderr = cli(folder, "hypsometry", "in.tif", "--bins", "20", "--csv", "h.csv")
    assert code == 0, stderr


# --- the commands that hold grids while they step: their own estimate before any cell --------

@pytest.mark.parametrize("command", [
    ("flow", "big.tif", "out.tif"),
    ("erode", "big.tif", "out.tif", "--steps", "1"),
    ("unerode", "big.tif", "out.tif", "--steps", "1"),
    ("climate-run", "big.tif", "out.tif", "--chronology", SHARED_DATA / "lr04" / "LR04stack.txt",
     "--from", "0", "--to", "10", "--dt", "1000"),
], ids=["flow", "erode", "unerode", "climate-run"])
def test_a_run_that_would_not_fit_is_refused_with_its_estimate(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, command: tuple[str, ...]) -> None:
    """A 20,000² raster is read in 3.0 GiB: under a 10 GiB cap the read fits, the command's
    run (BASE_BYTES + cells × its bytes per cell) does not, and says so before reading."""
    huge_tif(tmp_path / "big.tif", 20_000)
    monkeypatch.setenv(memory.MEMORY_ENV, "10")
    said = assert_refused(tmp_path, *command, phrase="memory")
    name = command[0]
    expected = (memory.BASE_BYTES + 20_000**2 * memory.COMMAND_BYTES_PER_CELL[name]) / memory.GIB
    assert f"{name} on" in said and "20,000 × 20,000 cells" in said
    needed = float(re.search(r"needs about ([\d,.]+) GiB", said).group(1).replace(",", ""))
    assert needed == pytest.approx(expected, abs=0.06)
    available = float(re.search(r"the ([\d,.]+) GiB available", said).group(1).replace(",", ""))
    assert 0.0 < available <= 10.0


def test_the_implicit_step_takes_its_lean_layout_where_the_ordered_one_would_not_fit(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from unerode_cli.run.registry import implicit_layout

    monkeypatch.setenv(memory.MEMORY_ENV, "1000")
    assert implicit_layout(4096 * 4096) == "ordered" or memory.available_bytes() < 64 * 4096**2
    # under a cap, what the process already holds counts against it
    monkeypatch.setenv(memory.MEMORY_ENV, "0.01")
    assert memory.headroom_bytes() < 0.0
    assert implicit_layout(64 * 64) == "lean"
