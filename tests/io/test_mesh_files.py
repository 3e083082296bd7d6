"""Mesh files: PLY and OBJ round trips (float32 / micrometre tolerance), the byte layout of the
binary PLY and the lines of the OBJ and its MTL, the Y-up rotation (upright, right-handed,
faces still outwards: trimesh's volume), the header's origin and CRS, refused outputs, and the
normals and box UVs the files carry (against radial directions and the projection's table)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from unerode_cli.errors import InputError
from unerode_cli.io.mesh_files import (
    UNKNOWN_MATERIAL,
    face_materials,
    layer_material_names,
    mesh_format,
    mesh_sidecars,
    read_mesh,
    read_mesh_file,
    write_mesh,
)
from unerode_cli.volume.mesh import (
    PALETTE,
    Mesh,
    enclosed_volume,
    linear_colours,
    material_colours,
    surface_mesh,
    vertex_normals,
)
from unerode_cli.volume.uv_projection import box_uv

ORIGIN = (512345.25, 5012345.5, 0.0)
WKT = 'PROJCS["WGS 84 / UTM zone 32N",\n  GEOGCS["WGS 84"]]'
ROCK_NAMES = ("sand stone", "cap")


def rock_mesh() -> Mesh:
    """A closed two-material mesh whose extents differ on each axis: the ellipsoid of semi-axes
    4, 3, 2 m around (15, 1, 4.5) m (x 11-19, y −2-4, z 2.5-6.5), material 1 (the cap) above
    z = 5 m, 0 below."""
    h, shape, low = 0.5, (20, 16, 12), np.array([10.0, -3.0, 2.0])
    nodes = np.moveaxis(np.indices(shape) * h, 0, -1) + low
    radius = np.linalg.norm((nodes - [15.0, 1.0, 4.5]) / [4.0, 3.0, 2.0], axis=-1)
    density = np.clip(4.0 * (1.0 - radius) + 0.5, 0.0, 1.0)
    return surface_mesh(density, tuple(low), h, materials=(nodes[..., 2] > 5.0).astype(np.int16))


def rock_attributes(mesh: Mesh) -> dict[str, np.ndarray]:
    """Per-vertex attributes of :func:`rock_mesh`: a ramp, the height and the layer."""
    return {"stress": np.linspace(0.0, 1.0, len(mesh.vertices)), "viability": mesh.vertices[:, 2] * 0.1,
            "layer": mesh.materials.astype(float)}


@pytest.fixture
def mesh() -> Mesh:
    rng = np.random.default_rng(4)
    vertices = rng.uniform(-50.0, 1500.0, (200, 3))
    faces = rng.integers(0, 200, (350, 3)).astype(np.int32)
    materials = rng.integers(0, 12, 200).astype(np.int16)
    return Mesh(vertices, faces, materials, material_colours(materials))


def test_ply_round_trip(tmp_path: Path, mesh: Mesh) -> None:
    path = tmp_path / "rock.ply"
    stress = np.linspace(-1.0, 1.0, 200)
    write_mesh(path, mesh, origin=ORIGIN, crs_wkt=WKT, comments=("frame 3",), attributes={"Stress": stress})
    read = read_mesh_file(path)
    back, origin = read_mesh(path)
    assert origin == ORIGIN == read.origin and read.crs_wkt == ' '.join(WKT.split()) and read.up == "z"
    assert np.array_equal(back.vertices, mesh.vertices.astype(np.float32).astype(np.float64))
    assert np.allclose(back.vertices, mesh.vertices, rtol=1e-7, atol=0.0)
    assert np.array_equal(back.faces, mesh.faces)
    assert np.array_equal(back.materials, mesh.materials) and np.array_equal(back.colours, mesh.colours)
    assert list(read.attributes) == ["stress"]
    assert np.array_equal(read.attributes["stress"], stress.astype(np.float32))
    data = path.read_bytes()
    header_end = data.index(b"end_header\n") + len(b"end_header\n")
    # x y z nx ny nz s t float32, r g b uchar, material int32, stress float32 per vertex;
    # a uchar count and 3 int32 per face
    assert len(data) - header_end == 200 * (8 * 4 + 3 + 4 + 4) + 350 * (1 + 3 * 4)
    header = data[:header_end].decode("ascii")
    assert "comment crs PROJCS[\"WGS 84 / UTM zone 32N\", GEOGCS[\"WGS 84\"]]" in header
    assert "comment up: z " in header
    assert ("property float nx\nproperty float ny\nproperty float nz\nproperty float s\nproperty float t\n"
            "property uchar red") in header
    assert "property int material\nproperty float stress\nelement face 350" in header
    assert "element face 350\nproperty list uchar int vertex_indices" in header
    assert np.frombuffer(data, "<f4", count=1, offset=header_end)[0] == np.float32(mesh.vertices[0, 0])
    normals = np.frombuffer(data, "<f4", count=3, offset=header_end + 12)
    assert np.allclose(normals, vertex_normals(mesh.vertices, mesh.faces)[0], atol=1e-6)


def test_a_ply_without_normals_uvs_or_attributes_reads(tmp_path: Path, mesh: Mesh) -> None:
    layout = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("red", "u1"), ("green", "u1"),
                       ("blue", "u1"), ("material", "<i4")])
    vertices = np.empty(200, dtype=layout)
    for a, name in enumerate("xyz"):
        vertices[name] = mesh.vertices[:, a]
    for a, name in enumerate(("red", "green", "blue")):
        vertices[name] = mesh.colours[:, a]
    vertices["material"] = mesh.materials
    faces = np.empty(350, dtype=[("count", "u1"), ("indices", "<i4", (3,))])
    faces["count"], faces["indices"] = 3, mesh.faces
    header = ("ply\nformat binary_little_endian 1.0\ncomment origin 1.0 2.0 3.0\nelement vertex 200\n"
              + "".join(f"property {t} {n}\n" for t, n in (("float", "x"), ("float", "y"), ("float", "z"),
                        ("uchar", "red"), ("uchar", "green"), ("uchar", "blue"), ("int", "material")))
              + "element face 350\nproperty list uchar int vertex_indices\nend_header\n")
    (tmp_path / "old.ply").write_bytes(header.encode() + vertices.tobytes() + faces.tobytes())
    back, origin = read_mesh(tmp_path / "old.ply")
    assert origin == (1.0, 2.0, 3.0)
    assert np.allclose(back.vertices, mesh.vertices, rtol=1e-7) and np.array_equal(back.faces, mesh.faces)
    assert np.array_equal(back.materials, mesh.materials) and np.array_equal(back.colours, mesh.colours)


@pytest.mark.parametrize("up", ["y", "z"])
def test_obj_round_trip(tmp_path: Path, mesh: Mesh, up: str) -> None:
    path = tmp_path / "rock.OBJ"
    write_mesh(path, mesh, origin=ORIGIN, crs_wkt=WKT, up=up)
    back, origin = read_mesh(path)
    assert origin == ORIGIN and read_mesh_file(path).up == up
    assert np.allclose(back.vertices, mesh.vertices, rtol=0.0, atol=5e-7)
    grouped = mesh.faces[np.argsort(face_materials(mesh.faces, mesh.materials), kind="stable")]
    assert np.array_equal(back.faces, grouped) and np.array_equal(back.colours, mesh.colours)
    assert np.all(back.materials == UNKNOWN_MATERIAL)
    lines = path.read_text().splitlines()
    assert "# units: metres (x east, y north, z up), relative to the origin" in lines
    assert sum(line.startswith("v ") for line in lines) == 200
    assert sum(line.startswith("vt ") for line in lines) == 200
    assert sum(line.startswith("vn ") for line in lines) == 200
    first_face = next(line for line in lines if line.startswith("f "))
    assert [c.split("/") for c in first_face.split()[1:]] == [[str(i + 1)] * 3 for i in grouped[0]]  # 1-based
    first_vertex = [float(w) for w in next(line for line in lines if line.startswith("v ")).split()[1:]]
    assert first_vertex[3] == pytest.approx(mesh.colours[0, 0] / 255.0, abs=1e-6)
    x, y, z = mesh.vertices[0]
    assert first_vertex[:3] == pytest.approx([x, z, -y] if up == "y" else [x, y, z], abs=5e-7)


def _obj_groups(lines: list[str]) -> tuple[list[str | None], list[str]]:
    """The ``usemtl`` name each face of an OBJ comes under (None before any) and the ``mtllib``s."""
    current: str | None = None
    groups = []
    for line in lines:
        if line.startswith("usemtl "):
            current = line.split(None, 1)[1]
        elif line.startswith("f "):
            groups.append(current)
    return groups, [line.split(None, 1)[1] for line in lines if line.startswith("mtllib ")]


def test_an_obj_of_two_layers_has_its_materials_and_stands_upright(tmp_path: Path) -> None:
    trimesh = pytest.importorskip("trimesh")
    rock = rock_mesh()
    path = tmp_path / "rock.obj"
    write_mesh(path, rock, material_names=ROCK_NAMES)
    assert mesh_sidecars(path) == (tmp_path / "rock.mtl",)
    lines = path.read_text().splitlines()
    groups, libraries = _obj_groups(lines)
    assert libraries == ["rock.mtl"] and len(groups) == len(rock.faces)
    assert set(groups) == {"sand_stone", "cap"}
    expected = np.where(face_materials(rock.faces, rock.materials) == 1, "cap", "sand_stone")
    assert sorted(groups) == sorted(expected.tolist())
    materials: dict[str, dict[str, list[float]]] = {}
    for line in (tmp_path / "rock.mtl").read_text().splitlines():
        words = line.split()
        if words[:1] == ["newmtl"]:
            current = materials.setdefault(words[1], {})
        elif words and words[0] in {"Kd", "Ka", "Ks", "d", "illum"}:
            current[words[0]] = [float(w) for w in words[1:]]
    assert list(materials) == ["sand_stone", "cap"]
    for name, layer in (("sand_stone", 0), ("cap", 1)):
        assert materials[name]["Kd"] == pytest.approx(linear_colours(PALETTE[layer]), abs=1e-5)
        assert materials[name]["Ka"] == [0.0] * 3 and materials[name]["Ks"] == [0.0] * 3
        assert materials[name]["d"] == [1.0] and materials[name]["illum"] == [1.0]
    positions = np.array([[float(w) for w in line.split()[1:4]] for line in lines if line.startswith("v ")])
    assert positions[:, 1].max() == pytest.approx(rock.vertices[:, 2].max(), abs=1e-5)   # Y up
    assert positions[:, 2].max() == pytest.approx(-rock.vertices[:, 1].min(), abs=1e-5)  # Z south
    scene = trimesh.load(path)   # one geometry per material; their border vertices merged by position
    loaded = trimesh.util.concatenate(list(scene.geometry.values()))
    loaded.merge_vertices(merge_tex=True, merge_norm=True)
    assert loaded.is_watertight
    assert loaded.volume > 0.0
    assert loaded.volume == pytest.approx(enclosed_volume(rock), rel=1e-6)


def test_a_face_takes_the_material_of_two_of_its_vertices_else_its_first() -> None:
    faces = np.array([[0, 1, 2], [0, 1, 3], [3, 4, 5], [1, 0, 4]])
    materials = np.array([0, 1, 1, 2, 2, 5])
    assert face_materials(faces, materials).tolist() == [1, 0, 2, 1]


def test_material_names_are_sanitised_unique_and_default_to_the_layer() -> None:
    layers = np.array([0, 1, 2, 3, 4])
    names = ["sand stone", "sand_stone", "", "cap/rock"]
    assert layer_material_names(layers, names) == ["sand_stone", "sand_stone_1", "layer_2", "cap_rock",
                                                   "layer_4"]
    assert layer_material_names(layers[:2], None) == ["layer_0", "layer_1"]


def test_an_existing_mtl_is_refused_before_any_file_is_written(tmp_path: Path, mesh: Mesh) -> None:
    (tmp_path / "rock.mtl").write_text("keep")
    with pytest.raises(InputError, match="rock.mtl already exists; pass --overwrite"):
        write_mesh(tmp_path / "rock.obj", mesh)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rock.mtl"]
    assert (tmp_path / "rock.mtl").read_text() == "keep"
    (tmp_path / "rock.mtl").unlink()
    (tmp_path / "rock.obj").write_text("keep")
    with pytest.raises(InputError, match="--overwrite"):
        write_mesh(tmp_path / "rock.obj", mesh)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rock.obj"]
    write_mesh(tmp_path / "rock.obj", mesh, overwrite=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rock.mtl", "rock.obj"]


@pytest.mark.parametrize("name", ["empty.ply", "empty.obj", "empty.glb"])
def test_an_empty_mesh_round_trips(tmp_path: Path, name: str) -> None:
    if name.endswith(".glb"):
        pytest.importorskip("trimesh")
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


def test_an_unknown_extension_is_one_sentence_naming_the_formats(tmp_path: Path, mesh: Mesh) -> None:
    with pytest.raises(ValueError, match=r"\.ply, \.obj or \.glb, not 'rock\.stl'") as caught:
        write_mesh(tmp_path / "rock.stl", mesh)
    assert "\n" not in str(caught.value) and not (tmp_path / "rock.stl").exists()
    assert mesh_format(Path("a/b.Ply")) == ".ply"


@pytest.mark.parametrize(("attributes", "up", "says"), [
    ({"x": np.zeros(200)}, "y", "not 'x'"), ({"2nd": np.zeros(200)}, "y", "not '2nd'"),
    ({"stress": np.zeros(199)}, "y", r"shape \(199,\), not \(200,\)"), ({}, "x", "up is 'y' or 'z'")])
def test_bad_attributes_or_axes_are_refused_before_writing(tmp_path: Path, mesh: Mesh, attributes, up: str,
                                                          says: str) -> None:
    with pytest.raises(ValueError, match=says):
        write_mesh(tmp_path / "rock.ply", mesh, attributes=attributes, up=up)
    assert list(tmp_path.iterdir()) == []


def test_sphere_normals_point_radially() -> None:
    nodes = np.moveaxis(np.indices((24, 24, 24)) * 0.5 - 5.75, 0, -1)
    density = np.clip(4.0 - np.linalg.norm(nodes, axis=-1) + 0.5, 0.0, 1.0)
    ball = surface_mesh(density, (-5.75, -5.75, -5.75), 0.5)
    normals = vertex_normals(ball.vertices, ball.faces)
    radial = ball.vertices / np.linalg.norm(ball.vertices, axis=1, keepdims=True)
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", normals, radial), -1.0, 1.0)))
    assert angle.max() < 5.0


def _hard_cube(low: np.ndarray, side: float) -> Mesh:
    """A cube with hard edges: four vertices of its own per face (so each vertex's normal is its
    face's), two triangles per face counter-clockwise seen from outside."""
    corners, faces = [], []
    for axis in range(3):
        b, c = (axis + 1) % 3, (axis + 2) % 3          # e_b × e_c = e_axis
        for sign in (-1, 1):
            square = [(0, 0), (1, 0), (1, 1), (0, 1)][:: sign]
            for u, v in square:
                point = np.zeros(3)
                point[axis], point[b], point[c] = (sign + 1) / 2, u, v
                corners.append(low + side * point)
            first = len(corners) - 4
            faces += [[first, first + 1, first + 2], [first, first + 2, first + 3]]
    return Mesh(np.array(corners), np.array(faces, dtype=np.int32), np.zeros(24, dtype=np.int16),
                material_colours(np.zeros(24, dtype=np.int64)))


def test_box_uvs_of_a_cube_and_the_projection_table() -> None:
    cube = _hard_cube(np.array([100.0, -20.0, 2.0]), 4.0)
    assert enclosed_volume(cube) == pytest.approx(64.0)   # outward faces
    normals = vertex_normals(cube.vertices, cube.faces)
    uv = box_uv(cube.vertices, normals, 10.0)
    top = normals[:, 2] == 1.0
    assert top.sum() == 4 and np.all(cube.vertices[top, 2] == 6.0)
    assert uv.dtype == np.float32 and np.allclose(uv[top], cube.vertices[top, :2] / 10.0, rtol=1e-7)
    east = normals[:, 0] == 1.0
    assert np.allclose(uv[east], cube.vertices[east][:, [1, 2]] / 10.0, rtol=1e-7)
    point = np.array([[2.0, 3.0, 5.0]] * 6)
    axes = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
    expected = np.array([[3, 5], [-3, 5], [-2, 5], [2, 5], [2, 3], [-2, 3]]) / 4.0
    assert np.array_equal(box_uv(point, axes * 0.9 + 0.05, 4.0), expected.astype(np.float32))
    with pytest.raises(ValueError, match="> 0"):
        box_uv(point, axes, 0.0)


def test_the_written_uvs_and_normals_are_the_projections(tmp_path: Path) -> None:
    rock = rock_mesh()
    write_mesh(tmp_path / "rock.obj", rock, up="y", uv_scale=2.5)
    lines = (tmp_path / "rock.obj").read_text().splitlines()
    uv = np.array([[float(w) for w in line.split()[1:]] for line in lines if line.startswith("vt ")])
    vn = np.array([[float(w) for w in line.split()[1:]] for line in lines if line.startswith("vn ")])
    normals = vertex_normals(rock.vertices, rock.faces)
    assert np.allclose(uv, box_uv(rock.vertices, normals, 2.5), atol=1e-6)
    assert np.allclose(vn, np.column_stack([normals[:, 0], normals[:, 2], -normals[:, 1]]), atol=1e-5)
    axes = r"^# up: y \(file X = east \(x\), Y = up \(z\), Z = south \(-y\)"
    assert re.search(axes, "\n".join(lines), re.M)
