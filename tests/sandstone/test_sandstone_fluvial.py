"""Fluvial erosion (002 §6, Eq. 14): the shear stress against Manning's law, the threshold, the
Q^0.6 scaling, the slope from normals, the frame loop's fluvial stage and the command line."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numba
import numpy as np
import pytest
from tests.conftest import run_cli

from unerode_cli.sandstone.fluvial import (
    SECONDS_PER_YEAR,
    FluvialParams,
    fluvial_rate,
    shear_stress,
    slope,
)
from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.mpm import MpmParams
from unerode_cli.sandstone.sampling import lattice_for, scene_particles
from unerode_cli.sandstone.scene import parse_scene
from unerode_cli.sandstone.simulation import Processes, Simulation, SimulationParams

GRID = Grid3D((0.0, 0.0, 0.0), 1.0, (4, 4, 4))


def test_the_default_k_f_gives_mannings_shear_stress_of_a_1_m_wide_flow():
    """τ = ρ g R S with the depth R = (n q / √S)^0.6 of Manning's law, n = 0.03, q = 1 m³/s
    over 1 m, S = 0.01: R = 0.3^0.6 m, τ = 9810 R × 0.01 ≈ 47.6 Pa."""
    depth = (0.03 * 1.0 / math.sqrt(0.01)) ** 0.6
    assert shear_stress(np.array([SECONDS_PER_YEAR]), np.array([0.01]))[0] == pytest.approx(
        1000.0 * 9.81 * depth * 0.01, rel=1e-12)


def test_slope_from_normals_and_its_cap():
    angles = np.radians([0.0, 10.0, 45.0, 80.0])
    normals = np.column_stack([np.sin(angles) * 0.6, np.sin(angles) * 0.8, np.cos(angles)])
    np.testing.assert_allclose(slope(normals), np.tan(angles), rtol=1e-12, atol=1e-15)
    # a vertical wall, a ceiling (|n_z|), a face at 86° (capped), one at 84° (S = 9.51)
    steep = [math.radians(86.0), math.radians(84.0)]
    walls = np.array([[1.0, 0.0, 0.0], [0.0, 0.6, -0.8], [math.sin(steep[0]), 0.0, math.cos(steep[0])],
                      [0.0, math.sin(steep[1]), math.cos(steep[1])]])
    np.testing.assert_allclose(slope(walls, max_slope=10.0), [10.0, 0.75, 10.0, math.tan(steep[1])],
                               rtol=1e-12)


def _surface_particles(discharges: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One surface particle on a 30° slope in each top cell of GRID, and the discharge grid
    that gives the particles ``discharges`` (m³/y, 16 values)."""
    i, j = np.meshgrid(np.arange(4), np.arange(4), indexing="ij")
    positions = np.column_stack([i.ravel() + 0.5, j.ravel() + 0.5, np.full(16, 3.5)])
    angle = math.radians(30.0)
    normals = np.tile([math.sin(angle), 0.0, math.cos(angle)], (16, 1))
    q = np.zeros(GRID.shape)
    q[i.ravel(), j.ravel(), 3] = discharges
    return positions, normals, q


def test_no_erosion_below_the_critical_shear_stress_and_k_t_times_the_excess_above():
    discharges = np.geomspace(1.0, 1e7, 16)  # m³/y
    positions, normals, q = _surface_particles(discharges)
    layer = np.zeros(16, dtype=np.int32)
    k_t, tau_c = np.array([300.0]), np.array([5.0])
    params = FluvialParams()
    rate = fluvial_rate(positions, normals, np.ones(16, bool), layer, k_t, tau_c, q, GRID, params)
    # Manning's depth for q = Q/1 m at S = tan 30°, then τ = ρ g R S (independent of k_f)
    s = math.tan(math.radians(30.0))
    tau = 1000.0 * 9.81 * (0.03 * discharges / SECONDS_PER_YEAR / math.sqrt(s)) ** 0.6 * s
    assert np.any(tau < 5.0) and np.any(tau > 5.0)
    np.testing.assert_allclose(rate, 300.0 * np.maximum(tau - 5.0, 0.0), rtol=1e-11, atol=1e-12)
    assert np.all(rate[tau < 5.0] == 0.0)
    dry = fluvial_rate(positions, normals, np.ones(16, bool), layer, k_t, np.array([0.0]), q * 0.0, GRID,
                       params)
    assert np.all(dry == 0.0)
    buried = fluvial_rate(positions, normals, np.zeros(16, bool), layer, k_t, tau_c, q, GRID, params)
    assert np.all(buried == 0.0)


def test_doubling_the_discharge_scales_f_plus_k_t_tau_c_by_2_to_the_0_6():
    discharges = np.geomspace(1e5, 1e8, 16)  # every τ above τ_c, at double Q too
    positions, normals, q = _surface_particles(discharges)
    args = (np.ones(16, bool), np.zeros(16, dtype=np.int32), np.array([250.0]), np.array([3.0]))
    once = fluvial_rate(positions, normals, *args, q, GRID, FluvialParams())
    twice = fluvial_rate(positions, normals, *args, 2.0 * q, GRID, FluvialParams())
    assert np.all(once > 0.0)
    np.testing.assert_allclose(twice + 250.0 * 3.0, 2.0**0.6 * (once + 250.0 * 3.0), rtol=1e-12)


SCENE = {
    "domain": {"size": [16.0, 10.0, 10.0]},
    "particles": 6000,
    "shape": {"box": {"min": [1.0, 1.0, 0.0], "max": [15.0, 9.0, 6.0]}},
    "layers": [{"k_w": 1e-4, "k_t": 400.0, "tau_c": 1.0}],
    "water": {"precipitation": 0.0, "sources": [{"position": [13.0, 5.0, 8.0], "discharge": 3e5}]},
}


def _simulation(seed: int, processes: Processes) -> Simulation:
    scene = parse_scene(SCENE)
    lattice, _ = lattice_for(scene.shape, scene.low, np.array(scene.domain.size), scene.particles)
    water = FluvialParams(precipitation=scene.water.precipitation, sources=scene.water.source_tuples())
    params = SimulationParams(mpm=MpmParams(substeps=10, settle_substeps=200), fluvial=water,
                              processes=processes)
    return Simulation(scene_particles(scene, lattice, seed), scene.layer_stack(), scene.rock_parameters(),
                      lattice, params, seed=seed)


def test_a_source_erodes_the_rock_it_runs_over_and_nothing_without_water(threads):
    """Wind off: every eroded particle is eroded by the water of the source (3e5 m³/y), which
    lands on the block's top and runs off it; without fluvial erosion nothing erodes. The same
    seed gives the same particles on one and two threads."""
    no_wind = {"abrasion": False, "deflation": False}
    runs = []
    for n in (1, 2):
        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
        simulation = _simulation(5, Processes(**no_wind))
        stats = [simulation.step() for _ in range(3)]
        runs.append(simulation.particles)
    assert sum(s.eroded for s in stats) > 0
    assert all(s.eroded_fluvial == s.eroded for s in stats)
    assert stats[-1].discharge_max >= 3e5 * (1.0 - 1e-12)
    for name, values in runs[0].arrays().items():
        np.testing.assert_array_equal(values, runs[1].arrays()[name], err_msg=name)
    numba.set_num_threads(1)
    dry = _simulation(5, Processes(fluvial=False, **no_wind))
    assert all(dry.step().eroded == 0 for _ in range(2))


def _scene_file(tmp_path: Path) -> Path:
    path = tmp_path / "scene.json.yaml"
    path.write_text(json.dumps(SCENE))  # JSON is YAML
    return path


def test_the_command_line_reports_the_fluvial_stage(tmp_path: Path):
    out = tmp_path / "run"
    result = run_cli("sandstone", _scene_file(tmp_path), out, "--frames", "2", "--substeps", "10",
                     "--settle-substeps", "200", "--source", "3,5,8,1e5", "--precipitation", "0.5",
                     "--no-abrasion", "-q")
    assert result.returncode == 0, result.stderr
    with open(out / "frames.csv", newline="") as table:
        rows = list(csv.DictReader(table))
    assert len(rows) == 2 and float(rows[-1]["discharge_max_m3y"]) >= 3e5 * (1.0 - 1e-12)
    run = json.loads((out / "run.json").read_text())
    assert run["parameters"]["fluvial"]["sources"] == [[13.0, 5.0, 8.0, 3e5], [3.0, 5.0, 8.0, 1e5]]
    assert run["parameters"]["fluvial"]["precipitation"] == 0.5
    assert run["statistics"]["eroded_fluvial"] == sum(int(r["eroded_fluvial"]) for r in rows)


@pytest.mark.parametrize("source, says", [("3,5,80,1e5", "outside the domain"), ("3,5,1e5", "X,Y,Z,Q"),
                                          ("3,5,8,-1", "discharge")])
def test_a_bad_source_is_refused_with_exit_2(tmp_path: Path, source: str, says: str):
    out = tmp_path / "run"
    result = run_cli("sandstone", _scene_file(tmp_path), out, "--source", source)
    assert result.returncode == 2, result.stderr
    lines = [line for line in result.stderr.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and says in lines[0]
    assert not out.exists()
