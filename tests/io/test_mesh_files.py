"""Mesh files: PLY and OBJ round trips (float32 / micrometre tolerance), the byte layout of the
binary PLY and the lines of the OBJ, the header's origin and CRS, and refused outputs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from unerode_cli.errors import InputError
from unerode_cli.io.mesh_files import UNKNOWN_MATERIAL, mesh_format, read_mesh, write_mesh
from unerode_cli.volume.mesh import Mesh, material_colours

ORIGIN = (512345.25, 5012345.5, 0.0)
WKT = 'PROJCS["WGS 84 / UTM zone 32N",\n  GEOGCS["WGS 84"]]'


@pytest.fixture
def mesh() -> Mesh:
    rng = np.random.default_rng(4)
    vertices = rng.uniform(-50.0, 1500.0, (200, 3))
    faces = rng.integers(0, 200, (350, 3)).astype(np.int32)
    materials = rng.integers(0, 12, 200).astype(np.int16)
    return Mesh(vertices, faces, materials, material_colours(materials))


def test_ply_round_trip(tmp_path: Path, mesh: Mesh) -> None:
    path = tmp_path / "rock.ply"
    write_mesh(path, mesh, origin=ORIGIN, crs_wkt=WKT, comments=("frame 3",))
    back, origin = read_mesh(path)
    assert origin == ORIGIN
    assert np.array_equal(back.vertices, mesh.vertices.astype(np.float32).astype(np.float64))
    assert np.allclose(back.vertices, mesh.vertices, rtol=1e-7, atol=0.0)
    assert np.array_equal(back.faces, mesh.faces)
    assert np.array_equal(back.materials, mesh.materials) and np.array_equal(back.colours, mesh.colours)
    data = path.read_bytes()
    header_end = data.index(b"end_header\n") + len(b"end_header\n")
    # x y z float32, r g b uchar, material int32 per vertex; a uchar count and 3 int32 per face
    assert len(data) - header_end == 200 * (3 * 4 + 3 + 4) + 350 * (1 + 3 * 4)
    header = data[:header_end].decode("ascii")
    assert "comment crs PROJCS[\"WGS 84 / UTM zone 32N\", GEOGCS[\"WGS 84\"]]" in header
    assert "element face 350\nproperty list uchar int vertex_indices" in header
    assert np.frombuffer(data, "<f4", count=1, offset=header_end)[0] == np.float32(mesh.vertices[0, 0])


def test_obj_round_trip(tmp_path: Path, mesh: Mesh) -> None:
    path = tmp_path / "rock.OBJ"
    write_mesh(path, mesh, origin=ORIGIN, crs_wkt=WKT)
    back, origin = read_mesh(path)
    assert origin == ORIGIN
    assert np.allclose(back.vertices, mesh.vertices, rtol=0.0, atol=5e-7)
    assert np.array_equal(back.faces, mesh.faces) and np.array_equal(back.colours, mesh.colours)
    assert np.all(back.materials == UNKNOWN_MATERIAL)
    lines = path.read_text().splitlines()
    assert "# units: metres (x east, y north, z up), relative to the origin" in lines
    assert sum(line.startswith("v ") for line in lines) == 200
    first_face = next(line for line in lines if line.startswith("f "))
    assert list(map(int, first_face.split()[1:])) == list(mesh.faces[0] + 1)  # 1-based
    first_vertex = next(line for line in lines if line.startswith("v ")).split()
    assert float(first_vertex[4]) == pytest.approx(mesh.colours[0, 0] / 255.0, abs=1e-6)


@pytest.mark.parametrize("name", ["empty.ply", "empty.obj"])
def test_an_empty_mesh_round_trips(tmp_path: Path, name: str) -> None:
    write_mesh(tmp_path / name, Mesh.empty())
    back, origin = read_mesh(tmp_path / name)
    assert back.vertices.shape == (0, 3) and back.faces.shape == (0, 3) and origin == (0.0, 0.0, 0.0)


def test_an_existing_file_is_kept_without_overwrite(tmp_path: Path, mesh: Mesh) -> None:
    path = tmp_path / "rock.ply"
    path.write_bytes(b"keep")
    with pytest.raises(InputError, match="--overwrite"):
        write_mesh(path, mesh)
    assert path.read_bytes() == b"keep"
    write_mesh(path, mesh, overwrite=True)
    assert len(read_mesh(path)[0].vertices) == 200
    assert [p.name for p in tmp_path.iterdir()] == ["rock.ply"]  # no temporary left


def test_an_unknown_extension_is_one_sentence_naming_both_formats(tmp_path: Path, mesh: Mesh) -> None:
    with pytest.raises(ValueError, match=r"\.ply or \.obj, not 'rock\.stl'") as caught:
        write_mesh(tmp_path / "rock.stl", mesh)
    assert "\n" not in str(caught.value) and not (tmp_path / "rock.stl").exists()
    assert mesh_format(Path("a/b.Ply")) == ".ply"
