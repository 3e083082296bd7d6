"""`unerode-cli sandstone --mesh`: the surface mesh of the final particles, its sidecar record,
and the options refused before any simulation (unknown extension, scikit-image missing)."""

from __future__ import annotations

import inspect
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from affine import Affine
from tests.conftest import run_cli, write_geotiff
from tests.volume.conftest import assert_watertight

from unerode_cli.io.mesh_files import read_mesh
from unerode_cli.io.particle_ply import read_particle_ply
from unerode_cli.volume.mesh import PALETTE, enclosed_volume
from unerode_cli.volume.particle_surface import SMOOTHING

SCENE = """
domain: {size: [16, 12, 10]}
particles: 8000
shape: {box: {min: [2, 2, 0], max: [14, 10, 8]}}
layers:
  - {top: 4, k_w: 1e-5}
  - {k_w: 1e-5}
wind: {azimuth: 180, speed: 1}
"""
FAST = ("--substeps", "5", "--settle-substeps", "50", "--no-deposition", "-q")


def _scene(tmp_path: Path) -> Path:
    path = tmp_path / "block.yaml"
    path.write_text(SCENE)
    return path


def _assert_refused(result: subprocess.CompletedProcess[str], out: Path, says: str) -> None:
    assert result.returncode == 2, result.stderr
    message = result.stderr.strip()
    assert says in message and len(message.splitlines()) == 1 and "Traceback" not in message
    assert not out.exists()  # refused in the plan, before any simulation


def test_a_block_run_writes_a_closed_mesh_of_its_particles(tmp_path: Path) -> None:
    out, mesh_path = tmp_path / "run", tmp_path / "block.obj"
    result = run_cli("sandstone", _scene(tmp_path), out, "--frames", "1", "--mesh", mesh_path, *FAST)
    assert result.returncode == 0, result.stderr
    mesh, origin = read_mesh(mesh_path)
    assert origin == (0.0, 0.0, 0.0)
    assert_watertight(mesh.faces)
    run = json.loads((out / "run.json").read_text())
    record = run["statistics"]["mesh"]
    assert (record["vertices"], record["faces"]) == (len(mesh.vertices), len(mesh.faces))
    assert record["smoothing_iterations"] == SMOOTHING
    particles, _ = read_particle_ply(out / "particles.ply")
    spacing = run["parameters"]["lattice_spacing_m"]
    assert enclosed_volume(mesh) == pytest.approx(len(particles["x"]) * spacing**3, rel=0.05)
    assert record["enclosed_volume_m3"] == pytest.approx(enclosed_volume(mesh), rel=1e-5)
    assert mesh.vertices[:, 2].min() == 0.0  # closed by the ground
    assert np.all(np.abs(mesh.vertices.min(axis=0)[:2] - 2.0) < spacing)
    assert np.all(np.abs(mesh.vertices.max(axis=0) - [14.0, 10.0, 8.0]) < spacing)
    top, bottom = mesh.vertices[:, 2] > 6.0, mesh.vertices[:, 2] < 2.0
    assert np.all(mesh.colours[top] == PALETTE[1]) and np.all(mesh.colours[bottom] == PALETTE[0])


@pytest.mark.slow
def test_the_arch_preset_end_to_end(tmp_path: Path) -> None:
    out, mesh_path = tmp_path / "arch", tmp_path / "out.ply"
    result = run_cli("sandstone", "arch", out, "--particles", "20000", "--frames", "2", "--mesh", mesh_path,
                     "-q")
    assert result.returncode == 0, result.stderr
    mesh, _ = read_mesh(mesh_path)
    assert_watertight(mesh.faces)
    run = json.loads((out / "run.json").read_text())
    particles, _ = read_particle_ply(out / "particles.ply")
    spacing = run["parameters"]["lattice_spacing_m"]
    assert enclosed_volume(mesh) == pytest.approx(len(particles["x"]) * spacing**3, rel=0.05)
    assert run["statistics"]["mesh"]["faces"] == len(mesh.faces)
    # the fin (2-54 m × 2-10 m, 36 m high) and its cap layer (from 26 m) on top
    assert np.all(np.abs(mesh.vertices.max(axis=0) - [54.0, 10.0, 36.0]) < spacing)
    cap = mesh.vertices[:, 2] > 28.0
    assert cap.sum() > 100 and np.all(mesh.materials[cap] == 3) and np.all(mesh.colours[cap] == PALETTE[3])
    slit = (np.abs(mesh.vertices[:, 0] - 28.0) < 8.0) & (np.abs(mesh.vertices[:, 2] - 2.0) < 0.3)
    assert slit.sum() > 10  # the slit's roof under the fin is a face of the mesh


def test_an_unknown_mesh_extension_is_refused_before_the_run(tmp_path: Path) -> None:
    out = tmp_path / "run"
    result = run_cli("sandstone", "arch", out, "--mesh", tmp_path / "rock.stl", "--frames", "1")
    _assert_refused(result, out, "--mesh: a mesh is written as .ply, .obj or .glb, not 'rock.stl'.")


def test_without_scikit_image_the_mesh_is_refused_with_the_extra_to_install(tmp_path: Path) -> None:
    out = tmp_path / "run"
    blocked = ("import sys; sys.modules['skimage'] = None; sys.argv[0] = 'unerode-cli'; "
               "from unerode_cli.cli.app import main; main()")
    result = subprocess.run([sys.executable, "-c", blocked, "sandstone", "arch", str(out), "--mesh",
                             str(tmp_path / "rock.ply"), "--frames", "1"],
                            capture_output=True, text=True, timeout=300)
    _assert_refused(result, out, "pip install 'unerode-cli[mesh]'")


def test_an_existing_mesh_or_a_missing_folder_is_refused(tmp_path: Path) -> None:
    out, existing = tmp_path / "run", tmp_path / "rock.ply"
    existing.write_bytes(b"keep")
    result = run_cli("sandstone", "arch", out, "--mesh", existing, "--frames", "1")
    _assert_refused(result, out, "--overwrite")
    assert existing.read_bytes() == b"keep"
    result = run_cli("sandstone", "arch", out, "--mesh", tmp_path / "no" / "rock.ply", "--frames", "1")
    _assert_refused(result, out, "of output rock.ply does not exist")


def test_the_command_line_default_smoothing_is_the_library_default() -> None:
    from unerode_cli.cli.sandstone import sandstone

    assert inspect.signature(sandstone).parameters["mesh_smoothing"].default == SMOOTHING


@pytest.mark.slow
def test_the_mesh_of_an_extruded_dem_gives_its_south_west_corner_and_crs(tmp_path: Path) -> None:
    hill = 100.0 + 20.0 * np.exp(-((np.indices((20, 24)) - 10.0) ** 2).sum(axis=0) / 30.0)
    corner = Affine(2.0, 0.0, 500000.0, 0.0, -2.0, 5000040.0)  # 2 m cells, north-west corner
    dem = write_geotiff(tmp_path / "hill.tif", hill.astype(np.float32), corner)
    out, mesh_path = tmp_path / "run", tmp_path / "hill.obj"
    result = run_cli("sandstone", dem, out, "--extrude", "95", "--particles", "5000", "--frames", "1",
                     "--mesh", mesh_path, *FAST)
    assert result.returncode == 0, result.stderr
    mesh, origin = read_mesh(mesh_path)
    assert origin == (500000.0, 5000000.0, 0.0)  # the DEM's south-west corner: x, y from 0 in the file
    assert "UTM zone 32N" in mesh_path.read_text().split("\nv ")[0]
    assert_watertight(mesh.faces)
    assert mesh.vertices[:, 2].min() == 95.0  # the ground: the extrusion's base
    assert mesh.vertices[:, 2].max() == pytest.approx(hill.max(), abs=1.0)
    assert np.all(np.abs(mesh.vertices.max(axis=0)[:2] - [48.0, 40.0]) < 1.0)
