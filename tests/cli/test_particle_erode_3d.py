"""`particle-erode` on 3D terrains as a user runs it: a density or binary block built from a DEM,
the altered volume (.npz), its closed mesh and a view of it, a volume read back with --voxels,
3D material layers from YAML, per-impact application, and bad input refused with one sentence
(exit 2)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from tests.cli.test_bad_input import assert_refused
from tests.conftest import run_cli, write_geotiff
from tests.volume.conftest import assert_watertight

from unerode_cli.io.mesh_files import read_mesh
from unerode_cli.io.voxel_files import read_voxels
from unerode_cli.volume.mesh import enclosed_volume
from unerode_cli.volume.voxel_kernels import top_surface

N = 24
DX = 20.0
WEST, NORTH = 500000.0, 5000000.0
TRANSFORM = Affine(DX, 0.0, WEST, 0.0, -DX, NORTH)
RUN = ("--particles", 200, "--iterations", 2, "--dtype", "float64", "--seed", 3)


@pytest.fixture
def cone(tmp_path: Path) -> Path:
    """A 120 m cone on a 24 × 24 grid of 20 m cells, its foot at 300 m."""
    yy, xx = np.mgrid[0:N, 0:N] - (N - 1) / 2.0
    return write_geotiff(tmp_path / "cone.tif", 300.0 + np.maximum(0.0, 120.0 - 0.5 * DX * np.hypot(xx, yy)),
                         transform=TRANSFORM)


def _sidecar(output: Path) -> dict:
    return json.loads(output.with_name(output.name + ".json").read_text())


def _read(path: Path) -> tuple[np.ndarray, Affine, str]:
    with rasterio.open(path) as src:
        return src.read(1).astype(np.float64), src.transform, src.crs.to_string()


def test_a_density_block_keeps_its_mass_and_writes_its_volume_and_a_closed_mesh(tmp_path: Path,
                                                                                 cone: Path) -> None:
    out, volume, mesh = tmp_path / "out.tif", tmp_path / "volume.npz", tmp_path / "out.ply"
    preview = tmp_path / "out.png"
    result = run_cli("particle-erode", cone, out, "--representation", "density", *RUN, "--volume-out", volume,
                     "--mesh", mesh, "--preview", preview)
    assert result.returncode == 0, result.stderr
    stats = _sidecar(out)["statistics"]
    b = stats["mass_budget_m3"]
    assert b["detached"] > 1e5 and b["left_grid"] == 0.0
    # Σ (1 + f)/2 · V of the volume changed by deposited − detached (003 Eq. 13), to rounding
    expected = b["deposited"] - b["detached"]
    assert b["terrain_volume_change"] == pytest.approx(expected, abs=1e-9 * b["detached"])
    # the volume: the DEM's extent and CRS, 10 voxels of the DEM's cell size below its lowest cell
    read = read_voxels(volume)
    geometry = read.voxels.geometry
    assert geometry.size == (DX, DX, DX) and geometry.shape[:2] == (N, N)
    assert geometry.origin == pytest.approx((WEST, NORTH, 300.0 - 10 * DX))
    assert "32632" in read.crs_wkt
    # OUT is the top heightfield of the volume written, on the DEM's grid
    top, transform, crs = _read(out)
    assert transform == TRANSFORM and crs == "EPSG:32632"
    assert top == pytest.approx(top_surface(read.voxels.density, geometry.origin[2], DX), abs=1e-3)
    assert np.abs(top - _read(cone)[0]).max() > 1.0
    # the mesh: closed, placed by its origin comment, enclosing the volume's matter
    shape, origin = read_mesh(mesh)
    assert_watertight(shape.faces)
    assert origin == pytest.approx((WEST, NORTH - N * DX, 300.0 - 10 * DX))
    assert enclosed_volume(shape) == pytest.approx(read.voxels.matter(), rel=0.02)
    assert stats["mesh"]["faces"] == len(shape.faces)
    assert preview.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"  # the mesh rendered


@pytest.mark.slow
def test_a_volume_read_back_continues_the_run(tmp_path: Path, cone: Path) -> None:
    first, volume = tmp_path / "first.tif", tmp_path / "first.npz"
    assert run_cli("particle-erode", cone, first, "--representation", "density", *RUN,
                   "--volume-out", volume).returncode == 0
    second, again = tmp_path / "second.tif", tmp_path / "second.npz"
    result = run_cli("particle-erode", cone, second, "--voxels", volume, *RUN, "--volume-out", again,
                     "--apply", "per-impact")
    assert result.returncode == 0, result.stderr
    sidecar = _sidecar(second)
    assert sidecar["parameters"]["representation"] == "density"
    assert sidecar["parameters"]["apply"] == "per-impact"
    b = sidecar["statistics"]["mass_budget_m3"]
    # the second run starts from the first one's volume (float32 in the file) and keeps its mass
    change = read_voxels(again).voxels.matter() - read_voxels(volume).voxels.matter()
    assert change == pytest.approx(b["deposited"] - b["detached"], abs=1e-3 * b["detached"])


LAYERS = """
materials:
  limestone: {erodibility: 5.0}
  marl: {erodibility: 0.5, critical_stress: 0.5}
  sand: {erodibility: 8.0}
horizons:
  - {material: marl, top: 360}
  - {material: limestone}
deposit: sand
"""


@pytest.mark.slow
def test_binary_voxels_with_3d_layers_count_their_hits(tmp_path: Path, cone: Path) -> None:
    materials = tmp_path / "layers.yaml"
    materials.write_text(LAYERS)
    out, volume = tmp_path / "out.tif", tmp_path / "volume.npz"
    result = run_cli("particle-erode", cone, out, "--representation", "binary", "--materials", materials,
                     *RUN, "--volume-out", volume)
    assert result.returncode == 0, result.stderr
    sidecar = _sidecar(out)
    hits = sidecar["statistics"]["binary_voxels"]
    parameters = sidecar["parameters"]
    assert parameters["materials_3d"] == ["limestone", "marl", "sand"]
    assert parameters["deposit_material"] == "sand"
    threshold = parameters["hits_threshold"]
    flips = hits["voxels_removed"] + hits["voxels_transformed"] - hits["voxels_added"]
    assert flips * threshold == hits["erosion_hits"] - hits["deposition_hits"] - hits["hits_held_change"]
    read = read_voxels(volume)
    assert read.material_names == ("limestone", "marl", "sand")
    material, solid = read.voxels.material, read.voxels.solid
    z = read.voxels.geometry.layer_centres()
    assert np.all(material[:, :, z < 360.0][solid[:, :, z < 360.0]] != 0)  # no limestone in the marl
    assert (material[solid] == 2).any() == (hits["voxels_added"] > 0)  # deposits became sand


EMPTY = np.zeros((4, 4, 4))


def _voxel_file(path: Path, **arrays) -> Path:
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize(("make_args", "mentions"), [
    (lambda tmp, cone: ("--voxels", _voxel_file(tmp / "v.npz", voxel_size=1.0, density=EMPTY)),
     "has no origin"),
    (lambda tmp, cone: ("--voxels", _voxel_file(tmp / "v.npz", origin=[0.0, 0.0, 0.0], density=EMPTY)),
     "no voxel_size"),
    (lambda tmp, cone: ("--representation", "density", "--voxel-size", 0.2), "memory-budget"),
    (lambda tmp, cone: ("--representation", "density", "--memory-budget", 0.0001),
     "more than the 0.0001 gib"),
    (lambda tmp, cone: ("--representation", "tetrahedra"), "unknown representation 'tetrahedra'"),
    (lambda tmp, cone: ("--apply", "sometimes"), "--apply must be per-iteration or per-impact"),
    (lambda tmp, cone: ("--representation", "density", "--voxels", tmp / "v.npz", "--voxel-size", 5.0),
     "--voxels brings its own grid"),
    (lambda tmp, cone: ("--voxel-size", 5.0), "need a 3d terrain"),
    (lambda tmp, cone: ("--representation", "density", "--hits-threshold", 10), "binary voxels"),
    (lambda tmp, cone: ("--representation", "density", "--mesh", tmp / "out.stl"), "--mesh"),
])
def test_bad_input_exits_2_with_one_sentence(tmp_path: Path, cone: Path, make_args, mentions: str) -> None:
    out = tmp_path / "out.tif"
    assert_refused(run_cli("particle-erode", cone, out, *make_args(tmp_path, cone)), out, mentions)


def test_per_impact_is_refused_on_layered_terrains(tmp_path: Path, cone: Path) -> None:
    layers = tmp_path / "layers.tif"
    with rasterio.open(layers, "w", driver="GTiff", height=N, width=N, count=1, dtype="float64",
                       crs="EPSG:32632", transform=TRANSFORM) as dst:
        dst.write(np.full((1, N, N), 10.0))
    table = tmp_path / "materials.csv"
    table.write_text("name,erodibility,critical_stress\nsoil,1.0,0\n")
    out = tmp_path / "out.tif"
    result = run_cli("particle-erode", cone, out, "--layers", layers, "--materials", table,
                     "--apply", "per-impact")
    assert_refused(result, out, "per-impact works on heightfield, density, binary terrains")


def test_a_geographic_dem_is_refused_for_a_block(tmp_path: Path) -> None:
    dem = write_geotiff(tmp_path / "geo.tif", np.full((8, 8), 100.0),
                        transform=Affine(0.001, 0.0, 7.0, 0.0, -0.001, 46.0), crs="EPSG:4326")
    out = tmp_path / "out.tif"
    assert_refused(run_cli("particle-erode", dem, out, "--representation", "density"), out, "projected crs")
