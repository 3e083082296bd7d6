"""Voxel volumes as .npz files (``--voxels``, ``--volume-out``): what is written is read back
(density to float32 rounding, everything else exactly), files that break the format are
refused with one sentence, and 3D material layers are read from YAML."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from unerode_cli.errors import InputError
from unerode_cli.io.voxel_files import (
    VoxelFile,
    read_material_layers,
    read_voxels,
    voxel_file_layout,
    write_voxels,
)
from unerode_cli.volume.voxels import BinaryVoxels, DensityVoxels, VoxelGeometry

CRS = 'PROJCS["WGS 84 / UTM zone 32N",AUTHORITY["EPSG","32632"]]'


@st.composite
def volumes(draw) -> VoxelFile:
    shape = tuple(draw(st.integers(1, 5)) for _ in range(3))
    size = tuple(draw(st.floats(0.1, 50.0)) for _ in range(3))
    origin = tuple(draw(st.floats(-1e6, 1e6)) for _ in range(3))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    geometry = VoxelGeometry(origin, size, shape)
    with_material = draw(st.booleans())
    material = rng.integers(0, 3, shape) if with_material else None
    valid = rng.random(shape[:2]) < 0.8 if draw(st.booleans()) else None
    if draw(st.booleans()):
        voxels = DensityVoxels(geometry, rng.uniform(-1.0, 1.0, shape), material, valid)
    else:
        solid, hits = rng.random(shape) < 0.5, rng.integers(-99, 99, shape)
        voxels = BinaryVoxels(geometry, solid, hits, material, valid)
    names = ("rock", "soil", "sand") if with_material and draw(st.booleans()) else ()
    return VoxelFile(voxels, draw(st.sampled_from(["", CRS])), names)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(volume=volumes())
def test_a_volume_round_trips(tmp_path: Path, volume: VoxelFile) -> None:
    path = tmp_path / "v.npz"
    path.unlink(missing_ok=True)
    write_voxels(path, volume)
    back = read_voxels(path)
    a, b = volume.voxels, back.voxels
    assert type(a) is type(b) and back.crs_wkt == volume.crs_wkt
    assert back.material_names == volume.material_names
    assert b.geometry.shape == a.geometry.shape and b.geometry.size == a.geometry.size
    assert b.geometry.origin == pytest.approx(a.geometry.origin, abs=1e-9 * (1.0 + abs(a.geometry.origin[1])))
    assert np.array_equal(b.valid, a.valid)
    if a.material is None:
        assert b.material is None
    else:
        assert np.array_equal(b.material, a.material)
    if isinstance(a, DensityVoxels):
        assert np.array_equal(b.density, a.density.astype(np.float32))
    else:
        assert np.array_equal(b.solid, a.solid) and np.array_equal(b.hits, a.hits)
    assert voxel_file_layout(path) == ((a.geometry.shape[1], a.geometry.shape[0], a.geometry.shape[2]),
                                       volume.representation, a.material is not None)


def test_the_file_axes_are_x_east_y_north_z_up(tmp_path: Path) -> None:
    density = -np.ones((3, 2, 4))  # nx = 3, ny = 2, nz = 4
    density[2, 1, 0] = 1.0  # the north-east bottom voxel
    path = tmp_path / "v.npz"
    np.savez(path, origin=[100.0, 200.0, -5.0], voxel_size=[10.0, 20.0, 1.0], density=density)
    voxels = read_voxels(path).voxels
    assert voxels.geometry.origin == (100.0, 240.0, -5.0)  # west, north, bottom
    assert voxels.geometry.shape == (2, 3, 4)  # rows (north first), columns, layers
    assert voxels.density[0, 2, 0] == 1.0 and (voxels.density == 1.0).sum() == 1


CUBE = np.zeros((2, 2, 2))


def _write(path: Path, **arrays) -> Path:
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize(("arrays", "message"), [
    ({"voxel_size": 1.0, "density": np.zeros((2, 2, 2))}, "has no origin"),
    ({"origin": [0, 0, 0], "density": np.zeros((2, 2, 2))}, "has no voxel_size"),
    ({"origin": [0, 0, 0], "voxel_size": 1.0}, "exactly one of 'density'"),
    ({"origin": [0, 0, 0], "voxel_size": 1.0, "density": CUBE, "solid": CUBE > 0},
     "exactly one of 'density'"),
    ({"origin": [0, 0, 0], "voxel_size": 1.0, "density": np.zeros((2, 2))}, "needs 3 axes"),
    ({"origin": [0, 0, 0], "voxel_size": 1.0, "density": np.zeros((2, 2, 2)), "densty": np.zeros(1)},
     "unknown array"),
    ({"origin": [0, 0, 0], "voxel_size": 1.0, "density": CUBE, "material": np.zeros((2, 2, 3), int)},
     "'material' of shape"),
    ({"origin": [0, 0, 0], "voxel_size": 1.0, "density": np.zeros((2, 2, 2)), "valid": np.ones((2, 3), bool)},
     "'valid' of shape"),
    ({"origin": [0, 0], "voxel_size": 1.0, "density": np.zeros((2, 2, 2))}, "bad origin"),
    ({"origin": [0, 0, 0], "voxel_size": [1.0, -1.0, 1.0], "density": CUBE}, "voxel sizes must be"),
    ({"origin": [0, 0, 0], "voxel_size": 1.0, "density": np.full((2, 2, 2), 2.0)}, "within \\[-1, 1\\]"),
    ({"origin": [0, 0, 0], "voxel_size": 1.0, "density": CUBE, "material": np.full((2, 2, 2), 2),
      "material_names": np.array(["a", "b"])}, "names 2 material"),
])
def test_files_that_break_the_format_are_refused_in_one_sentence(tmp_path: Path, arrays, message) -> None:
    path = _write(tmp_path / "bad.npz", **arrays)
    with pytest.raises(InputError, match=message) as info:
        read_voxels(path)
    text = str(info.value)
    assert text.endswith(".") and text.count(". ") == 0 and str(path) in text


def test_a_file_that_is_not_an_npz_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "v.npz"
    path.write_text("not a zip")
    with pytest.raises(InputError, match="not a NumPy .npz archive"):
        read_voxels(path)
    with pytest.raises(InputError, match="does not exist"):
        read_voxels(tmp_path / "missing.npz")


LAYERS = """
materials:
  limestone: {erodibility: 5.0, critical_stress: 0}
  marl: {erodibility: 0.5, critical_stress: 2}
  sand: {erodibility: 8.0}
horizons:
  - {material: marl, top: 120}
  - {material: limestone, top: 150}
  - {material: marl}
deposit: sand
eroded: {marl: sand}
"""


def test_3d_material_layers_are_read_from_yaml(tmp_path: Path) -> None:
    path = tmp_path / "layers.yaml"
    path.write_text(LAYERS)
    layers = read_material_layers(path)
    assert layers.names == ("limestone", "marl", "sand")
    assert [(m.k_eps, m.tau_c) for m in layers.materials] == [(5.0, 0.0), (0.5, 2.0), (8.0, 0.0)]
    assert layers.tops == (120.0, 150.0, float("inf")) and layers.horizon_materials == (1, 0, 1)
    assert layers.deposit == 2 and layers.eroded == {1: 2}


@pytest.mark.parametrize(("text", "message"), [
    ("materials: {a: {erodibility: 1}}\nhorizon: []\n", "unknown key"),
    ("materials: {a: {k: 1}}\n", "needs 'erodibility'"),
    ("materials: {a: {erodibility: -1}}\n", "K_ε ≥ 0"),
    ("materials: {a: {erodibility: 1}}\nhorizons: [{material: b}]\n", "names 'b'"),
    ("materials: {a: {erodibility: 1}}\n"
     "horizons: [{material: a, top: 5}, {material: a, top: 4}, {material: a}]\n", "must increase"),
    ("materials: {a: {erodibility: 1}}\nhorizons: [{material: a}, {material: a}]\n", "only the last"),
    ("materials: {a: {erodibility: 1}}\neroded: {a: c}\n", "names 'c'"),
])
def test_bad_material_layers_are_refused(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "layers.yaml"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_material_layers(path)
