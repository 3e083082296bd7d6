"""Vegetation (002 §8.3): the cover shields the rock from the wind, and grows on stable deposits."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.sandstone.deflation import DeflationParams
from unerode_cli.sandstone.layers import Layer, LayerStack, Rock
from unerode_cli.sandstone.mpm import MpmParams
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.sampling import Lattice
from unerode_cli.sandstone.simulation import Processes, Simulation, SimulationParams
from unerode_cli.sandstone.surface import surface_particles
from unerode_cli.sandstone.vegetation import VegetationParams, grow, shielding

#: Block of 12 × 12 × 12 lattice cells (1 m) in a 12 × 12 × 14 m domain.
SIDE, HEIGHT = 12, 12
#: A few MPM substeps: the deflation below does not depend on the stress (μ_c = μ_f = 0).
FAST_MPM = MpmParams(substeps=2, settle_substeps=2)


def _block(cover: float) -> tuple[Particles, Lattice]:
    """One particle per 1 m cell centre of the block; a rim one cell wide is painted
    non-erodible, so only the top of the inside wears and every layer holds 10 × 10 particles."""
    i, j, k = np.meshgrid(np.arange(SIDE), np.arange(SIDE), np.arange(HEIGHT), indexing="ij")
    positions = np.column_stack([i.ravel(), j.ravel(), k.ravel()]) + 0.5
    rim = (np.minimum(i, j).ravel() == 0) | (np.maximum(i, j).ravel() == SIDE - 1)
    particles = Particles.new(positions, np.zeros(len(positions), np.int32),
                              erodibility=np.where(rim, 0.0, 1.0), vegetation=np.full(len(positions), cover))
    return particles, Lattice((0.0, 0.0, 0.0), (float(SIDE), float(SIDE), HEIGHT + 2.0), 1.0)


def _deflated(cover: float, shield: float, frames: int) -> int:
    """Particles the block loses in ``frames`` frames of deflation alone at W_d = k_d = 10 and
    E·Δt = 1e-4 /y × 1000 y: a bare surface particle loses b = 1 in one frame."""
    particles, lattice = _block(cover)
    params = SimulationParams(mpm=FAST_MPM, deflation=DeflationParams(cohesion=0.0, friction=0.0),
                              processes=Processes(abrasion=False, deposition=False),
                              vegetation=VegetationParams(shield=shield))
    layers = LayerStack((Layer(k_w=1e-4, k_d=10.0),), Layer(k_w=1e-4, k_d=10.0))
    simulation = Simulation(particles, layers, Rock(), lattice, params)
    for _ in range(frames):
        simulation.step()
    return len(particles) - len(simulation.particles)


def test_a_vegetated_block_loses_one_minus_s_times_the_particles_of_a_bare_one(one_thread) -> None:
    """Deflation alone, rim non-erodible: the inside's top retreats one layer (100 particles)
    every 1/r frames, r the viability lost per frame. Bare r = 1; under a full cover with
    s = 0.75, r = 0.25 (exact in binary, so the fourth frame reaches b = 0 exactly), so in 8
    frames the bare block loses 8 layers and the vegetated one 2: the ratio 1 − s holds to the
    particle. (With a rate whose inverse is not a whole number of frames, the ratio would only
    hold within one frame per layer.)"""
    bare = _deflated(0.0, 0.75, 8)
    vegetated = _deflated(1.0, 0.75, 8)
    assert bare == 8 * 100
    assert vegetated / bare == pytest.approx(1.0 - 0.75, abs=1e-12)


def test_a_shield_of_zero_leaves_the_erosion_unchanged(one_thread) -> None:
    assert _deflated(1.0, 0.0, 3) == _deflated(0.0, 0.9, 3) == 3 * 100


def test_shielding_is_one_minus_s_v() -> None:
    cover = np.array([0.0, 0.25, 1.0])
    np.testing.assert_allclose(shielding(cover, 0.9), [1.0, 0.775, 0.1], rtol=1e-15)


def test_growth_adds_r_dt_on_stable_deposits_only_and_caps_at_one() -> None:
    cover = np.array([0.0, 0.5, 0.95, 1.0, 0.3])
    stable = np.array([True, True, True, True, False])
    np.testing.assert_allclose(grow(cover, stable, 1e-4, 1000.0), [0.1, 0.6, 1.0, 1.0, 0.3], rtol=1e-12)


def test_vegetation_params_are_checked() -> None:
    with pytest.raises(ValueError, match="shield"):
        VegetationParams(shield=1.5)
    with pytest.raises(ValueError, match="growth"):
        VegetationParams(growth=-1.0)


def test_in_a_run_only_the_surface_deposits_grow_a_cover_up_to_one(one_thread) -> None:
    """A slab of deposits 3 cells thick on the ground beside a rock column that deflation erodes
    a layer per frame; deposits do not deflate (their k_d is 0), so they all stay. Growth
    R = 2e-4 /y, Δt = 1000 y: after 7 frames the slab's particles still on the surface carry
    min(1, 7 × 0.2) = 1, its buried ones 0, the rock 0, and every deposit 0.2 per frame it has
    lain on the surface: a multiple of 0.2 in [0, 1], above 0 for some of the column's debris."""
    i, j, k = np.meshgrid(np.arange(SIDE), np.arange(SIDE), np.arange(3), indexing="ij")
    slab = np.column_stack([i.ravel(), j.ravel(), k.ravel()])[i.ravel() >= 6] + 0.5
    i, j, k = np.meshgrid(np.arange(1, 4), np.arange(4, 8), np.arange(10), indexing="ij")
    column = np.column_stack([i.ravel(), j.ravel(), k.ravel()]) + 0.5
    rock = Particles.new(column, np.zeros(len(column), np.int32))
    deposits = Particles.new(slab, np.ones(len(slab), np.int32), viability=0.0, deposit=True)
    lattice = Lattice((0.0, 0.0, 0.0), (float(SIDE), float(SIDE), HEIGHT + 2.0), 1.0)
    params = SimulationParams(mpm=FAST_MPM, deflation=DeflationParams(cohesion=0.0, friction=0.0),
                              processes=Processes(abrasion=False),
                              vegetation=VegetationParams(growth=2e-4))
    layers = LayerStack((Layer(k_w=1e-4, k_d=10.0),), Layer(k_w=1e-4, k_d=0.0))
    simulation = Simulation(rock.appended(deposits), layers, Rock(), lattice, params)
    for _ in range(7):
        simulation.step()
    p = simulation.particles
    n_rock = int(np.count_nonzero(~p.deposit))
    assert n_rock < len(column) - 20, "the column did not erode"
    assert np.all(p.vegetation[~p.deposit] == 0.0)
    old = p.select(np.arange(n_rock, n_rock + len(slab)))
    np.testing.assert_allclose(old.positions, slab, atol=1e-3)
    on_top = surface_particles(old.positions, simulation.surface_grid)
    np.testing.assert_allclose(old.vegetation[on_top & (slab[:, 2] > 2.0)], 1.0, rtol=1e-12)
    x, y, z = slab.T
    buried = (z < 2.0) & (x > 7.0) & (x < 11.0) & (y > 1.0) & (y < 11.0)
    np.testing.assert_array_equal(old.vegetation[buried], 0.0)
    cover = p.vegetation[p.deposit]
    np.testing.assert_allclose(cover / 0.2, np.round(cover / 0.2), atol=1e-9)
    assert cover.max() <= 1.0
    assert p.vegetation[n_rock + len(slab):].max(initial=0.0) > 0.0, "no debris lay on the surface a frame"
