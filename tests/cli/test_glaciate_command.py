"""`glaciate` as a user runs it: a valley glacier eroding its bed, the ISMIP-HOM diagnostic
solve, the ice-volume series, side outputs and bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from tests.cli.test_bad_input import assert_refused
from tests.conftest import run_cli, write_geotiff
from tests.glacier.test_glacier_ismip import DATA, FULL_STOKES, HIGHER_ORDER, X_HAT, _model_profiles

from unerode_cli.glacier import blatter
from unerode_cli.grid import Grid
from unerode_cli.io.rasters import read_terrain

DX = 100.0
ELA = 3000.0


def _transform(dx: float) -> Affine:
    return Affine(dx, 0.0, 500000.0, 0.0, -dx, 5000000.0)


def valley(ny: int = 40, nx: int = 60, dx: float = DX, base: float = 2300.0, head: float = 1500.0,
           scale: float = 1200.0) -> np.ndarray:
    """A V-shaped valley (walls of slope 0.25) draining east from a head above the ELA, floor
    base + head·exp(−x/scale) (m); by default its lower half stays below the ELA, so the ice
    there is a tongue fed from the head."""
    y, x = np.mgrid[0:ny, 0:nx] * dx
    return base + head * np.exp(-x / scale) + 0.25 * np.abs(y - (ny - 1) * dx / 2)


@pytest.fixture
def valley_dem(tmp_path: Path) -> Path:
    return write_geotiff(tmp_path / "valley.tif", valley().astype(np.float32), _transform(DX))


def _power_law_exponent(section: np.ndarray, half_width: int) -> float:
    """b of z − z_floor ∝ |y − y_c|^b fitted over ``half_width`` cells each side of the centre:
    1 for a V, 2 for a parabolic U (a classic U-shape index of glaciated valleys)."""
    centre = (section.size - 1) / 2
    distance = np.abs(np.arange(section.size) - centre)
    floor = section[distance < 1].mean()
    fit = (distance > 1) & (distance <= half_width)
    return float(np.polyfit(np.log(distance[fit]), np.log(np.maximum(section[fit] - floor, 1e-3)), 1)[0])


def _ice_volume(path: Path) -> float:
    ice = read_terrain(path)
    return float(np.nansum(ice.elevation)) * ice.dx * ice.dy


# --- runs ---------------------------------------------------------------------------------------

def test_sia_valley_glacier_deepens_its_floor_more_than_its_sides(tmp_path: Path, valley_dem: Path) -> None:
    out, ice = tmp_path / "bed.tif", tmp_path / "ice.tif"
    result = run_cli("glaciate", valley_dem, out, "--ela", ELA, "--duration", 2000, "--dt", 20,
                     "--iceflow", "sia", "--sliding-C", 1e5, "--k-e", 1e-4, "--k-q", 0, "--ice", ice,
                     "--sliding", tmp_path / "ub.tif", "--velocity", tmp_path / "v.tif",
                     "--snapshot-every", 1000, "--dtype", "float64", "--preview", tmp_path / "bed.png",
                     # 001 Eq. 2 as printed: the valley's head is a 51° wall that feeds the glacier
                     "--snow-slope-min", 90, "--snow-slope-max", 90)
    assert result.returncode == 0, result.stderr
    before, after = read_terrain(valley_dem).elevation, read_terrain(out).elevation
    lowering = before - after
    assert lowering.min() >= 0.0
    h = read_terrain(ice).elevation
    tongue = [c for c in range(h.shape[1]) if before[19, c] < ELA - 200.0 and h[19, c] > 50.0]
    assert len(tongue) >= 5  # the ablation-zone tongue, 200 m or more below the ELA
    floor = lowering[19:21, tongue].mean()
    sides = lowering[[12, 27], :][:, tongue].mean()  # 7.5 cells (750 m) from the valley axis
    assert floor > 1.3 * sides and floor > 5.0  # measured: 7.4 m under the tongue's axis, 4.6 m beside
    # the JSON sidecar's ice-volume series: from 0 at t = 0 to the final ice raster's volume
    series = json.loads((tmp_path / "bed.tif.json").read_text())["statistics"]["ice_volume_series"]
    times, volumes = series["time_years"], series["ice_volume_m3"]
    assert times[0] == 0.0 and times[-1] == 2000.0 and np.all(np.diff(times) > 0)
    assert volumes[0] == 0.0 and np.all(np.diff(volumes[:20]) > 0)  # growing from nothing
    assert volumes[-1] == pytest.approx(_ice_volume(ice), rel=1e-9)
    assert [p.name for p in sorted(tmp_path.glob("ice_0*.tif"))] == ["ice_001.tif", "ice_002.tif"]
    assert _ice_volume(tmp_path / "ice_002.tif") == pytest.approx(volumes[-1], rel=1e-9)
    with rasterio.open(tmp_path / "v.tif") as src:
        assert src.count == 2 and src.shape == h.shape
        speed = np.hypot(*src.read().astype(float))
    assert speed.max() > 10.0 and (speed[h == 0] == 0).all()
    assert (tmp_path / "bed.png").stat().st_size > 10_000


def test_blatter_run_writes_the_velocities_of_the_final_geometry(tmp_path: Path) -> None:
    """The default ice flow (Blatter–Pattyn) on a small valley, frozen bed: surface velocities,
    no sliding, and the re-solve statistics in the sidecar."""
    dem = write_geotiff(tmp_path / "v.tif", valley(12, 18, 300.0, base=2400.0, head=900.0, scale=2000.0
                                                   ).astype(np.float32), _transform(300.0))
    out, velocity, sliding = tmp_path / "bed.tif", tmp_path / "v_s.tif", tmp_path / "u_b.tif"
    result = run_cli("glaciate", dem, out, "--ela", ELA, "--duration", 60, "--dt", 30, "--layers", 5,
                     "--sliding-C", "inf", "--velocity", velocity, "--sliding", sliding,
                     "--no-hillslope", "--no-debris", "--no-fluvial")
    assert result.returncode == 0, result.stderr
    np.testing.assert_array_equal(read_terrain(out).elevation, read_terrain(dem).elevation)  # no sliding
    assert read_terrain(sliding).elevation.max() == 0.0
    with rasterio.open(velocity) as src:
        assert src.descriptions[0].startswith("surface velocity vx")
        assert np.hypot(*src.read().astype(float)).max() > 1.0
    stats = json.loads((tmp_path / "bed.tif.json").read_text())["statistics"]
    assert stats["steps"] == 4 and stats["velocity_resolves"] >= 1  # 10, 15 (ramp), 30, 60 y
    assert stats["final_flow"]["residual"] <= 0.03 and stats["unconverged_solves"] == 0


@pytest.mark.parametrize(("cfl", "noted"), [(None, True), (0.05, False)])
def test_ice_over_a_kilometre_thick_gets_a_note_on_the_cfl_number(tmp_path: Path, cfl, noted) -> None:
    """At 001's c = 0.1 one-cell grooves under ice this thick grew into divergences (the Fig. 6 ice
    sheet, the Grindelwald cycle): the run says so once, and says nothing at 0.05."""
    bed = valley(10, 12, 250.0, base=1000.0, head=200.0, scale=2000.0)
    dem = write_geotiff(tmp_path / "bed.tif", bed.astype(np.float32), _transform(250.0))
    ice = write_geotiff(tmp_path / "ice.tif", np.full(bed.shape, 1100.0, np.float32), _transform(250.0))
    options = () if cfl is None else ("--transport-cfl", cfl)
    result = run_cli("glaciate", dem, tmp_path / "out.tif", "--ela", 1500, "--duration", 20, "--dt", 10,
                     "--layers", 5, "--ice-thickness", ice, "--no-hillslope", "--no-debris", "--no-fluvial",
                     *options)
    assert result.returncode == 0, result.stderr
    assert ("--transport-cfl 0.1 can grow one-cell grooves" in result.stderr) is noted, result.stderr
    assert result.stderr.count("m thick at t = ") == int(noted)


@pytest.mark.slow
def test_the_transport_cfl_reaches_the_multiscale_step(tmp_path: Path) -> None:
    """--transport-cfl is recorded in the sidecar and changes the multi-scale steps where the ice
    moves (``coupled._multiscale_cfl``)."""
    dem = write_geotiff(tmp_path / "v.tif", valley(12, 18, 300.0, base=2400.0, head=900.0, scale=2000.0
                                                   ).astype(np.float32), _transform(300.0))
    volumes = {}
    for c in (0.1, 0.05):
        out = tmp_path / f"bed_{c}.tif"
        result = run_cli("glaciate", dem, out, "--ela", ELA, "--duration", 300, "--dt", 50, "--layers", 5,
                         "--transport-cfl", c, "--no-hillslope", "--no-debris", "--no-fluvial")
        assert result.returncode == 0, result.stderr
        sidecar = json.loads((tmp_path / f"bed_{c}.tif.json").read_text())
        assert sidecar["parameters"]["transport_cfl"] == c
        volumes[c] = sidecar["statistics"]["final_ice_volume_m3"]
    assert volumes[0.05] != pytest.approx(volumes[0.1], rel=1e-3)


def _eroded_valley(tmp_path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(bed before, bed after, ice) of a V valley of 16 × 24 cells of 250 m under 1000 y of strong
    abrasion (k_e 2e-4, no quarrying), the ice alone, converged Blatter–Pattyn velocities."""
    bed = valley(16, 24, 250.0, base=2400.0, head=900.0, scale=2000.0)
    dem = write_geotiff(tmp_path / "v.tif", bed.astype(np.float32), _transform(250.0))
    out, ice = tmp_path / "bed.tif", tmp_path / "ice.tif"
    result = run_cli("glaciate", dem, out, "--ela", ELA, "--duration", 1000, "--dt", 50,
                     "--sliding-C", 3e4, "--k-e", 2e-4, "--k-q", 0, "--ice", ice, "--dtype", "float64",
                     "--no-hillslope", "--no-debris", "--no-fluvial")
    assert result.returncode == 0, result.stderr
    return read_terrain(dem).elevation, read_terrain(out).elevation, read_terrain(ice).elevation


@pytest.fixture(scope="module")
def eroded_valley(tmp_path_factory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return _eroded_valley(tmp_path_factory.mktemp("valley"))


def test_blatter_valley_glacier_widens_the_v(eroded_valley) -> None:
    """Blatter–Pattyn flow with sliding erodes the lower walls: the power-law exponent b of the
    cross-sections (1 for a V, 2 for a U) rises from 1.24 to 1.58, 1.48 and 1.40 along the
    glaciated valley (measured, ~10 s). The map's edges are lowered as the cell inside them is:
    the bed keeps its slope across them."""
    before, after, ice = eroded_valley
    for column, measured in ((2, 1.58), (4, 1.48), (8, 1.40)):
        assert _power_law_exponent(before[:, column], 6) == pytest.approx(1.24, abs=0.01)
        assert _power_law_exponent(after[:, column], 6) == pytest.approx(measured, abs=0.05)
    edge = np.zeros(before.shape, dtype=bool)
    edge[[0, -1], :] = edge[:, [0, -1]] = True
    assert ice[edge].max() > 20.0  # measured 34 m at the valley's head
    lowering = before - after
    np.testing.assert_allclose(lowering[[0, -1], 1:-1], lowering[[1, -2], 1:-1], rtol=0, atol=1e-6)
    np.testing.assert_allclose(lowering[1:-1, [0, -1]], lowering[1:-1, [1, -2]], rtol=0, atol=1e-6)
    assert lowering[edge].max() > 1.0 and lowering[~edge].max() > 5.0


@pytest.mark.xfail(strict=True, reason="the median b of the glaciated sections is 1.48: a V widened, "
                   "not yet a U (b > 1.5); docs/glaciate.md §6")
def test_blatter_valley_glacier_turns_the_v_into_a_u(eroded_valley) -> None:
    """A U (median b over the glaciated sections above 1.5) after 1000 y of strong abrasion."""
    _, after, _ = eroded_valley
    assert np.median([_power_law_exponent(after[:, column], 6) for column in (2, 4, 8)]) > 1.5


# --- diagnostic mode: ISMIP-HOM B ----------------------------------------------------------------

@pytest.mark.skipif(not DATA.is_dir(), reason=f"ISMIP-HOM data not found at {DATA}")
def test_ismip_hom_b_diagnostic_matches_the_solver_and_the_published_models(tmp_path: Path) -> None:
    """ISMIP-HOM B at L = 20 km (Pattyn et al. 2008): a flowline of 100 columns, periodic, tilted
    0.5°, bumpy bed z_b = −1000 + 500 sin(ωx) under a flat surface, no slip, A = 1e-16 Pa⁻³/a."""
    length, nx = 20e3, 100
    dx = length / nx
    x = np.arange(nx) * dx
    bed = (-1000.0 + 500.0 * np.sin(2 * np.pi * x / length))[None].astype(np.float32)
    dem = write_geotiff(tmp_path / "bed.tif", bed, _transform(dx))
    thickness = write_geotiff(tmp_path / "h.tif", -bed, _transform(dx))
    velocity, sliding = tmp_path / "v.tif", tmp_path / "ub.tif"
    result = run_cli("glaciate", dem, "--diagnostic", "--ice-thickness", thickness, "--boundary", "periodic",
                     "--background-slope", 0.5, "--rate-factor", 1e-16, "--sliding-C", "inf",
                     "--velocity", velocity, "--sliding", sliding)
    assert result.returncode == 0, result.stderr
    with rasterio.open(velocity) as src:
        vx = src.read(1).astype(np.float64)[0]
    params = blatter.FlowParams(glen_a=1e-16, sliding_c=math.inf, n_layers=10)
    direct = blatter.solve(bed.astype(np.float64), -bed.astype(np.float64), Grid.full((1, nx), dx), params,
                           boundary="periodic", background_slope=math.radians(0.5), rtol=1e-5, max_iter=20000)
    assert direct.converged
    np.testing.assert_allclose(vx, direct.surface_velocity()[0][0], rtol=1e-6)
    assert read_terrain(sliding).elevation.max() == 0.0  # frozen bed
    ours = np.interp(X_HAT, x / length, vx, period=1.0)
    models = _model_profiles("b", 20, FULL_STOKES + HIGHER_ORDER)
    maxima = models.max(axis=1)
    assert maxima.min() <= ours.max() <= maxima.max()
    assert ours.max() == pytest.approx(np.median(maxima), rel=0.05)
    assert np.corrcoef(ours, np.median(models, axis=0))[0, 1] > 0.99


# --- no ice, bad input ----------------------------------------------------------------------------

def test_ela_above_every_peak_makes_no_ice_and_says_so(tmp_path: Path, valley_dem: Path) -> None:
    out, ice = tmp_path / "bed.tif", tmp_path / "ice.tif"
    result = run_cli("glaciate", valley_dem, out, "--ela", 5000, "--duration", 1000, "--ice", ice,
                     "--no-hillslope", "--no-debris", "--no-fluvial")
    assert result.returncode == 0, result.stderr
    assert "note:" in result.stderr and "no ice" in result.stderr
    np.testing.assert_array_equal(read_terrain(out).elevation, read_terrain(valley_dem).elevation)
    assert (read_terrain(ice).elevation == 0).all()
    stats = json.loads((tmp_path / "bed.tif.json").read_text())["statistics"]
    assert stats["ice_volume_series"]["ice_volume_m3"] == [0.0, 0.0] and "note" in stats


def test_without_ice_the_ice_free_processes_still_shape_the_bed(tmp_path: Path, valley_dem: Path) -> None:
    out, ice = tmp_path / "bed.tif", tmp_path / "ice.tif"
    result = run_cli("glaciate", valley_dem, out, "--ela", 5000, "--duration", 1000, "--dt", 100,
                     "--ice", ice)
    assert result.returncode == 0, result.stderr
    assert "no ice forms and only the processes of ice-free ground change the bed" in result.stderr
    change = read_terrain(out).elevation - read_terrain(valley_dem).elevation
    assert (read_terrain(ice).elevation == 0).all()
    assert 1e-3 < np.abs(change).max() < 0.1 * 1000          # at most 0.1 m/y anywhere
    removed = json.loads((tmp_path / "bed.tif.json").read_text())["statistics"]["ice_free_removed_m3"]
    assert removed["debris"] >= 0.0 and removed["fluvial"] > 0.0  # neither deposits


def test_ela_time_table(tmp_path: Path, valley_dem: Path) -> None:
    """E stays above the peaks for 500 y, then drops to 3000 m: ice appears only after 500 y."""
    table = tmp_path / "ela.csv"
    table.write_text("# ELA history\ntime,ela\n0,5000\n500,5000\n510,3000\n")
    out = tmp_path / "bed.tif"
    result = run_cli("glaciate", valley_dem, out, "--ela", table, "--duration", 1000, "--dt", 20,
                     "--iceflow", "sia", "--sliding-C", 1e5)
    assert result.returncode == 0, result.stderr
    series = json.loads((tmp_path / "bed.tif.json").read_text())["statistics"]["ice_volume_series"]
    volume = dict(zip(series["time_years"], series["ice_volume_m3"], strict=True))
    assert volume[500.0] == 0.0 and volume[1000.0] > 1e8


@pytest.mark.parametrize(("args", "mentions"), [
    (("--layers", -3), "--layers"),
    (("--ela", "nan"), "finite"),
    (("--ela", "3000", "--transport", "explicit", "--no-substep", "--dt", 50, "--iceflow", "sia"),
     "--no-substep"),
    (("--transport-cfl", 0), "--transport-cfl"),
    (("--transport-cfl", 1.5), "--transport-cfl"),
])
def test_bad_options_exit_2(tmp_path: Path, valley_dem: Path, args, mentions) -> None:
    ice = write_geotiff(tmp_path / "h0.tif", np.full((40, 60), 100.0, np.float32), _transform(DX))
    out = tmp_path / "bed.tif"
    base = ("glaciate", valley_dem, out, "--duration", 100, "--ice-thickness", ice)
    extra = () if "--ela" in args else ("--ela", ELA)
    assert_refused(run_cli(*base, *extra, *args), out, mentions)


def _bad_raster(tmp_path: Path, case: str) -> tuple[list, str]:
    """Arguments that pass a bad raster, and what the error names."""
    if case == "ela of another shape":
        ela = write_geotiff(tmp_path / "ela.tif", np.full((10, 10), 3000.0, np.float32), _transform(DX))
        return ["--ela", ela], "10 × 10 cells"
    if case == "ice on another grid":
        shifted = Affine(DX, 0.0, 500050.0, 0.0, -DX, 5000000.0)
        ice = write_geotiff(tmp_path / "h1.tif", np.zeros((40, 60), np.float32), shifted)
        return ["--ela", ELA, "--ice-thickness", ice], "not aligned"
    holes = np.zeros((40, 60), np.float32)
    holes[5, 5] = np.nan
    ice = write_geotiff(tmp_path / "h2.tif", holes, _transform(DX), nodata=float("nan"))
    return ["--ela", ELA, "--ice-thickness", ice], "nan"


@pytest.mark.parametrize("case", ["ela of another shape", "ice on another grid", "nan ice"])
def test_bad_rasters_exit_2(tmp_path: Path, valley_dem: Path, case: str) -> None:
    out = tmp_path / "bed.tif"
    args, mentions = _bad_raster(tmp_path, case)
    assert_refused(run_cli("glaciate", valley_dem, out, "--duration", 100, *args), out, mentions)


def test_diagnostic_needs_a_thickness(tmp_path: Path, valley_dem: Path) -> None:
    velocity = tmp_path / "v.tif"
    assert_refused(run_cli("glaciate", valley_dem, "--diagnostic", "--velocity", velocity), velocity,
                   "--ice-thickness")


def test_existing_outputs_are_not_overwritten(tmp_path: Path, valley_dem: Path) -> None:
    out, ice = tmp_path / "bed.tif", tmp_path / "ice.tif"
    ice.write_bytes(b"precious")
    args = ("glaciate", valley_dem, out, "--ela", 5000, "--duration", 100, "--ice", ice)
    assert_refused(run_cli(*args), out, "--overwrite")
    assert ice.read_bytes() == b"precious"
    assert run_cli(*args, "--overwrite").returncode == 0
    assert read_terrain(ice).shape == (40, 60)
