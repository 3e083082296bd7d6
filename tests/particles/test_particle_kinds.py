"""Several kinds of particles in one run (003 Fig. 8): on a terrain frozen for the run (one
iteration) a run of rain+wind is the sum of a rain run and a wind run, and each kind's
particles follow their own parameters."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.particles import (
    Emission,
    HeightfieldTerrain,
    ParticleKind,
    VelocityField,
    kind_seed,
    preset_params,
    run,
    run_kinds,
)

N, DX = 40, 20.0


def _cone() -> np.ndarray:
    yy, xx = np.mgrid[0:N, 0:N] - (N - 1) / 2.0
    return np.maximum(0.0, 200.0 - 0.5 * DX * np.hypot(xx, yy))


def test_rain_and_wind_together_are_the_sum_of_their_parts():
    terrain = HeightfieldTerrain(_cone(), Grid.full((N, N), DX))
    rain = ParticleKind(preset_params("rain", DX), Emission.rain(300), None, "rain")
    wind = ParticleKind(preset_params("wind", DX), Emission.rain(200),
                        VelocityField.uniform(8.0, 2.0, medium="air"), "wind")
    both = run_kinds(terrain, (rain, wind), seed=21, paths=20)
    alone = [run(terrain, kind.params, kind.emission, velocity=kind.velocity, seed=kind_seed(21, position))
             for position, kind in enumerate((rain, wind))]
    moved = both.budget.detached + both.budget.deposited
    assert moved > 0 and all(part.budget.detached > 0 for part in alone)
    for field in ("emitted", "detached", "deposited", "suspended", "lost", "dropped"):
        parts = [getattr(part.budget, field) for part in alone]
        assert getattr(both.budget, field) == pytest.approx(sum(parts), abs=1e-12 * moved)
        assert [getattr(kind.budget, field) for kind in both.kinds] == pytest.approx(parts, abs=1e-12 * moved)
    assert both.stats.impacts == sum(part.stats.impacts for part in alone)
    assert [kind.stats for kind in both.kinds] == [part.stats for part in alone]
    assert np.abs(both.dh - (alone[0].dh + alone[1].dh)).max() < 1e-9 * np.abs(both.dh).max()


def test_each_kind_follows_its_own_parameters():
    """Rain that cannot detach (K_ε = 0) and a loaded river from a point: only the river
    detaches, only the rain starts its 10 m drop over the whole domain, and the river's
    particles start within their spread of the source, at their own drop height."""
    z = _cone()
    terrain = HeightfieldTerrain(z, Grid.full((N, N), DX))
    rain = ParticleKind(preset_params("rain", DX, k_eps=0.0), Emission.rain(100), None, "rain")
    river_params = preset_params("river", DX, drop_height=2.0)
    river = ParticleKind(river_params, Emission.source(50, (12.0, 25.0), spread=30.0), None, "river")
    result = run_kinds(terrain, (rain, river), iterations=2, seed=5, paths=150)
    assert result.kinds[0].budget.detached == 0.0
    assert result.kinds[1].budget.detached > 0.0
    starts = np.array([p.points[0] for p in result.paths])
    is_rain = np.array([p.index < 100 for p in result.paths])
    rows, cols = (np.clip(np.rint(starts[:, k]).astype(int), 0, N - 1) for k in (1, 0))
    ground = z[rows, cols]
    height = starts[:, 2] - ground
    assert np.all(np.hypot(starts[~is_rain, 0] - 12.0, starts[~is_rain, 1] - 25.0) * DX <= 30.0 + 1e-9)
    assert np.ptp(starts[is_rain, 0]) > 0.8 * N  # rain over the whole domain
    assert np.median(height[is_rain]) == pytest.approx(10.0, abs=3.0)
    assert np.median(height[~is_rain]) == pytest.approx(2.0, abs=3.0)
