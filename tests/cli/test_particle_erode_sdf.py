"""`particle-erode` on implicit terrains (--representation sdf, --sdf scenes), the meanders
preset and several kinds of particles in one run, as a user runs them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from affine import Affine
from tests.cli.test_bad_input import assert_refused
from tests.cli.test_particle_erode_command import read
from tests.conftest import run_cli, write_geotiff

from unerode_cli.io.voxel_files import read_voxels
from unerode_cli.volume.voxel_kernels import top_surface

N = 24
DX = 20.0
WEST, NORTH = 500000.0, 5000000.0
#: Particles that move nothing (no detachment, no deposition, no load): OUT is the terrain.
STILL = ("--k-eps", 0, "--omega", 0, "--particles", 20, "--iterations", 1, "--dtype", "float64")


def _hill() -> np.ndarray:
    yy, xx = (np.mgrid[0:N, 0:N] - (N - 1) / 2.0) * DX
    return 20.0 + 80.0 * np.exp(-(xx**2 + yy**2) / (2 * 120.0**2))


@pytest.fixture
def hill(tmp_path: Path) -> Path:
    return write_geotiff(tmp_path / "hill.tif", _hill(), transform=Affine(DX, 0.0, WEST, 0.0, -DX, NORTH))


def _sidecar(path: Path) -> dict:
    return json.loads(path.with_name(path.name + ".json").read_text())


def test_the_top_heightfield_of_an_unaltered_dem_is_the_dem(tmp_path: Path, hill: Path) -> None:
    out, mesh, volume = tmp_path / "out.tif", tmp_path / "out.ply", tmp_path / "out.npz"
    result = run_cli("particle-erode", hill, out, "--representation", "sdf", *STILL, "--mesh", mesh,
                     "--volume-out", volume)
    assert result.returncode == 0, result.stderr
    assert np.abs(read(out) - _hill()).max() < 1e-9  # the highest zero crossing of each column
    assert _sidecar(out)["parameters"]["representation"] == "sdf"
    assert mesh.stat().st_size > 0
    voxels = read_voxels(volume).voxels  # density voxels keep the 0-level
    bottom, dz = voxels.geometry.origin[2], voxels.geometry.size[2]
    assert np.abs(top_surface(voxels.density, bottom, dz) - _hill()).max() < 1e-6


def test_a_scene_adds_a_box_and_carves_a_sphere_where_its_coordinates_say(tmp_path: Path, hill: Path) -> None:
    """A 60 m box up to 150 m over cells 10–12 (rows and columns), and a ball of 40 m centred
    10 m above the ground at the centre of cell (row 4, column 5): the columns through them
    cross zero at 150 m and 40 m below the ball's centre (f linear along them there)."""
    centre_z = float(_hill()[4, 5]) + 10.0
    scene = tmp_path / "scene.yaml"
    scene.write_text(
        "shape:\n"
        "  difference:\n"
        "    - union:\n"
        "        - surface: {}\n"
        "        - box: {min: [500200, 4999740, 0], max: [500260, 4999800, 150]}\n"
        f"    - sphere: {{centre: [500110, 4999910, {centre_z}], radius: 40}}\n")
    out = tmp_path / "out.tif"
    result = run_cli("particle-erode", hill, out, "--sdf", scene, *STILL)
    assert result.returncode == 0, result.stderr
    surface, dem = read(out), _hill()
    assert np.abs(surface[10:13, 10:13] - 150.0).max() < 1e-6
    assert surface[4, 5] == pytest.approx(centre_z - 40.0, abs=1e-6)
    untouched = np.ones((N, N), bool)
    untouched[9:14, 9:14] = untouched[1:8, 2:9] = False
    assert np.abs(surface - dem)[untouched].max() < 1e-9


def test_an_unknown_primitive_is_refused(tmp_path: Path, hill: Path) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text("shape:\n  union:\n    - surface: {}\n    - cone: {apex: [0, 0, 0]}\n")
    out = tmp_path / "out.tif"
    assert_refused(run_cli("particle-erode", hill, out, "--sdf", scene), out, "unknown primitive 'cone'")


@pytest.mark.parametrize("options, mentions", [
    (("--representation", "density"), "--sdf gives an implicit terrain"),
    (("--hits-threshold", "3"), "--hits-threshold"),
])
def test_options_of_other_representations_are_refused(tmp_path: Path, hill: Path, options, mentions) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text("shape: {surface: {}}\n")
    out = tmp_path / "out.tif"
    assert_refused(run_cli("particle-erode", hill, out, "--sdf", scene, *options), out, mentions)


def test_the_meanders_preset_runs_on_an_implicit_terrain_with_its_field(tmp_path: Path, hill: Path) -> None:
    out = tmp_path / "out.tif"
    result = run_cli("particle-erode", hill, out, "--preset", "meanders", "--iterations", 3,
                     "--dtype", "float64")
    assert result.returncode == 0, result.stderr
    sidecar = _sidecar(out)
    parameters, budget = sidecar["parameters"], sidecar["statistics"]["mass_budget_m3"]
    assert (parameters["representation"], parameters["velocity"]) == ("sdf", "sin")
    assert parameters["radius"] == pytest.approx(5 * DX)  # Table 1: R = 5 voxels
    moved = budget["detached"] + budget["deposited"]
    assert moved > 0 and abs(budget["residual"]) < 1e-9 * moved
    # each metaball is sized on the node columns it changes, also at the domain's edges
    assert abs(budget["terrain_volume_change"] - (budget["deposited"] - budget["detached"])) < 1e-6 * moved


def test_several_kinds_each_with_its_preset(tmp_path: Path, hill: Path) -> None:
    """rain+wind: each kind with its preset's radius (Table 1: 1 and 1.5 cells) and particle
    density, and the run's budget the sum of the kinds'."""
    out = tmp_path / "out.tif"
    result = run_cli("particle-erode", hill, out, "--preset", "rain+wind", "--velocity", "uniform:5,0",
                     "--particles", 30, "--iterations", 1)
    assert result.returncode == 0, result.stderr
    sidecar = _sidecar(out)
    kinds = sidecar["parameters"]["kinds"]
    assert [(k["kind"], k["radius"], k["density"]) for k in kinds] == [("rain", DX, 1000.0),
                                                                      ("wind", 1.5 * DX, 1.5)]
    stats = sidecar["statistics"]
    assert [k["particles"] for k in stats["kinds"]] == [30, 30]
    total = stats["mass_budget_m3"]["detached"]
    assert sum(k["detached_m3"] for k in stats["kinds"]) == pytest.approx(total, rel=1e-12)


def test_a_kinds_file_sets_counts_and_values_and_refuses_unknown_presets(tmp_path: Path, hill: Path) -> None:
    kinds = tmp_path / "kinds.yaml"
    kinds.write_text("iterations: 2\nkinds:\n  - {preset: rain, particles: 25, parameters: {k_eps: 0.5}}\n"
                     "  - {preset: river, particles: 10}\n")
    out = tmp_path / "out.tif"
    result = run_cli("particle-erode", hill, out, "--kinds", kinds, "--radius", 25)
    assert result.returncode == 0, result.stderr
    sidecar = _sidecar(out)
    described = sidecar["parameters"]["kinds"]
    assert [(k["kind"], k["particles_per_iteration"], k["k_eps"], k["radius"]) for k in described] == \
        [("rain", 25, 0.5, 25.0), ("river", 10, 1.0, 25.0)]  # the command line's radius goes to every kind
    assert sidecar["statistics"]["particles"] == 2 * 35
    kinds.write_text("kinds:\n  - {preset: drizzle}\n")
    bad = tmp_path / "bad.tif"
    assert_refused(run_cli("particle-erode", hill, bad, "--kinds", kinds), bad, "unknown preset 'drizzle'")
