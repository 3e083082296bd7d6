"""The outlets of a nested run given none: the fine window drains where its coarse run's water
leaves it (``run.nesting.crossing_outlets``), not through every edge; ``--outlets`` overrides
that. On Big Tujunga (the case of bench/nested_scales.py) the nested window then beats the lone
window by at least 2× in RMSE against a 30 m run of the whole map."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from affine import Affine
from tests.conftest import SHARED_DATA, run_cli, write_geotiff

from unerode_cli.io.coarse_runs import read_coarse_run
from unerode_cli.io.rasters import read_terrain
from unerode_cli.run.nesting import crossing_outlets

LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"
pytestmark = pytest.mark.skipif(not LR04.is_file(), reason="needs ../shared/data")
RUN = ("--chronology", LR04, "--from", 0, "--to", 2, "--dt", 1000, "--process", "fluvial", "--K", 2e-5,
       "--snapshots", 1)
#: The coarse map: 30 × 40 cells of 90 m, its top-left corner at (0, 2700) m.
COARSE_SHAPE, COARSE_CELL = (30, 40), 90.0
#: The window: coarse rows 8–21 and columns 10–29, as 42 × 60 cells of 30 m.
WINDOW_ROWS, WINDOW_COLS = (8, 22), (10, 30)
FINE_CELL = 30.0
#: The valley's axis (m): the centre of coarse row 15, and of fine row 22 of the window.
AXIS_Y = 1305.0


def _valley(transform: Affine, shape: tuple[int, int]) -> np.ndarray:
    """A valley along y = AXIS_Y falling west 5 % and with 20 % side slopes, at the cell centres
    of a grid (m, float32)."""
    rows, cols = np.mgrid[0:shape[0], 0:shape[1]] + 0.5
    x, y = transform @ (cols, rows)
    return (300.0 + 0.05 * x + 0.2 * np.abs(y - AXIS_Y)).astype(np.float32)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The coarse run of the valley (2 ka, --write-fluxes) and the window's DEM."""
    folder = tmp_path_factory.mktemp("valley")
    coarse = Affine(COARSE_CELL, 0.0, 0.0, 0.0, -COARSE_CELL, COARSE_SHAPE[0] * COARSE_CELL)
    write_geotiff(folder / "coarse.tif", _valley(coarse, COARSE_SHAPE), coarse)
    x0, y0 = coarse @ (WINDOW_COLS[0], WINDOW_ROWS[0])
    fine = Affine(FINE_CELL, 0.0, x0, 0.0, -FINE_CELL, y0)
    shape = (3 * (WINDOW_ROWS[1] - WINDOW_ROWS[0]), 3 * (WINDOW_COLS[1] - WINDOW_COLS[0]))
    write_geotiff(folder / "window.tif", _valley(fine, shape), fine)
    result = run_cli("climate-run", folder / "coarse.tif", folder / "coarse_past.tif", *RUN, "--write-fluxes")
    assert result.returncode == 0, result.stderr
    return folder


def test_the_window_drains_where_the_coarse_water_leaves_it(runs: Path) -> None:
    fine = read_terrain(runs / "window.tif")
    outlets = crossing_outlets(read_coarse_run(runs / "coarse_past.tif"), fine, (0.0, 2.0))
    ny, nx = fine.shape
    # every drop leaves by the west edge, down the valley; the east edge takes the valley's
    # inflow, and the sides drain into the window (its slopes face the axis)
    assert outlets[:, 0].all()
    assert not outlets[:, -1].any()
    # the north and south edges only where the west edge's corner cells widen (one fine cell:
    # half a 90 m face on 30 m cells)
    assert not outlets[[0, -1], 2:].any()
    assert not outlets[1:-1, 1:].any()
    assert int(outlets.sum()) == ny + 2


def _edge_cells(said: str) -> int:
    """The number of boundary nodes that follow the coarse surface, from the run's summary."""
    found = re.search(r"(\d+) edge cells follow the coarse run's surface", said)
    assert found, said
    return int(found.group(1))


def test_a_nested_run_takes_those_outlets_unless_given_its_own(runs: Path) -> None:
    fine = read_terrain(runs / "window.tif")
    ny, nx = fine.shape
    auto = run_cli("climate-run", runs / "window.tif", runs / "auto.tif", *RUN, "--inflow-from",
                   runs / "coarse_past.tif")
    assert auto.returncode == 0, auto.stderr
    assert _edge_cells(auto.stdout + auto.stderr) == ny + 2
    given = run_cli("climate-run", runs / "window.tif", runs / "all.tif", *RUN, "--inflow-from",
                    runs / "coarse_past.tif", "--outlets", "all")
    assert given.returncode == 0, given.stderr
    assert _edge_cells(given.stdout + given.stderr) == 2 * (ny + nx) - 4


# --- Big Tujunga: the case of bench/nested_scales.py ---------------------------------------------

TUJUNGA = SHARED_DATA / "dem" / "sangabriel_bigtujunga" / "bigtujunga.tif"
BOX = "388000,3792000,400000,3802000"
WINDOW = (50, 80, 20, 50)          # rows, columns of the 90 m grid
BENCH_RUN = ("--chronology", LR04, "--from", 0, "--to", 6, "--dt", 1000, "--process", "fluvial",
             "--K", 2e-5, "-q")


def _rmse_against_reference(past: Path, window: Path, reference: Path) -> float:
    """RMSE (m) of a window's past surface against the same cells of the reference run, the
    window's 3-cell boundary ring left out."""
    ref = read_terrain(reference)
    win = read_terrain(window)
    col, row = (int(v) for v in ~ref.transform @ (win.transform.c + 15.0, win.transform.f - 15.0))
    ny, nx = win.shape
    error = (read_terrain(past).elevation - ref.elevation[row:row + ny, col:col + nx])[3:-3, 3:-3]
    return float(np.sqrt(np.mean(error**2)))


@pytest.mark.slow
@pytest.mark.skipif(not TUJUNGA.is_file(), reason="needs ../shared/data")
def test_big_tujunga_nested_with_its_own_outlets_beats_the_lone_window_twice(tmp_path: Path) -> None:
    """A 2.7 km window of the main stem (30 m), unerosion back 6 ka: nested in a 90 m run of the
    12 × 10 km map with the outlets it takes (none given), against alone with outlets on the S
    and W edges the main stem and its slopes leave by; both against a 30 m run of the map."""
    def cli(*args: object) -> None:
        result = run_cli(*args)
        assert result.returncode == 0, result.stderr

    cli("convert", TUJUNGA, tmp_path / "coarse90.tif", "--crop", BOX, "--cell-size", 90)
    cli("convert", TUJUNGA, tmp_path / "ref30.tif", "--crop", BOX)
    coarse = read_terrain(tmp_path / "coarse90.tif")
    r0, r1, c0, c1 = WINDOW
    x0, y0 = coarse.transform @ (c0, r1)
    x1, y1 = coarse.transform @ (c1, r0)
    window = tmp_path / "window30.tif"
    cli("convert", TUJUNGA, window, "--crop", f"{x0},{y0},{x1},{y1}")
    cli("climate-run", tmp_path / "coarse90.tif", tmp_path / "coarse_past.tif", *BENCH_RUN, "--write-fluxes")
    cli("climate-run", tmp_path / "ref30.tif", tmp_path / "ref_past.tif", *BENCH_RUN)
    cli("climate-run", window, tmp_path / "nested.tif", *BENCH_RUN, "--inflow-from",
        tmp_path / "coarse_past.tif")
    cli("climate-run", window, tmp_path / "alone.tif", *BENCH_RUN, "--outlets", "S,W")
    reference = tmp_path / "ref_past.tif"
    nested = _rmse_against_reference(tmp_path / "nested.tif", window, reference)
    alone = _rmse_against_reference(tmp_path / "alone.tif", window, reference)
    assert alone >= 2.0 * nested, (nested, alone)
