"""Particle PLY files: the red green blue vertex colours that Blender, MeshLab and Houdini read
beside the named properties, read back by trimesh (an independent PLY reader) and by our own
reader; the viridis colours of a property."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib import colormaps

from unerode_cli.io.particle_ply import attribute_colours, read_particle_ply, write_particle_ply


def _particles(n: int = 50) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], np.ndarray]:
    rng = np.random.default_rng(4)
    positions = rng.uniform(0.0, 10.0, (n, 3))
    normals = np.tile([0.0, 0.0, 1.0], (n, 1))
    layer = rng.integers(0, 3, n).astype(np.int32)
    colours = np.array([[31, 119, 180], [255, 127, 14], [44, 160, 44]], dtype=np.uint8)[layer]
    return positions, normals, {"stress": rng.uniform(0.0, 1.0, n), "layer": layer}, colours


def test_colours_are_written_as_uchar_red_green_blue(tmp_path: Path) -> None:
    positions, normals, properties, colours = _particles()
    path = tmp_path / "p.ply"
    write_particle_ply(path, positions, normals, properties, colours=colours)
    header = path.read_bytes().split(b"end_header\n")[0].decode("ascii")
    names = [line.split()[-1] for line in header.splitlines() if line.startswith("property")]
    assert names == ["x", "y", "z", "nx", "ny", "nz", "red", "green", "blue", "stress", "layer"]
    assert "property uchar red" in header and "property uchar blue" in header
    props, _ = read_particle_ply(path)
    assert np.array_equal(np.column_stack([props["red"], props["green"], props["blue"]]), colours)
    assert np.array_equal(props["layer"], properties["layer"])
    assert np.allclose(props["x"], positions[:, 0], rtol=1e-6)

    trimesh = pytest.importorskip("trimesh")
    cloud = trimesh.load(path, process=False)
    assert np.allclose(cloud.vertices, positions, rtol=1e-6)
    assert np.array_equal(np.asarray(cloud.colors)[:, :3], colours)


def test_colours_are_optional_and_checked(tmp_path: Path) -> None:
    positions, normals, properties, colours = _particles()
    write_particle_ply(tmp_path / "p.ply", positions, normals, properties)
    assert "red" not in read_particle_ply(tmp_path / "p.ply")[0]
    with pytest.raises(ValueError, match="colours"):
        write_particle_ply(tmp_path / "q.ply", positions, normals, properties, colours=colours[:-1])


def test_attribute_colours_follow_viridis() -> None:
    values = np.array([-1.0, 0.0, 0.5, 1.0, 2.0, np.nan])
    colours = attribute_colours(values, 0.0, 1.0)
    assert colours.dtype == np.uint8 and colours.shape == (6, 3)
    viridis = colormaps["viridis"]
    expected = np.round(np.array([viridis(0.0), viridis(0.0), viridis(0.5), viridis(1.0), viridis(1.0)])
                        [:, :3] * 255.0)
    assert np.abs(colours[:5].astype(int) - expected).max() <= 2
    assert tuple(colours[0]) == (68, 1, 84) and tuple(colours[3]) == (253, 231, 37)
    assert tuple(colours[5]) == (128, 128, 128)
    assert np.array_equal(attribute_colours(np.array([3.0, 3.0]), 3.0, 3.0), attribute_colours(
        np.array([0.0, 0.0]), 0.0, 1.0))
