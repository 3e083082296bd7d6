"""What Blender reads of the mesh files (skipped without a ``blender`` on the PATH): each file of
the two-material rock imported with Blender's importers and their default settings
(tests/io/blender_import.py) stands upright (Blender is Z-up: its world bounds are the mesh's x, y,
z bounds), faces outwards (positive enclosed volume, equal to the mesh's), and has one material
per layer with the layer's name and colour (OBJ and glTF)."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from tests.io.test_mesh_files import ROCK_NAMES, rock_attributes, rock_mesh

from unerode_cli.io.mesh_files import write_mesh
from unerode_cli.volume.mesh import PALETTE, Mesh, enclosed_volume, linear_colours

SCRIPT = Path(__file__).resolve().parent / "blender_import.py"
BLENDER = shutil.which("blender")

pytestmark = pytest.mark.skipif(BLENDER is None, reason="Blender is not installed (no 'blender' on the PATH)")


@pytest.fixture(scope="module")
def rock() -> Mesh:
    return rock_mesh()


@pytest.fixture(scope="module")
def blender_reads(tmp_path_factory: pytest.TempPathFactory, rock: Mesh) -> dict:
    """Blender's records of rock.obj (with rock.mtl), rock.glb and rock.ply, keyed by file suffix
    and importer."""
    pytest.importorskip("trimesh")
    folder = tmp_path_factory.mktemp("blender")
    for suffix in (".obj", ".glb", ".ply"):
        write_mesh(folder / f"rock{suffix}", rock, origin=(500000.0, 5000000.0, 0.0),
                   material_names=ROCK_NAMES, attributes=rock_attributes(rock))
    result = subprocess.run([BLENDER, "-b", "--factory-startup", "--python", str(SCRIPT), "--",
                             *(str(folder / f"rock{s}") for s in (".obj", ".glb", ".ply"))],
                            capture_output=True, text=True, timeout=300)
    line = next((line for line in result.stdout.splitlines() if line.startswith("BLENDER_JSON ")), None)
    assert line is not None, result.stdout[-2000:] + result.stderr[-2000:]
    report = json.loads(line[len("BLENDER_JSON "):])
    return {(Path(r["file"]).suffix, r["importer"]): r for r in report["imports"]}


def _imports(reads: dict, suffix: str) -> list[dict]:
    records = [r for (s, _), r in reads.items() if s == suffix]
    assert records, f"this Blender has no importer for {suffix}"
    for record in records:
        if "No module named 'numpy'" in record.get("error", ""):
            pytest.skip(f"{record['importer']} needs NumPy, which this Blender's Python lacks")
    return records


@pytest.mark.parametrize("suffix", [".obj", ".glb", ".ply"])
def test_blender_imports_the_mesh_upright_and_outwards(blender_reads: dict, rock: Mesh, suffix: str) -> None:
    for record in _imports(blender_reads, suffix):
        assert record.get("result") == ["FINISHED"], record.get("error")
        assert len(record["objects"]) == 1, record["importer"]
        obj = record["objects"][0]
        assert np.allclose(obj["min"], rock.vertices.min(axis=0), atol=1e-3), record["importer"]
        assert np.allclose(obj["max"], rock.vertices.max(axis=0), atol=1e-3), record["importer"]
        assert obj["faces"] == len(rock.faces)
        assert obj["volume"] == pytest.approx(enclosed_volume(rock), rel=1e-4)
        assert obj["uv_layers"], record["importer"]


@pytest.mark.parametrize("suffix", [".obj", ".glb"])
def test_blender_reads_one_material_per_layer(blender_reads: dict, suffix: str) -> None:
    for record in _imports(blender_reads, suffix):
        materials = record["objects"][0]["materials"]
        assert [m["name"] for m in materials] == ["sand_stone", "cap"], record["importer"]
        for material, layer in zip(materials, (0, 1), strict=True):
            expected = linear_colours(PALETTE[layer])
            assert material["base_color"] == pytest.approx(expected, abs=0.5 / 255 + 1e-6)
            assert material["metallic"] == 0.0
            assert material["roughness"] == pytest.approx(0.9, abs=1e-6)
        assert record["objects"][0]["custom_normals"], record["importer"]
