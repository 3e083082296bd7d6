"""particle-erode on the shared stepping loop: --max-steps stops after that many iterations with
a checkpoint, --resume continues bit for bit (the surface, the change map, the sampled paths,
the altered volume and the sidecar's statistics of an uninterrupted run), a finished run removes
its checkpoint, and a checkpoint of another run is refused."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from tests.conftest import run_cli, write_geotiff

N = 24
DX = 20.0
TRANSFORM = Affine(DX, 0.0, 500000.0, 0.0, -DX, 5000000.0)
RUN = ("--particles", 150, "--iterations", 5, "--seed", 3, "--dtype", "float64", "--checkpoint-every", 2)
#: Statistics of the sidecar that are wall-clock timings, not results.
TIMINGS = ("wall_time_s", "particles_per_second")


@pytest.fixture
def cone(tmp_path: Path) -> Path:
    """A 120 m cone on a 24 × 24 grid of 20 m cells, its foot at 300 m."""
    yy, xx = np.mgrid[0:N, 0:N] - (N - 1) / 2.0
    return write_geotiff(tmp_path / "cone.tif", 300.0 + np.maximum(0.0, 120.0 - 0.5 * DX * np.hypot(xx, yy)),
                         transform=TRANSFORM)


def _pixels(path: Path) -> np.ndarray:
    with rasterio.open(path) as src:
        return src.read()


def _statistics(output: Path) -> dict:
    stats = json.loads(output.with_name(output.name + ".json").read_text())["statistics"]
    return {key: value for key, value in stats.items() if key not in TIMINGS}


def _outputs(tmp_path: Path, name: str, representation: str) -> list[object]:
    """The output options of a run called ``name``: a change map, and sampled paths on a
    heightfield or the altered volume on a 3D terrain."""
    extra: list[object] = ["--change-map", tmp_path / f"{name}_dh.tif"]
    if representation == "heightfield":
        return [*extra, "--preset", "rain+landslide", "--paths", tmp_path / f"{name}.geojson",
                "--path-count", 40]
    return [*extra, "--representation", representation, "--volume-out", tmp_path / f"{name}.npz"]


@pytest.mark.parametrize("representation", ["heightfield", "density"])
def test_a_stopped_run_resumes_bit_for_bit(tmp_path: Path, cone: Path, representation: str) -> None:
    full, part = tmp_path / "full.tif", tmp_path / "part.tif"
    done = run_cli("particle-erode", cone, full, *RUN, *_outputs(tmp_path, "full", representation))
    assert done.returncode == 0, done.stderr
    assert not (tmp_path / ".full.tif.checkpoint.npz").exists()
    part_options = (*RUN, *_outputs(tmp_path, "part", representation))
    stopped = run_cli("particle-erode", cone, part, *part_options, "--max-steps", 3)
    assert stopped.returncode == 0, stopped.stderr
    assert "stopped after iteration 3 of 5" in stopped.stderr and "--resume" in stopped.stderr
    checkpoint = tmp_path / ".part.tif.checkpoint.npz"
    assert checkpoint.exists() and not part.exists() and not (tmp_path / "part_dh.tif").exists()
    refused = run_cli("particle-erode", cone, part, *part_options)
    assert refused.returncode == 2 and "--resume" in refused.stderr
    resumed = run_cli("particle-erode", cone, part, *part_options, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert "resuming after step 3 of 5" in resumed.stderr
    assert not checkpoint.exists()
    for suffix in (".tif", "_dh.tif"):
        assert np.array_equal(_pixels(tmp_path / f"full{suffix}"), _pixels(tmp_path / f"part{suffix}"))
    assert _statistics(full) == _statistics(part)
    assert _statistics(full)["particles"] == 5 * 150 * (2 if representation == "heightfield" else 1)
    if representation == "heightfield":
        paths = [json.loads((tmp_path / f"{n}.geojson").read_text()) for n in ("full", "part")]
        assert paths[0] == paths[1] and len(paths[0]["features"]) == 40
    else:
        with np.load(tmp_path / "full.npz") as a, np.load(tmp_path / "part.npz") as b:
            assert sorted(a.files) == sorted(b.files) and "density" in a.files
            for key in a.files:
                assert np.array_equal(a[key], b[key]), key


def test_a_checkpoint_of_another_run_is_refused(tmp_path: Path, cone: Path) -> None:
    out = tmp_path / "out.tif"
    assert run_cli("particle-erode", cone, out, *RUN, "--max-steps", 2).returncode == 0
    other = list(RUN)
    other[other.index("--seed") + 1] = 4  # another run: another seed
    result = run_cli("particle-erode", cone, out, *other, "--resume")
    assert result.returncode == 2
    assert "belongs to a run with other inputs or options" in result.stderr
    assert (tmp_path / ".out.tif.checkpoint.npz").exists() and not out.exists()
