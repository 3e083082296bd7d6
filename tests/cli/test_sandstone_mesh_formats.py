"""`unerode-cli sandstone` meshes for DCC tools: a glTF binary with one material per layer and
the particles' stress, viability and layer per vertex; OBJ with its MTL; --mesh-cell;
--mesh-every; and their refusals before any simulation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from tests.cli.test_sandstone_mesh import FAST, _assert_refused, _scene
from tests.conftest import run_cli
from tests.volume.conftest import assert_watertight

from unerode_cli.io.mesh_files import read_mesh_file
from unerode_cli.io.particle_ply import read_particle_ply

pytest.importorskip("trimesh")


@pytest.fixture(scope="module")
def glb_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two frames of the two-layer block, a glb of each frame and one at the end (cell s/2)."""
    tmp = tmp_path_factory.mktemp("glb")
    out = tmp / "run"
    result = run_cli("sandstone", _scene(tmp), out, "--frames", "2", "--mesh", out / "rock.glb",
                     "--mesh-every", "1", "--mesh-cell", "0.25", *FAST)
    assert result.returncode == 0, result.stderr
    return out


def test_the_glb_carries_one_material_per_layer_and_the_particles_values(glb_run: Path) -> None:
    read = read_mesh_file(glb_run / "rock.glb")
    mesh = read.mesh
    assert read.up == "y"
    assert_watertight(mesh.faces)
    assert set(np.unique(mesh.materials)) == {0, 1}       # the block's two layers
    particles, _ = read_particle_ply(glb_run / "particles.ply")
    positions = np.column_stack([particles[a] for a in "xyz"])
    assert mesh.vertices[:, 2].max() == pytest.approx(positions[:, 2].max(), abs=0.5)
    # each vertex has the values of its nearest particle
    nearest = np.argmin(((mesh.vertices[::50, None, :] - positions[None, :, :]) ** 2).sum(axis=2), axis=1)
    np.testing.assert_allclose(read.attributes["stress"][::50], particles["stress"][nearest], rtol=1e-6)
    np.testing.assert_array_equal(read.attributes["layer"][::50], particles["layer"][nearest])
    record = json.loads((glb_run / "run.json").read_text())["statistics"]["mesh"]
    assert record["cell_m"] == 0.25 and record["up"] == "y"
    assert record["vertices"] == len(mesh.vertices)


def test_mesh_every_writes_each_frame(glb_run: Path) -> None:
    frames = sorted(p.name for p in (glb_run / "meshes").iterdir())
    assert frames == ["frame_00001.glb", "frame_00002.glb"]
    last = read_mesh_file(glb_run / "meshes" / "frame_00002.glb").mesh
    final = read_mesh_file(glb_run / "rock.glb").mesh
    assert np.array_equal(last.faces, final.faces) and np.array_equal(last.vertices, final.vertices)


def test_a_finer_cell_gives_a_finer_mesh_of_the_same_rock(tmp_path: Path, glb_run: Path) -> None:
    out = tmp_path / "coarse"
    result = run_cli("sandstone", _scene(tmp_path), out, "--frames", "2", "--mesh", out / "rock.glb", *FAST)
    assert result.returncode == 0, result.stderr
    coarse = json.loads((out / "run.json").read_text())["statistics"]["mesh"]
    fine = json.loads((glb_run / "run.json").read_text())["statistics"]["mesh"]
    assert fine["vertices"] / coarse["vertices"] == pytest.approx(4.0, rel=0.4)   # cell halved
    assert fine["enclosed_volume_m3"] == pytest.approx(coarse["enclosed_volume_m3"], rel=0.03)


def test_an_obj_comes_with_its_mtl_which_is_not_overwritten(tmp_path: Path) -> None:
    mesh = tmp_path / "rock.obj"
    (tmp_path / "rock.mtl").write_text("newmtl mine\n")
    out = tmp_path / "run"
    result = run_cli("sandstone", _scene(tmp_path), out, "--frames", "1", "--mesh", mesh, *FAST)
    _assert_refused(result, out, "rock.mtl already exists")
    assert (tmp_path / "rock.mtl").read_text() == "newmtl mine\n" and not mesh.exists()


@pytest.mark.parametrize(("options", "says"), [
    (("--mesh-cell", "0.5"), "--mesh-cell sets the cell of --mesh or --mesh-every"),
    (("--mesh-every", "1", "--mesh", "rock.stl"), "--mesh: a mesh is written as .ply, .obj or .glb"),
    (("--mesh", "rock.glb", "--mesh-cell", "0.001"), "choose a coarser --mesh-cell"),
])
def test_mesh_options_are_refused_before_the_run(tmp_path: Path, options: tuple[str, ...], says: str) -> None:
    out = tmp_path / "run"
    options = tuple(str(tmp_path / o) if o.startswith("rock.") else o for o in options)
    result = run_cli("sandstone", _scene(tmp_path), out, "--frames", "1", *options, *FAST)
    _assert_refused(result, out, says)
