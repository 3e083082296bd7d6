"""Mass budget of particle erosion: what the particles detach, deposit, carry off the domain,
keep in suspension or bring in by design, against the terrain's volume change."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.particles import (
    Emission,
    HeightfieldTerrain,
    LayeredTerrain,
    Material,
    VelocityField,
    preset_params,
    run,
)

DX = 20.0
N = 48


def _cone_grid() -> tuple[np.ndarray, Grid]:
    yy, xx = np.mgrid[0:N, 0:N] - (N - 1) / 2.0
    z = np.maximum(0.0, 200.0 - 0.5 * DX * np.hypot(xx, yy))
    valid = np.ones((N, N), bool)
    valid[5:9, 30:36] = False  # a nodata hole: particles over it are lost
    return z, Grid(DX, DX, valid)


def _closes(result, terrain_volume_change: float) -> None:
    b = result.budget
    scale = b.detached + b.emitted
    assert scale > 0
    assert abs(b.residual) <= 1e-9 * scale
    assert abs(terrain_volume_change - (b.deposited - b.detached)) <= 1e-9 * scale


@pytest.mark.parametrize("preset", ["rain", "volcano", "coastal"])
def test_budget_closes_on_a_heightfield(preset):
    z, grid = _cone_grid()
    params = preset_params(preset, DX)
    emission = (Emission.source(500, (N / 2, N / 2), spread=40.0) if preset == "volcano"
                else Emission.rain(500))
    result = run(HeightfieldTerrain(z, grid), params, emission, iterations=2, seed=5, sea_level=40.0,
                 velocity=VelocityField.uniform(3.0, -1.0, medium="water"))
    _closes(result, result.dh.sum() * grid.cell_area)
    assert result.stats.lost > 0  # the edges and the nodata hole take some
    assert np.all(result.dh[~grid.valid] == 0.0)
    b = result.budget
    if preset == "volcano":  # matter added by design, counted as emitted (closure above)
        assert b.emitted > 0
    if preset == "coastal":  # corrosion: dissolved matter stays suspended
        assert b.suspended > 0 and b.dropped == 0.0


def test_budget_closes_on_a_layered_terrain():
    z, grid = _cone_grid()
    thickness = np.stack([np.full((N, N), 50.0), np.maximum(z - 50.0, 0.0)])
    terrain = LayeredTerrain(np.minimum(z, 50.0) - 50.0, thickness, [0, 1],
                             [Material("rock", 0.5, 0.5), Material("soil", 2.5), Material("sand", 4.0)],
                             deposit_material=2, grid=grid)
    result = run(terrain, preset_params("rain", DX), Emission.rain(800), iterations=2, seed=9)
    new = result.terrain
    volume = (new.thickness.sum(axis=0) + new.base - thickness.sum(axis=0) - terrain.base)[grid.valid].sum()
    _closes(result, volume * grid.cell_area)
    assert np.array_equal(result.elevation, new.base + new.thickness.sum(axis=0))
