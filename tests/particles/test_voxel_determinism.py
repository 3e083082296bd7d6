"""Runs on voxel terrains are bit-identical for a seed whatever the number of numba threads: the
same script in fresh interpreters with NUMBA_NUM_THREADS=1 and 2 prints the same digests (and,
faster, one process switching its threads gets the same density)."""

from __future__ import annotations

import os
import subprocess
import sys

import numba
import numpy as np
import pytest

from unerode_cli.particles import DensityTerrain, Emission, preset_params, run
from unerode_cli.volume.voxels import DensityVoxels, VoxelGeometry, density_block

SCRIPT = """
import hashlib, numba, numpy as np
from unerode_cli.particles import (BinaryTerrain, DensityTerrain, Emission, Material, MaterialRules,
                                   preset_params, run)
from unerode_cli.volume.voxels import (BinaryVoxels, DensityVoxels, VoxelGeometry, binary_block,
                                       density_block, horizon_material)
d, n = 20.0, 32
rng = np.random.default_rng(0)
h = 100.0 + np.add.outer(np.arange(n), np.arange(n)) * 4.0 + 10.0 * rng.random((n, n))
g = VoxelGeometry((0.0, n * d, 0.0), (d, d, d), (n, n, 24))
layers = horizon_material(g, np.array([150.0, np.inf]), np.array([0, 1]))
materials = [Material("rock", 1.0), Material("soil", 3.0), Material("sand", 5.0)]
rules = MaterialRules(deposit=2, eroded={0: 2})
params = preset_params("river", d)
for name, terrain, apply in (
        ("density", DensityTerrain(DensityVoxels(g, density_block(h, g), layers), materials, rules),
         "per-iteration"),
        ("binary", BinaryTerrain(BinaryVoxels(g, binary_block(h, g), material=layers), materials, rules),
         "per-iteration"),
        ("density per impact", DensityTerrain(DensityVoxels(g, density_block(h, g))), "per-impact")):
    # 1500 particles a run: several batches, the first one a pilot, so batching is exercised too
    result = run(terrain, params, Emission.rain(1500), iterations=2, seed=11, paths=3, apply=apply)
    v = result.terrain.voxels
    state = v.density if name.startswith("density") else np.stack([v.solid, v.hits])
    digest = hashlib.sha256(np.ascontiguousarray(state).tobytes())
    digest.update(v.material.tobytes() if v.material is not None else b"")
    digest.update(repr((result.budget, result.stats)).encode())
    for path in result.paths:
        digest.update(path.points.tobytes())
    print(name, numba.get_num_threads(), result.stats.impacts, digest.hexdigest())
"""


def _digests(threads: int) -> list[str]:
    env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, env=env,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    lines = [line.split() for line in done.stdout.splitlines()]
    assert [line[-3] for line in lines] == [str(threads)] * 3  # the threads asked for were used
    return [line[-2] + " " + line[-1] for line in lines]


@pytest.mark.slow
def test_voxel_runs_are_bit_identical_on_one_and_two_threads() -> None:
    one, two = _digests(1), _digests(2)
    assert one == two
    assert all(int(line.split()[0]) > 10_000 for line in one)  # impacts: the runs did something


@pytest.fixture
def threads():
    before = numba.get_num_threads()
    yield
    numba.set_num_threads(before)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
def test_a_density_run_is_the_same_on_one_and_two_threads_in_one_process(threads) -> None:
    d, n = 20.0, 24
    h = 100.0 + np.add.outer(np.arange(n), np.arange(n)) * 4.0
    g = VoxelGeometry((0.0, n * d, 0.0), (d, d, d), (n, n, 16))
    results = []
    for count in (1, 2):
        numba.set_num_threads(count)
        results.append(run(DensityTerrain(DensityVoxels(g, density_block(h, g))), preset_params("river", d),
                           Emission.rain(1200), seed=3))
    assert np.array_equal(results[0].terrain.voxels.density, results[1].terrain.voxels.density)
    assert results[0].budget == results[1].budget and results[0].stats.impacts > 10_000
