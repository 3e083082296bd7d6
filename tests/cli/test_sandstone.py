"""`unerode-cli sandstone` as a user runs it: outputs, determinism, resume, DEMs, bad input."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from tests.conftest import run_cli, write_geotiff

from unerode_cli.io.particle_ply import read_particle_ply
from unerode_cli.io.rasters import read_terrain
from unerode_cli.jobs.sandstone.options import PRESET_NAMES
from unerode_cli.volume.mesh import PALETTE

SCENE = """
domain: {size: [20, 12, 14]}
particles: 4000
shape:
  difference:
    - box: {min: [4, 4, 0], max: [16, 8, 10]}
    - cylinder: {base: [10, 3, 0], radius: 2.5, height: 10, axis: y}
layers:
  - {top: 4, k_w: 2e-4, interlocking: 1.5e6, k_a: 0.02, k_d: 1.0}
  - {k_w: 1e-4, interlocking: 3e6, k_a: 0.01, k_d: 0.5}
paint:
  - {shape: {box: {min: [4, 4, 0], max: [6, 8, 10]}}, erodibility: 0}
wind: {azimuth: 180, speed: 10}
"""
FAST = ("--substeps", "20", "--settle-substeps", "400", "-q")
HELP_PROBE = """
import sys
from unerode_cli.cli.app import app
try:
    app(["sandstone", "--help"], standalone_mode=False)
finally:
    print("NUMBA=" + str("numba" in sys.modules), file=sys.stderr)
"""


def _scene(tmp_path: Path, text: str = SCENE) -> Path:
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    return path


def test_a_scene_run_writes_every_output(tmp_path: Path) -> None:
    out = tmp_path / "run"
    result = run_cli("sandstone", _scene(tmp_path), out, "--frames", "6", "--color-by", "stress", *FAST)
    assert result.returncode == 0, result.stderr
    props, origin = read_particle_ply(out / "particles.ply")
    assert {"x", "y", "z", "nx", "ny", "nz", "viability", "stress", "erodibility", "layer", "surface",
            "deposit", "interlocked"} <= set(props)
    assert len(props["x"]) == pytest.approx(4000, rel=0.05) and origin == (0.0, 0.0, 0.0)
    normals = np.column_stack([props["nx"], props["ny"], props["nz"]])[props["surface"] == 1]
    assert np.linalg.norm(normals, axis=1) == pytest.approx(1.0, abs=1e-3)   # every surface particle's
    colours = np.column_stack([props["red"], props["green"], props["blue"]])
    assert np.array_equal(colours, PALETTE[props["layer"] % len(PALETTE)])  # the layer's, as the mesh's
    assert props["stress"].max() < 1.0  # MPa: a 10 m rock weighs ~0.2 MPa at its base
    painted = (props["x"] < 5.9) & (props["deposit"] == 0)
    assert np.all(props["erodibility"][painted] == 0.0)
    run = json.loads((out / "run.json").read_text())
    assert run["seed"] == 0 and run["statistics"]["frames"] == 6 and "numba" in run["versions"]
    assert len((out / "frames.csv").read_text().strip().splitlines()) == 7
    with rasterio.open(out / "top.tif") as top:
        assert top.read(1).max() == pytest.approx(10.0, abs=0.6)
    assert (out / "preview.png").stat().st_size > 10_000
    again = run_cli("sandstone", _scene(tmp_path), out, "--frames", "6", *FAST)
    assert again.returncode == 2 and "--overwrite" in again.stderr


@pytest.mark.slow
def test_same_seed_same_particles_file_with_one_or_two_threads(tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    files = []
    for threads in (1, 2):
        out = tmp_path / f"t{threads}"
        result = run_cli("sandstone", scene, out, "--frames", "6", "--seed", "3", "--threads", threads, *FAST)
        assert result.returncode == 0, result.stderr
        files.append((out / "particles.ply").read_bytes())
    assert files[0] == files[1]


def test_a_resumed_run_ends_as_the_uninterrupted_one(tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    whole = tmp_path / "whole"
    result = run_cli("sandstone", scene, whole, "--frames", "4", "--seed", "3", "--threads", "1", *FAST)
    assert result.returncode == 0, result.stderr
    resumed = tmp_path / "resumed"
    first = run_cli("sandstone", scene, resumed, "--frames", "2", "--seed", "3", "--snapshot-every", "2",
                    "--threads", "1", *FAST)
    assert first.returncode == 0, first.stderr
    assert (resumed / "snapshots" / "frame_00002.ply").exists()
    rest = run_cli("sandstone", scene, resumed, "--frames", "4", "--seed", "3", "--resume", "--threads", "1",
                   *FAST)
    assert rest.returncode == 0, rest.stderr
    assert (resumed / "particles.ply").read_bytes() == (whole / "particles.ply").read_bytes()
    assert len((resumed / "frames.csv").read_text().strip().splitlines()) == 5
    other = run_cli("sandstone", scene, resumed, "--frames", "5", "--seed", "4", "--resume", *FAST)
    assert other.returncode == 2 and "seed" in other.stderr


def test_an_extruded_dem_keeps_its_grid_and_crs(tmp_path: Path) -> None:
    rows, cols = np.mgrid[0:12, 0:16]
    dem = (105.0 + 0.4 * cols + 0.2 * rows).astype(np.float32)
    source = write_geotiff(tmp_path / "dem.tif", dem)
    out = tmp_path / "block"
    result = run_cli("sandstone", source, out, "--extrude", "100", "--particles", "6000", "--frames", "1",
                     "--top-format", "exr", *FAST)
    assert result.returncode == 0, result.stderr
    terrain = read_terrain(out / "top.exr")
    assert terrain.shape == dem.shape and terrain.dx == pytest.approx(30.0)
    assert "32632" in terrain.crs_wkt or "UTM zone 32N" in terrain.crs_wkt
    spacing = json.loads((out / "run.json").read_text())["parameters"]["lattice_spacing_m"]
    assert np.abs(terrain.elevation - dem).max() < spacing


@pytest.mark.parametrize("args, says", [
    (("--frames", "0"), "--frames"),
    (("--particles", "1000000000000"), "memory"),
    (("--color-by", "heat"), "--color-by"),
])
def test_bad_options_are_refused_before_any_output(tmp_path: Path, args: tuple[str, ...], says: str) -> None:
    out = tmp_path / "out"
    result = run_cli("sandstone", _scene(tmp_path), out, *args)
    _assert_refused(result, out, says)


@pytest.mark.parametrize("replace, by, says", [
    ("cylinder:", "cone:", "unknown shape 'cone'"),
    ("- {k_w: 1e-4,", "- {top: 2, k_w: 1e-4,", "increase"),
    ("size: [20, 12, 14]", "size: [20, -12, 14]", "positive"),
])
def test_malformed_scenes_are_refused(tmp_path: Path, replace: str, by: str, says: str) -> None:
    out = tmp_path / "out"
    result = run_cli("sandstone", _scene(tmp_path, SCENE.replace(replace, by)), out)
    _assert_refused(result, out, says)


def test_a_dem_needs_extrude_and_a_preset_does_not_take_it(tmp_path: Path) -> None:
    dem = write_geotiff(tmp_path / "dem.tif", np.ones((4, 4), np.float32))
    _assert_refused(run_cli("sandstone", dem, tmp_path / "a"), tmp_path / "a", "--extrude")
    _assert_refused(run_cli("sandstone", "arch", tmp_path / "b", "--extrude", "0"), tmp_path / "b",
                    "--extrude")
    _assert_refused(run_cli("sandstone", "mesa", tmp_path / "c"), tmp_path / "c", "preset")


def _assert_refused(result, out: Path, says: str) -> None:
    assert result.returncode == 2, result.stderr
    lines = [line for line in result.stderr.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert says.lower() in lines[0].lower()
    assert not out.exists()


def test_a_scene_carries_the_frames_and_time_step_its_landform_needs(tmp_path: Path) -> None:
    """``run: {frames, dt}`` in a scene sets the defaults of --frames and --dt; the options win;
    a wind rose is read from the scene."""
    scene = _scene(tmp_path, SCENE.replace("wind: {azimuth: 180, speed: 10}",
                                           "wind: {speed: 10, rose: [{azimuth: 0, weight: 1}, "
                                           "{azimuth: 180, weight: 3}]}\nrun: {frames: 3, dt: 2500}"))
    out = tmp_path / "run"
    assert run_cli("sandstone", scene, out, *FAST).returncode == 0
    run = json.loads((out / "run.json").read_text())
    assert run["statistics"]["frames"] == 3 and run["parameters"]["dt_years"] == 2500.0
    assert run["parameters"]["wind"]["rose"] == [[0.0, 1.0], [180.0, 3.0]]
    given = run_cli("sandstone", scene, tmp_path / "given", "--frames", "2", "--dt", "100", *FAST)
    assert given.returncode == 0, given.stderr
    run = json.loads((tmp_path / "given" / "run.json").read_text())
    assert run["statistics"]["frames"] == 2 and run["parameters"]["dt_years"] == 100.0


def test_help_lists_every_preset_without_loading_numba() -> None:
    """The presets named in ``--help`` (a static list, so that --help need not load the scene
    parser or numba) are those of ``sandstone.presets``."""
    from unerode_cli.sandstone.presets import PRESETS

    assert PRESET_NAMES == tuple(PRESETS)
    result = subprocess.run([sys.executable, "-c", HELP_PROBE], capture_output=True, text=True, timeout=120,
                            env={**os.environ, "COLUMNS": "100"})
    text = " ".join(result.stdout.replace("│", " ").split())
    assert f"a preset ({', '.join(PRESETS)}), or a DEM" in text, text
    assert "NUMBA=False" in result.stderr


def test_a_mesh_in_the_out_dir_that_the_run_creates(tmp_path: Path) -> None:
    """``--mesh OUT_DIR/rock.obj`` is accepted before OUT_DIR exists: the job creates OUT_DIR."""
    out = tmp_path / "run"
    result = run_cli("sandstone", "arch", out, "--particles", "3000", "--frames", "1", "--mesh",
                     out / "rock.obj", *FAST)
    assert result.returncode == 0, result.stderr
    assert (out / "rock.obj").stat().st_size > 1000
    assert json.loads((out / "run.json").read_text())["statistics"]["mesh"]["faces"] > 100
    nested = run_cli("sandstone", "arch", tmp_path / "other", "--particles", "3000", "--frames", "1",
                     "--mesh", tmp_path / "other" / "sub" / "rock.obj", *FAST)
    _assert_refused(nested, tmp_path / "other", "does not exist")


def test_npz_snapshots_hold_the_columns_of_the_ply(tmp_path: Path) -> None:
    """``--snapshot-format npz``: the snapshot of the last frame holds particles.ply's columns,
    value for value, in a compressed archive smaller than the PLY."""
    out = tmp_path / "run"
    result = run_cli("sandstone", _scene(tmp_path), out, "--frames", "2", "--snapshot-every", "2",
                     "--snapshot-format", "npz", *FAST)
    assert result.returncode == 0, result.stderr
    snapshot = out / "snapshots" / "frame_00002.npz"
    assert not (out / "snapshots" / "frame_00002.ply").exists()
    npz, origin = read_particle_ply(snapshot)
    ply, ply_origin = read_particle_ply(out / "particles.ply")
    assert npz.keys() == ply.keys() and origin == ply_origin
    assert all(npz[k].dtype == ply[k].dtype for k in ply)
    assert all(np.array_equal(npz[k], ply[k]) for k in ply if k not in ("nx", "ny", "nz"))
    for k in ("nx", "ny", "nz"):   # int8 steps of 1/127 in the archive
        np.testing.assert_allclose(npz[k], ply[k], atol=0.5 / 127 + 1e-7)
    assert snapshot.stat().st_size < (out / "particles.ply").stat().st_size / 3
    with np.load(snapshot) as plain:   # a plain archive: 4-byte columns as their byte planes
        assert "x" in plain["byte_planes"] and plain["x"].shape == (4, len(ply["x"]))
        x = np.ascontiguousarray(plain["x"].T).view(plain["plane_types"][0]).ravel()
        assert np.array_equal(x, ply["x"])
