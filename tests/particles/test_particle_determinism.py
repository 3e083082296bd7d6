"""Particle runs are bit-identical for a seed whatever the number of numba threads."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.particles import Emission, HeightfieldTerrain, preset_params, run

DX = 20.0


@pytest.fixture
def threads():
    before = numba.get_num_threads()
    yield
    numba.set_num_threads(before)


def _run(seed: int, n_threads: int):
    numba.set_num_threads(n_threads)
    rng = np.random.default_rng(0)
    z = 100.0 + np.add.outer(np.arange(40.0), np.arange(40.0)) * 4.0 + 5.0 * rng.random((40, 40))
    # 3000 particles: several batches, the first one a pilot, so batching is exercised too
    return run(HeightfieldTerrain(z, Grid.full(z.shape, DX)), preset_params("river", DX),
               Emission.rain(1500), iterations=2, seed=seed, paths=4)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
def test_same_seed_is_bit_identical_on_one_and_two_threads(threads):
    one, two = _run(11, 1), _run(11, 2)
    assert np.array_equal(one.elevation, two.elevation)
    assert one.budget == two.budget and one.stats == two.stats
    assert all(np.array_equal(a.points, b.points) for a, b in zip(one.paths, two.paths, strict=True))
    other = _run(12, 2)
    assert not np.array_equal(one.elevation, other.elevation)
    assert np.abs(one.dh - other.dh).max() > 1e-3
