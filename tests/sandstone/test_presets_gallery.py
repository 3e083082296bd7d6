"""The presets of every 002 example (Fig. 6, Fig. 7 rows 1–5): each builds the rock its docstring
describes, the water of its sources runs out of the domain, and the fluvial ones shape what
002 §8.2 says they do — the canyon cuts a channel along its water path, the cave's tunnel opens
from its source to the outside, the butte's base retreats under a caprock that stays. A run
with fluvial erosion is the same on one and two threads (separate processes)."""

from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from scipy import ndimage

from unerode_cli.sandstone import basins, discharge, water_receivers
from unerode_cli.sandstone.deposition import DepositionParams
from unerode_cli.sandstone.fluvial import FluvialParams
from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.presets import (
    CANYON_CREST_Y,
    CANYON_CREST_Z,
    CANYON_PATH,
    CANYON_PATH_DEPTH,
    CANYON_PATH_HEAD,
    CANYON_RADIUS,
    CAVE_AXIS,
    CAVE_END,
    CAVE_RADIUS,
    CAVE_SOURCE_Y,
    PRESETS,
    preset_scene,
)
from unerode_cli.sandstone.sampling import lattice_for, scene_particles
from unerode_cli.sandstone.scene import Scene
from unerode_cli.sandstone.simulation import Simulation, SimulationParams
from unerode_cli.sandstone.wind import WindParams


def _canyon_volume() -> float:
    """The canyon block (x 2–28 m, y 2–42 m) under its cylindrical top, less the water path
    (3 m wide, 1.5 m deep from the south face to CANYON_PATH_HEAD), by quadrature (m³)."""
    y = np.linspace(2.0, 42.0, 40_001)
    top = CANYON_CREST_Z + np.sqrt(CANYON_RADIUS**2 - (y - CANYON_CREST_Y) ** 2)
    path_length = CANYON_PATH_HEAD - 2.0
    return 26.0 * np.trapezoid(top, y) - (CANYON_PATH[1] - CANYON_PATH[0]) * CANYON_PATH_DEPTH * path_length


def _ball_below_ground(radius: float, centre_z: float) -> float:
    """Volume (m³) of the cap of a ball below z = 0 (centre at ``centre_z`` > 0)."""
    h = radius - centre_z
    return math.pi * h * h * (3.0 * radius - h) / 3.0


#: The rock's volume (m³) of each preset from its docstring's sizes, worked by hand.
VOLUMES = {
    "arch": 52 * 8 * 36 - 32 * 8 * 2,                                     # fin less the slit
    "hoodoo": 10 * 10 * 30,
    "arcade": 40 * 6 * 26,
    # block less the half ball (r = 2 m, centre 1 m up) on its front face, above the ground
    "alcove": 30 * 14 * 26 - (2 / 3 * math.pi * 2**3 - _ball_below_ground(2.0, 1.0) / 2),
    "butte": 180**2 * 30 + 130**2 * 30 + 80**3 - 5 * 40 * 10,            # three blocks less the crevice
    "canyon": _canyon_volume(),
    "cave": 16 * 36 * 16 - math.pi * CAVE_RADIUS**2 * (CAVE_END - 2.0),  # block less the tunnel
}
#: Share (of the rock) of each preset's painted erodibility factor, from its sizes: the arch's
#: two supports (0.1), the arcade's four balls in its weak layer (4), the alcove's non-erodible
#: back and sides, 1.5 m deep (0).
PAINTED = {
    "arch": (0.1, 2 * 10 * 8 * 8 / VOLUMES["arch"]),
    "arcade": (4.0, 4 * 4 / 3 * math.pi * 2.5**3 / VOLUMES["arcade"]),
    "alcove": (0.0, (30 * 1.5 * 26 + 2 * 1.5 * 12.5 * 26) / VOLUMES["alcove"]),
}


def _particles(scene: Scene, count: int, seed: int = 0):
    lattice, _ = lattice_for(scene.shape, scene.low, np.asarray(scene.domain.size, dtype=float), count)
    return scene_particles(scene, lattice, seed), lattice


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_builds_the_rock_of_its_sizes(name: str) -> None:
    """About 30 000 particles (within 5 %: the sampler sizes its lattice from a probe of the shape)
    fill the preset's volume: N s³ within 3 % of the volume worked out from the sizes its
    docstring gives (the lattice's jitter of a quarter spacing biases the count at faces that do
    not fall on its planes, by up to a quarter spacing times their area); the painted shares are
    those of the painted shapes."""
    particles, lattice = _particles(preset_scene(name), 30_000)
    assert len(particles) == pytest.approx(30_000, rel=0.05)
    assert len(particles) * lattice.spacing**3 == pytest.approx(VOLUMES[name], rel=0.03)
    if name in PAINTED:
        factor, share = PAINTED[name]
        assert np.mean(particles.erodibility == factor) == pytest.approx(share, rel=0.1)


@pytest.mark.parametrize("name", ["canyon", "cave"])
def test_the_water_of_a_source_runs_out_of_the_domain(name: str, one_thread) -> None:
    """The source lies in open space (neither buried in rock nor in a sealed cavity): routed
    over the rock as built, all its water and the rain leave the domain (outflow = inflow,
    nothing lost), and the largest discharge is at least the source's."""
    scene = preset_scene(name)
    particles, lattice = _particles(scene, 20_000)
    receivers = water_receivers.water_receivers(particles.positions, lattice.mpm_grid(), 0, 0)
    flow = discharge.discharge(basins.route_depressions(receivers), scene.water.precipitation,
                               scene.water.source_tuples())
    (source,) = scene.water.sources
    assert flow.lost == 0.0
    assert flow.outflow == pytest.approx(flow.inflow, rel=1e-12)
    assert flow.q.max() >= source.discharge * (1.0 - 1e-12)


def _run(name: str, count: int, frames: int) -> tuple[Simulation, np.ndarray]:
    """``frames`` frames of the preset with the parameters the command line gives it (its wind,
    water and deposit viability), on two threads; returns the run and the initial positions."""
    scene = preset_scene(name)
    particles, lattice = _particles(scene, count)
    wind = WindParams(azimuth=scene.wind.azimuth, elevation=scene.wind.elevation, speed=scene.wind.speed,
                      cone_angle=scene.wind.cone_angle, rays=scene.wind.rays)
    rock = scene.rock_parameters()
    params = SimulationParams(
        wind=wind, deposition=DepositionParams(deposit_viability=rock.deposit_viability),
        fluvial=FluvialParams(precipitation=scene.water.precipitation, sources=scene.water.source_tuples()))
    initial = particles.positions.copy()
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    simulation = Simulation(particles, scene.layer_stack(), rock, lattice, params)
    for _ in range(frames):
        simulation.step()
    return simulation, initial


def _tops(positions: np.ndarray, grid: Grid3D) -> np.ndarray:
    """The highest particle's altitude (m) in each column of ``grid``, 0 (the ground) where none."""
    cells = grid.cells_of(positions)
    top = np.zeros(grid.shape[:2])
    np.maximum.at(top, (cells[:, 0], cells[:, 1]), positions[:, 2])
    return top


CANYON_RUNS = [pytest.param(20_000, 20, id="20k"), pytest.param(60_000, 40, id="60k", marks=pytest.mark.slow)]


@pytest.mark.parametrize("count, frames", CANYON_RUNS)
def test_the_canyon_cuts_a_channel_along_its_water_path(count: int, frames: int, threads) -> None:
    """The top surface's lowering, column by column: all along the water path (each section
    across it, from the south face to the head) the deepest column is lowered by ≥ 3 m, twice the
    path's initial depth, while no column off the path (≥ 1.5 m beside it) is lowered by more than
    0.5 m — the source's water cuts a channel, the rain alone (τ < τ_c) leaves the top."""
    simulation, initial = _run("canyon", count, frames)
    grid = simulation.surface_grid
    lowering = _tops(initial, grid) - _tops(simulation.particles.positions, grid)
    x, y = np.meshgrid(*(grid.origin[a] + (np.arange(grid.shape[a]) + 0.5) * grid.h for a in (0, 1)),
                       indexing="ij")
    on_path = (x > CANYON_PATH[0]) & (x < CANYON_PATH[1])
    sections = (y[0] > 3.0) & (y[0] < CANYON_PATH_HEAD - 1.0)
    depth = np.where(on_path, lowering, -np.inf).max(axis=0)[sections]
    beside = (np.abs(x - 0.5 * sum(CANYON_PATH)) > 3.0) & (x > 2.0) & (x < 28.0) & (y > 2.0) & (y < 42.0)
    assert depth.min() >= 2.0 * CANYON_PATH_DEPTH
    assert lowering[beside].max() <= 0.5


def _open_from_source(positions: np.ndarray, grid: Grid3D) -> tuple[bool, float]:
    """On ``grid`` (one particle per cell of rock): whether the empty cells 6-connected to the
    cave's source cell reach a side or the top of the domain, and the smallest area (m²) that
    region has in a section across the tunnel (along y), from 1 m south of the source to 1 m
    north of the south face, under the block's top."""
    occupied = grid.occupancy(positions) > 0
    labels, _ = ndimage.label(~occupied)
    source = tuple(grid.cells_of(np.array([[CAVE_AXIS[0], CAVE_SOURCE_Y, CAVE_AXIS[1]]]))[0])
    region = labels == labels[source]
    outside = region[0].any() or region[-1].any() or region[:, 0].any() or region[:, -1].any() \
        or region[:, :, -1].any()
    centres = grid.origin[1] + (np.arange(grid.shape[1]) + 0.5) * grid.h
    heights = grid.origin[2] + (np.arange(grid.shape[2]) + 0.5) * grid.h
    inside = region[:, :, heights < 16.0 - grid.h]
    sections = (centres > 3.0) & (centres < CAVE_SOURCE_Y - 1.0)
    return bool(outside), float(inside.sum(axis=(0, 2))[sections].min() * grid.h**2)


CAVE_RUNS = [pytest.param(20_000, 30, id="20k"), pytest.param(60_000, 60, id="60k", marks=pytest.mark.slow)]


@pytest.mark.parametrize("count, frames", CAVE_RUNS)
def test_the_cave_opens_a_tunnel_from_its_source_to_the_outside(count: int, frames: int, threads) -> None:
    """After the run, empty cells lead from the source to the outside (the water's debris did
    not block the course), and the tunnel's narrowest section along it has grown to ≥ 1.5 times
    that of the initial tunnel (π r², r = 2 m): the source's water opens the cave."""
    simulation, _ = _run("cave", count, frames)
    reaches_outside, narrowest = _open_from_source(simulation.particles.positions, simulation.surface_grid)
    assert reaches_outside
    assert narrowest >= 1.5 * math.pi * CAVE_RADIUS**2


BUTTE_RUNS = [pytest.param(20_000, 40, id="20k"), pytest.param(60_000, 100, id="60k", marks=pytest.mark.slow)]


@pytest.mark.parametrize("count, frames", BUTTE_RUNS)
def test_the_buttes_base_retreats_under_a_caprock_that_stays(count: int, frames: int, threads) -> None:
    """The plan area of the lower slab's upper 10 m (columns holding such rock) shrinks by ≥ 4 %
    (its edges retreat under the water falling over them), while the caprock keeps ≥ 98 % of its
    plan area and of its particles."""
    simulation, initial = _run("butte", count, frames)
    grid = simulation.surface_grid
    rock = simulation.particles.select(~simulation.particles.deposit)
    start_layer = simulation.layers.index_of(initial[:, 2])

    def plan_area(positions: np.ndarray, low: float, high: float) -> float:
        cells = grid.cells_of(positions[(positions[:, 2] > low) & (positions[:, 2] < high)])
        return len(np.unique(cells[:, 0] * grid.shape[1] + cells[:, 1])) * grid.h**2

    slab_before = plan_area(initial[start_layer == 0], 20.0, 30.0)
    slab_after = plan_area(rock.positions[rock.layer == 0], 20.0, 30.0)
    cap_before = plan_area(initial[start_layer == 3], 110.0, 140.0)
    cap_after = plan_area(rock.positions[rock.layer == 3], 110.0, 140.0)
    assert slab_after <= 0.96 * slab_before
    assert cap_after >= 0.98 * cap_before
    assert np.count_nonzero(rock.layer == 3) >= 0.98 * np.count_nonzero(start_layer == 3)


@pytest.mark.slow
def test_a_canyon_run_is_the_same_on_one_and_two_threads(tmp_path: Path) -> None:
    """The command line in two processes, NUMBA_NUM_THREADS=1 and 2: the same particles file,
    byte for byte, after frames in which the water eroded (eroded_fluvial > 0)."""
    files = []
    for threads in (1, 2):
        out = tmp_path / f"t{threads}"
        result = subprocess.run(
            [sys.executable, "-m", "unerode_cli", "sandstone", "canyon", str(out), "--particles", "6000",
             "--frames", "4", "--seed", "3", "--substeps", "10", "--settle-substeps", "200", "-q"],
            capture_output=True, text=True, timeout=300,
            env={**os.environ, "NUMBA_NUM_THREADS": str(threads)})
        assert result.returncode == 0, result.stderr
        with open(out / "frames.csv", newline="") as table:
            assert sum(int(row["eroded_fluvial"]) for row in csv.DictReader(table)) > 0
        files.append((out / "particles.ply").read_bytes())
    assert files[0] == files[1]
