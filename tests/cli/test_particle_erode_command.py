"""`particle-erode` as a user runs it: mass budget in the sidecar, change map, layered terrains,
particle paths, determinism and bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from tests.cli.test_bad_input import assert_refused
from tests.conftest import run_cli, write_geotiff

N = 40
DX = 20.0
TRANSFORM = Affine(DX, 0.0, 500000.0, 0.0, -DX, 5000000.0)


def _cone() -> np.ndarray:
    """A 200 m cone on a 40 × 40 grid of 20 m cells, its foot at 0 m."""
    yy, xx = np.mgrid[0:N, 0:N] - (N - 1) / 2.0
    return np.maximum(0.0, 200.0 - 0.5 * DX * np.hypot(xx, yy))


@pytest.fixture
def cone(tmp_path: Path) -> Path:
    return write_geotiff(tmp_path / "cone.tif", _cone(), transform=TRANSFORM)


def write_bands(path: Path, bands: np.ndarray, transform: Affine = TRANSFORM,
                descriptions: list[str] | None = None) -> Path:
    """A plain multi-band float64 GeoTIFF (no unerode-cli code involved)."""
    with rasterio.open(path, "w", driver="GTiff", height=bands.shape[1], width=bands.shape[2],
                       count=bands.shape[0], dtype="float64", crs="EPSG:32632", transform=transform) as dst:
        dst.write(bands)
        for band, text in enumerate(descriptions or [], start=1):
            dst.set_band_description(band, text)
    return path


def read(path: Path) -> np.ndarray:
    with rasterio.open(path) as src:
        return src.read().astype(np.float64).squeeze()


def budget_of(output: Path) -> dict[str, float]:
    return json.loads(output.with_name(output.name + ".json").read_text())["statistics"]["mass_budget_m3"]


RUN = ("--particles", 300, "--iterations", 3, "--dtype", "float64")


@pytest.mark.parametrize("preset", ["rain", "volcano"])
def test_budget_closes_and_output_is_input_plus_change(tmp_path: Path, cone: Path, preset: str) -> None:
    out, dh = tmp_path / "out.tif", tmp_path / "dh.tif"
    result = run_cli("particle-erode", cone, out, "--preset", preset, *RUN, "--seed", 4,
                     "--change-map", dh)
    assert result.returncode == 0, result.stderr
    assert "particle-erode: " in result.stderr and str(out) in result.stderr
    b = budget_of(out)
    scale = b["detached"] + b["emitted"]
    assert b["detached"] > 0 and b["deposited"] > 0
    # emitted + detached − deposited − suspended − lost = 0 (emitted: volcano's loaded particles)
    closure = b["emitted"] + b["detached"] - b["deposited"] - b["suspended"] - b["lost_at_edges"]
    assert abs(closure) <= 1e-9 * scale
    assert b["relative_residual"] <= 1e-9
    assert (b["emitted"] > 0) == (preset == "volcano")
    # the terrain's volume, from the files, changed by deposited − detached
    before, after, change = read(cone), read(out), read(dh)
    np.testing.assert_allclose(after, before + change, rtol=0, atol=1e-9)
    assert change.min() < -0.01 and change.max() > 0.01
    volume = change.sum() * DX * DX
    assert volume == pytest.approx(b["deposited"] - b["detached"], rel=1e-9, abs=1e-9 * scale)
    assert b["terrain_volume_change"] == pytest.approx(volume, rel=1e-9, abs=1e-9 * scale)


def _layered_inputs(tmp_path: Path, table: str) -> tuple[Path, Path]:
    """Two layers under the cone: 300 m of rock, then soil (20 m, 80 m where the cone is high)."""
    soil = np.clip(_cone() - 100.0, 0.0, 60.0) + 20.0
    layers = write_bands(tmp_path / "layers.tif", np.stack([np.full((N, N), 300.0), soil]))
    materials = tmp_path / "materials.csv"
    materials.write_text(table)
    return layers, materials


TABLE = "# materials of the test\nname,erodibility,critical_stress,description\nrock,0.2,1.0,hard\n" \
        "soil,2.5,0,soft\nsand,4.0,0,deposits\n"


def test_layered_run_keeps_layers_and_deposits_sand(tmp_path: Path, cone: Path) -> None:
    layers, materials = _layered_inputs(tmp_path, TABLE)
    out, dh = tmp_path / "out.tif", tmp_path / "dh.tif"
    result = run_cli("particle-erode", cone, out, *RUN, "--seed", 2, "--layers", layers,
                     "--materials", materials, "--layer-materials", "rock,soil",
                     "--deposit-material", "sand", "--change-map", dh)
    assert result.returncode == 0, result.stderr
    layers_out = tmp_path / "out_layers.tif"
    with rasterio.open(layers_out) as src:
        assert src.descriptions == ("rock", "soil", "sand")  # the deposit layer added on top
        bands = src.read().astype(np.float64)
    before = read(layers)
    surface, change = read(out), read(dh)
    # base + Σ thickness = surface; the base (300 m of rock never eroded through) is unchanged
    base = read(cone) - before.sum(axis=0)
    np.testing.assert_allclose(base + bands.sum(axis=0), surface, rtol=0, atol=1e-9)
    assert np.array_equal(bands[0], before[0])
    assert (bands[1] <= before[1] + 1e-12).all() and (bands[1] < before[1] - 0.01).any()
    # deposits are sand: where the surface rose, at least that much sand lies on top
    assert (bands[2] >= change - 1e-9).all()
    assert (change > 0.01).sum() > 10
    b = budget_of(out)
    assert 0 < bands[2].sum() * DX * DX <= b["deposited"]
    assert abs(b["residual"]) <= 1e-9 * b["detached"]
    sidecar = json.loads((tmp_path / "out_layers.tif.json").read_text())
    assert sidecar["statistics"]["layer_materials"] == ["rock", "soil", "sand"]


def test_layered_output_chains_into_a_second_run(tmp_path: Path, cone: Path) -> None:
    """The layers output is an input again: its band descriptions name the materials."""
    layers, materials = _layered_inputs(tmp_path, TABLE)
    first = tmp_path / "first.tif"
    assert run_cli("particle-erode", cone, first, "--particles", 100, "--iterations", 1, "--layers", layers,
                   "--materials", materials, "--layer-materials", "rock,soil",
                   "--deposit-material", "sand").returncode == 0
    second = tmp_path / "second.tif"
    result = run_cli("particle-erode", first, second, "--particles", 100, "--iterations", 1,
                     "--layers", tmp_path / "first_layers.tif", "--materials", materials)
    assert result.returncode == 0, result.stderr
    with rasterio.open(tmp_path / "second_layers.tif") as src:
        assert src.descriptions == ("rock", "soil", "sand")


def test_paths_are_geojson_lines_inside_the_dem(tmp_path: Path, cone: Path) -> None:
    out, paths = tmp_path / "out.tif", tmp_path / "paths.geojson"
    x0, y0 = 500000.0 + 20.5 * DX, 5000000.0 - 19.5 * DX  # the summit's map coordinates
    result = run_cli("particle-erode", cone, out, "--preset", "river", "--particles", 50,
                     "--iterations", 2, "--source", f"{x0},{y0}", "--spread", 30,
                     "--paths", paths, "--path-count", 12, "--path-stride", 2)
    assert result.returncode == 0, result.stderr
    data = json.loads(paths.read_text())
    assert data["type"] == "FeatureCollection"
    assert data["crs"]["properties"]["name"].endswith("EPSG::32632")
    features = data["features"]
    assert len(features) == 12
    left, top = 500000.0, 5000000.0
    for feature in features:
        assert feature["geometry"]["type"] == "LineString"
        xyz = np.array(feature["geometry"]["coordinates"])
        assert xyz.shape[1] == 3 and len(xyz) >= 2
        assert ((xyz[:, 0] >= left) & (xyz[:, 0] <= left + N * DX)).all()
        assert ((xyz[:, 1] <= top) & (xyz[:, 1] >= top - N * DX)).all()
        assert (np.hypot(xyz[0, 0] - x0, xyz[0, 1] - y0) <= 30.0 + 1e-3)  # starts at the source
        times = np.array(feature["properties"]["times_s"])
        assert len(times) == len(xyz) and times[0] == 0.0 and (np.diff(times) >= 0).all()
        assert feature["properties"]["fate"] in ("settled", "edge", "expired")
    # the river runs down: paths end lower than they start
    drops = [f["geometry"]["coordinates"][0][2] - f["geometry"]["coordinates"][-1][2] for f in features]
    assert np.median(drops) > 20.0


def test_same_seed_same_output_whatever_the_threads(tmp_path: Path, cone: Path) -> None:
    outs = {name: tmp_path / f"{name}.tif" for name in "abc"}
    outs["c"].write_bytes(b"an older result")  # replaced: --overwrite below
    for name, seed, threads in (("a", 7, 1), ("b", 7, 2), ("c", 8, 2)):
        result = run_cli("particle-erode", cone, outs[name], "--particles", 200, "--iterations", 2,
                         "--seed", seed, "--threads", threads, "--overwrite")
        assert result.returncode == 0, result.stderr
    a, b, c = (read(outs[k]) for k in "abc")
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    assert np.abs(a - c).max() > 0.01


def test_uniform_velocity_pushes_the_deposits_downwind(tmp_path: Path, cone: Path) -> None:
    """Light particles in an eastward wind deposit more east of the summit than west of it."""
    dh = {}
    for name, wind in (("still", None), ("east", "uniform:8,0")):
        out = tmp_path / f"{name}.tif"
        args = ["--velocity", wind] if wind else []
        result = run_cli("particle-erode", cone, out, "--particles", 400, "--iterations", 1,
                         "--preset", "wind", "--dtype", "float64", *args)
        assert result.returncode == 0, result.stderr
        dh[name] = read(out) - read(cone)
    east, west = slice(N // 2 + 1, None), slice(None, N // 2)
    shift = dh["east"][:, east].sum() - dh["east"][:, west].sum()
    still = dh["still"][:, east].sum() - dh["still"][:, west].sum()
    assert shift > still + 1.0


def _wrong_shape_velocity(tmp_path: Path) -> list[object]:
    return ["--velocity", write_bands(tmp_path / "v.tif", np.zeros((2, N, N - 1)))]


def _bad_materials(tmp_path: Path) -> list[object]:
    layers, materials = _layered_inputs(tmp_path, "name,erodibility\nrock,0.2\nsoil,lots\n")
    return ["--layers", layers, "--materials", materials]


def _shifted_layers(tmp_path: Path) -> list[object]:
    _, materials = _layered_inputs(tmp_path, TABLE)
    shifted = Affine(DX, 0.0, 500001.0, 0.0, -DX, 5000000.0)
    layers = write_bands(tmp_path / "shifted.tif", np.ones((2, N, N)), transform=shifted)
    return ["--layers", layers, "--materials", materials, "--layer-materials", "rock,soil"]


@pytest.mark.parametrize(("make_args", "mentions"), [
    (lambda tmp: ["--preset", "tsunami"], "unknown particle preset 'tsunami'"),
    (lambda tmp: ["--radius", "-5"], "radius must be ≥ 0"),
    (lambda tmp: ["--R", "0"], "radius must be > 0"),
    (_wrong_shape_velocity, "velocity raster"),
    (lambda tmp: ["--velocity", "uniform:1"], "--velocity uniform:"),
    (_bad_materials, "line 3: erodibility must be a number, got 'lots'"),
    (_shifted_layers, "not aligned with the DEM"),
    (lambda tmp: ["--source", "1,2"], "source points must lie on the grid"),
    (lambda tmp: ["--layers", "x.tif"], "both --layers"),
])
def test_bad_input_exits_2_with_one_line(tmp_path: Path, cone: Path, make_args, mentions: str) -> None:
    out = tmp_path / "out.tif"
    result = run_cli("particle-erode", cone, out, "--particles", 10, "--iterations", 1, *make_args(tmp_path))
    assert_refused(result, out, mentions)


def test_refuses_to_overwrite_without_overwrite(tmp_path: Path, cone: Path) -> None:
    out, paths = tmp_path / "out.tif", tmp_path / "paths.geojson"
    paths.write_text("precious")
    assert_refused(run_cli("particle-erode", cone, out, "--paths", paths), out, "--overwrite")
    assert paths.read_text() == "precious"
    out.write_bytes(b"precious too")
    assert_refused(run_cli("particle-erode", cone, out), None, "--overwrite")
    assert out.read_bytes() == b"precious too"
