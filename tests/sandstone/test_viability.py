"""Fabric interlocking and viability (002 Eq. 1–2), and the stress–erosion feedback they make
(Bruthans et al. 2014): a loaded pillar thins until its stress reaches the threshold."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.sandstone.deflation import DeflationParams
from unerode_cli.sandstone.layers import GRAVITY, Layer, LayerStack, Rock
from unerode_cli.sandstone.mpm import MpmParams
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.sampling import Lattice, sample
from unerode_cli.sandstone.scene import parse_scene
from unerode_cli.sandstone.simulation import Processes, Simulation, SimulationParams
from unerode_cli.sandstone.viability import erode, erodibility


def test_erodibility_switches_where_compression_exceeds_the_threshold() -> None:
    """E = k_s where −tr σ > I, else k_w (002 Eq. 2), times the painted factor; per layer."""
    layer = np.array([0, 0, 1, 1], dtype=np.int32)
    stress = np.array([2.9e6, 3.1e6, 2.9e6, -5e6])  # the last one is in tension
    rate, locked = erodibility(layer, np.array([1.0, 1.0, 0.5, 1.0]), stress, np.array([1e-4, 2e-4]),
                               np.array([1e-6, 2e-6]), np.array([3e6, 2e6]))
    assert locked.tolist() == [False, True, True, False]
    np.testing.assert_allclose(rate, [1e-4, 1e-6, 1e-6, 2e-4])


def test_viability_drops_by_rate_times_wind_times_dt_on_the_surface_only() -> None:
    """b ← b − E·(W + F)·Δt on surface particles (002 Eq. 1); eroded once b ≤ 0 after a loss."""
    b = np.array([1.0, 0.05, 1.0, 0.0])
    surface = np.array([True, True, False, True])
    eroded = erode(b, surface, np.full(4, 1e-4), np.array([2.0, 2.0, 2.0, 0.0]),
                   np.array([0.5, 0.5, 0.5, 0.0]), 1000.0)
    np.testing.assert_allclose(b, [0.75, -0.2, 1.0, 0.0])
    assert eroded.tolist() == [False, True, False, False]  # the last: b = 0 but nothing erodes it


SPACING = 0.5
WIDTH, HEIGHT, CAP = 4.0, 6.0, 2.0


pytestmark = pytest.mark.usefixtures("one_thread")


def _pillar_run(interlocking: float, stress: bool, frames: int) -> Particles:
    """A pillar under a non-erodible cap, eroded by uniform deflation (W = k_d = 1)."""
    scene = parse_scene({"domain": {"size": [12.0, 12.0, 10.0]}, "shape": {"union": [
        {"box": {"min": [4.0, 4.0, 0.0], "max": [8.0, 8.0, HEIGHT]}},
        {"box": {"min": [2.0, 2.0, HEIGHT], "max": [10.0, 10.0, HEIGHT + CAP]}}]}})
    lattice = Lattice((0.0, 0.0, 0.0), (12.0, 12.0, 10.0), SPACING)
    positions = sample(scene.shape, lattice, seed=5)
    factor = np.where(positions[:, 2] > HEIGHT, 0.0, 1.0)
    particles = Particles.new(positions, np.zeros(len(positions)), factor)
    layers = LayerStack((Layer(k_w=1e-4, k_s=1e-6, interlocking=interlocking, k_a=0.0, k_d=1.0),))
    params = SimulationParams(dt=1000.0, mpm=MpmParams(settle_substeps=6000, substeps=150),
                              deflation=DeflationParams(alpha=1e30, cohesion=0.0, friction=0.0),
                              processes=Processes(abrasion=False, deposition=False, stress=stress))
    simulation = Simulation(particles, layers, Rock(), lattice, params, seed=0)
    for _ in range(frames):
        simulation.step()
    return simulation.particles


def _section(particles: Particles, z: float) -> tuple[float, float]:
    """Area (m²) of the pillar's section at height z (m) and the weight (N) above it."""
    zs = particles.positions[:, 2]
    area = np.count_nonzero(np.abs(zs - z) < SPACING / 2) * SPACING**2
    weight = Rock().density * GRAVITY * SPACING**3 * np.count_nonzero(zs > z)
    return area, weight


def test_a_loaded_pillar_stops_thinning_where_its_stress_reaches_the_threshold() -> None:
    """The pillar loses whole particle layers (widths 4, 3, 2, 1 m at this spacing); with
    I = W/(4.4 m²) (W the weight above mid-height once thinned) it must stop at the 2 m width,
    whose section 4 m² is W/I within 15 %, and hold there for frames; with --no-stress
    (I = ∞) it thins on (to 1 m or less)."""
    mid = HEIGHT / 2 + SPACING / 4
    cap_weight = Rock().density * GRAVITY * (8.0 * 8.0 * CAP + 2.0 * 2.0 * (HEIGHT - mid))
    threshold = cap_weight / 4.4
    locked = _pillar_run(threshold, stress=True, frames=40)
    area, weight = _section(locked, mid)
    assert area == pytest.approx(weight / threshold, rel=0.15)
    free = _pillar_run(threshold, stress=False, frames=40)
    assert _section(free, mid)[0] <= 0.3 * area
