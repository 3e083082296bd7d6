"""glTF binary meshes: what trimesh reads of them (one geometry per material, its PBR colour),
the raw glTF JSON (attributes, POSITION's bounds Y-up, the extras), the custom attributes'
values (float32), the round trip through :func:`read_mesh_file` back to Z-up, and the extra to
install when trimesh is missing."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from tests.io.test_mesh_files import ROCK_NAMES, rock_attributes, rock_mesh

from unerode_cli.io.mesh_files import face_materials, read_mesh_file, write_mesh
from unerode_cli.volume.mesh import PALETTE, Mesh, enclosed_volume, linear_colours

trimesh = pytest.importorskip("trimesh")

ORIGIN = (500000.0, 5000000.0, 95.0)


def glb_parts(path: Path) -> tuple[dict, bytes]:
    """The JSON chunk and the binary chunk of a .glb, read by the glTF 2.0 layout: a 12-byte
    header (magic 'glTF', version 2, length), then chunks of (length, type, data)."""
    data = path.read_bytes()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert (magic, version, length) == (b"glTF", 2, len(data))
    json_length, json_type = struct.unpack_from("<I4s", data, 12)
    assert json_type == b"JSON"
    tree = json.loads(data[20:20 + json_length])
    bin_length, bin_type = struct.unpack_from("<I4s", data, 20 + json_length)
    assert bin_type == b"BIN\x00"
    start = 28 + json_length
    return tree, data[start:start + bin_length]


def accessor(tree: dict, blob: bytes, index: int) -> np.ndarray:
    """The values of a float32 or uint8 accessor, read from its buffer view (tightly packed)."""
    acc = tree["accessors"][index]
    view = tree["bufferViews"][acc["bufferView"]]
    dtype = {5126: np.float32, 5121: np.uint8, 5125: np.uint32}[acc["componentType"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[acc["type"]]
    offset = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    return np.frombuffer(blob, dtype, acc["count"] * width, offset).reshape(acc["count"], width)


@pytest.fixture(scope="module")
def rock() -> Mesh:
    return rock_mesh()


@pytest.fixture
def glb(tmp_path: Path, rock: Mesh) -> Path:
    path = tmp_path / "rock.glb"
    write_mesh(path, rock, origin=ORIGIN, crs_wkt="EPSG:32632 WKT", material_names=ROCK_NAMES,
               attributes=rock_attributes(rock), comments=("frame 3",))
    return path


def _used_per_material(rock: Mesh) -> dict[int, np.ndarray]:
    materials = face_materials(rock.faces, rock.materials)
    return {layer: np.unique(rock.faces[materials == layer]) for layer in (0, 1)}


def test_trimesh_reads_one_geometry_per_material_with_its_colour(glb: Path, rock: Mesh) -> None:
    scene = trimesh.load(glb)
    assert isinstance(scene, trimesh.Scene) and len(scene.geometry) == 2
    by_name = {g.visual.material.name: g for g in scene.geometry.values()}
    assert sorted(by_name) == ["cap", "sand_stone"]
    used = _used_per_material(rock)
    for name, layer in (("sand_stone", 0), ("cap", 1)):
        geometry = by_name[name]
        linear = np.rint(255.0 * linear_colours(PALETTE[layer]))   # trimesh keeps 8 bits a channel
        assert np.abs(geometry.visual.material.baseColorFactor - [*linear, 255]).max() <= 1
        assert geometry.visual.material.metallicFactor == 0.0
        assert geometry.visual.material.roughnessFactor == pytest.approx(0.9)
        assert len(geometry.vertices) == len(used[layer])
    total = sum(len(g.vertices) for g in scene.geometry.values())
    assert total == len(used[0]) + len(used[1]) > len(rock.vertices)   # the border's vertices twice
    assert sum(len(g.faces) for g in scene.geometry.values()) == len(rock.faces)
    assert scene.metadata["unerode_cli"]["origin"] == list(ORIGIN)


def test_the_gltf_json_lists_the_attributes_and_is_y_up(glb: Path, rock: Mesh) -> None:
    tree, blob = glb_parts(glb)
    assert len(tree["meshes"]) == 1 and len(tree["nodes"]) == 1 and tree["nodes"][0]["name"] == "rock"
    primitives = tree["meshes"][0]["primitives"]
    assert len(primitives) == 2
    materials = [tree["materials"][p["material"]] for p in primitives]
    assert [m["name"] for m in materials] == ["sand_stone", "cap"]
    for material, layer in zip(materials, (0, 1), strict=True):
        pbr = material["pbrMetallicRoughness"]
        expected = [*linear_colours(PALETTE[layer]), 1.0]
        assert pbr["baseColorFactor"] == pytest.approx(expected, abs=0.5 / 255 + 1e-9)   # 8 bits a channel
        assert pbr["metallicFactor"] == 0.0
    used = _used_per_material(rock)
    attributes = rock_attributes(rock)
    for primitive, layer in zip(primitives, (0, 1), strict=True):
        assert set(primitive["attributes"]) == {"POSITION", "NORMAL", "TEXCOORD_0", "_STRESS",
                                                "_VIABILITY", "_LAYER", "_MATERIAL"}
        position = tree["accessors"][primitive["attributes"]["POSITION"]]
        z = rock.vertices[used[layer], 2]
        assert position["min"][1] == pytest.approx(z.min(), abs=1e-5)   # glTF's Y: the mesh's z
        assert position["max"][1] == pytest.approx(z.max(), abs=1e-5)
        points = accessor(tree, blob, primitive["attributes"]["POSITION"])
        assert np.array_equal(points, np.column_stack([rock.vertices[used[layer]][:, i] * s for i, s in
                                                       ((0, 1), (2, 1), (1, -1))]).astype(np.float32))
        for name in ("stress", "viability", "layer"):
            values = accessor(tree, blob, primitive["attributes"][f"_{name.upper()}"])[:, 0]
            assert np.array_equal(values, attributes[name][used[layer]].astype(np.float32))
    z_all = rock.vertices[:, 2]
    y_bounds = [tree["accessors"][p["attributes"]["POSITION"]][k][1] for p in primitives
                for k in ("min", "max")]
    assert min(y_bounds) == pytest.approx(z_all.min(), abs=1e-5)
    assert max(y_bounds) == pytest.approx(z_all.max(), abs=1e-5)
    extras = tree["scenes"][0]["extras"]["unerode_cli"]
    assert extras["origin"] == list(ORIGIN) and extras["crs_wkt"] == "EPSG:32632 WKT"
    assert extras["units"] == "m"
    assert extras["up"] == "y" and extras["comments"] == ["frame 3"]
    assert extras["materials"] == {"sand_stone": 0, "cap": 1}


def test_a_glb_round_trips_to_z_up(glb: Path, rock: Mesh) -> None:
    read = read_mesh_file(glb)
    back = read.mesh
    assert read.origin == ORIGIN and read.crs_wkt == "EPSG:32632 WKT" and read.up == "y"
    assert len(back.vertices) == len(rock.vertices) and len(back.faces) == len(rock.faces)
    expected = rock.vertices.astype(np.float32).astype(np.float64)
    order_back, order_rock = np.lexsort(back.vertices.T), np.lexsort(expected.T)
    assert np.array_equal(back.vertices[order_back], expected[order_rock])
    index = np.empty(len(rock.vertices), dtype=np.int64)   # rock's vertex → back's
    index[order_rock] = order_back
    assert np.array_equal(back.materials[index], rock.materials)
    assert np.array_equal(back.colours[index], rock.colours)
    faces = {tuple(np.roll(f, -np.argmin(f))) for f in index[rock.faces]}   # same turn, any start
    assert faces == {tuple(np.roll(f, -np.argmin(f))) for f in back.faces}
    assert enclosed_volume(back) == pytest.approx(enclosed_volume(rock), rel=1e-6)
    for name, values in rock_attributes(rock).items():
        assert np.array_equal(read.attributes[name][index], values.astype(np.float32))


def test_a_z_up_glb_keeps_the_axes(tmp_path: Path, rock: Mesh) -> None:
    write_mesh(tmp_path / "rock.glb", rock, up="z")
    tree, _ = glb_parts(tmp_path / "rock.glb")
    tops = [tree["accessors"][p["attributes"]["POSITION"]]["max"][2] for p in tree["meshes"][0]["primitives"]]
    assert max(tops) == pytest.approx(rock.vertices[:, 2].max(), abs=1e-5)
    back = read_mesh_file(tmp_path / "rock.glb")
    assert back.up == "z" and np.allclose(np.sort(back.mesh.vertices, axis=0), np.sort(rock.vertices, axis=0),
                                          atol=1e-5)


def test_without_trimesh_a_glb_is_refused_with_the_extra_to_install(tmp_path: Path) -> None:
    code = ("import sys; sys.modules['trimesh'] = None\n"
            "from unerode_cli.io.mesh_files import mesh_format\n"
            "from unerode_cli.volume.mesh import MeshExtraMissing\n"
            "print(mesh_format('rock.obj'))\n"
            "try:\n    mesh_format('rock.glb')\nexcept MeshExtraMissing as exc:\n    print(exc)\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == [
        ".obj", "glTF meshes (.glb) need trimesh, which is not installed: pip install 'unerode-cli[mesh]'"]
