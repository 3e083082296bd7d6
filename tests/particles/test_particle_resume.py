"""A particle run saved after some iterations (``ParticleIterations.state``, through a state
checkpoint file) and restored into a fresh run goes on bit for bit as the run never stopped, on
every terrain representation, with impacts per iteration or per impact, several kinds of
particles and sampled paths; and ``run_kinds`` is the same run in one call."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.io.checkpoints import read_state_checkpoint, write_state_checkpoint
from unerode_cli.particles import (
    PER_IMPACT,
    PER_ITERATION,
    BinaryTerrain,
    DensityTerrain,
    Emission,
    HeightfieldTerrain,
    LayeredTerrain,
    Material,
    ParticleKind,
    SdfTerrain,
    preset_params,
    run_kinds,
)
from unerode_cli.particles.simulate import ParticleIterations, terrain_state
from unerode_cli.volume.sdf_field import ImplicitField
from unerode_cli.volume.sdf_shapes import Surface
from unerode_cli.volume.voxels import BinaryVoxels, DensityVoxels, VoxelGeometry, binary_block, density_block

DX = 20.0
N = 16
ITERATIONS, STOP = 4, 2
GEOMETRY = VoxelGeometry((0.0, N * DX, 0.0), (DX, DX, DX), (N, N, 16))


def _cone() -> np.ndarray:
    yy, xx = (np.mgrid[0:N, 0:N] - (N - 1) / 2.0) * DX
    return 50.0 + np.maximum(0.0, 120.0 - 0.6 * np.hypot(xx, yy))


def _terrain(representation: str):
    h = _cone()
    grid = Grid.full(h.shape, DX)
    if representation == "heightfield":
        return HeightfieldTerrain(h, grid)
    if representation == "layers":
        return LayeredTerrain(h - 30.0, np.stack([np.full((N, N), 20.0), np.full((N, N), 10.0)]), [0, 1],
                              [Material("rock", 0.5, 1.0), Material("soil", 2.5)], 1, grid)
    if representation == "density":
        return DensityTerrain(DensityVoxels(GEOMETRY, density_block(h, GEOMETRY)))
    if representation == "binary":
        return BinaryTerrain(BinaryVoxels(GEOMETRY, binary_block(h, GEOMETRY)), alpha=1000.0, threshold=50)
    # an implicit terrain flattened every 40 metaballs: the state holds a flattened base too
    return SdfTerrain(ImplicitField(GEOMETRY, Surface(), h, flatten_every=40))


def _kinds() -> tuple[ParticleKind, ...]:
    return (ParticleKind(preset_params("rain", DX), Emission.rain(60), name="rain"),
            ParticleKind(preset_params("landslide", DX), Emission.rain(30), name="landslide"))


def _iterations(representation: str, apply: str) -> ParticleIterations:
    return ParticleIterations(_terrain(representation), _kinds(), iterations=ITERATIONS, seed=7, paths=25,
                              path_stride=2, apply=apply)


def _same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for key in a:
        if isinstance(a[key], np.ndarray):
            assert np.array_equal(a[key], b[key]), key
        else:
            assert a[key] == b[key], key


@pytest.mark.parametrize(("representation", "apply"), [
    ("heightfield", PER_ITERATION), ("heightfield", PER_IMPACT), ("layers", PER_ITERATION),
    ("density", PER_ITERATION), ("density", PER_IMPACT), ("binary", PER_IMPACT), ("sdf", PER_ITERATION)])
def test_a_restored_run_goes_on_bit_for_bit(tmp_path: Path, representation: str, apply: str) -> None:
    whole = _iterations(representation, apply)
    for _ in range(ITERATIONS):
        whole.iterate()
    stopped = _iterations(representation, apply)
    for _ in range(STOP):
        stopped.iterate()
    path = tmp_path / "run.npz"
    write_state_checkpoint(path, "fingerprint", STOP, stopped.state())
    _, step, state = read_state_checkpoint(path)
    resumed = _iterations(representation, apply)
    resumed.restore(state)
    assert step == STOP and resumed.done == STOP
    _same(resumed.state(), state)  # everything saved is taken back
    while resumed.done < ITERATIONS:
        resumed.iterate()
    a, b = whole.result(), resumed.result()
    assert np.array_equal(a.elevation, b.elevation) and np.array_equal(a.dh, b.dh)
    assert a.budget == b.budget and a.stats == b.stats and a.kinds == b.kinds
    assert a.budget.detached > 0 and a.iterations == b.iterations == ITERATIONS
    assert len(a.paths) == len(b.paths) == 25
    for p, q in zip(a.paths, b.paths, strict=True):
        assert (p.iteration, p.index, p.fate) == (q.iteration, q.index, q.fate)
        assert np.array_equal(p.points, q.points)
    _same(terrain_state(a.terrain), terrain_state(b.terrain))
    if representation == "sdf":
        assert a.terrain.field.base.grid.size  # the run did flatten its tree


def test_run_kinds_is_the_iterations_in_one_call() -> None:
    steps = _iterations("heightfield", PER_ITERATION)
    while steps.done < ITERATIONS:
        steps.iterate()
    once = run_kinds(_terrain("heightfield"), _kinds(), iterations=ITERATIONS, seed=7, paths=25,
                     path_stride=2)
    assert np.array_equal(once.elevation, steps.result().elevation)
    assert once.budget == steps.result().budget


def test_run_kinds_stops_when_cancelled() -> None:
    asked = []
    result = run_kinds(_terrain("heightfield"), _kinds(), iterations=ITERATIONS, seed=7,
                       on_iteration=asked.append, cancelled=lambda: len(asked) == STOP)
    assert result.iterations == STOP and asked == [1, 2]
