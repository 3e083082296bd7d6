"""`--iceflow cnn` (001 §4–5): the network trained on the fly on the Blatter–Pattyn energy, its
refinement, the takeover by the converged solver, determinism, and the refusal without PyTorch.

The glacier: a V valley of 32 × 32 cells of 200 m (walls of slope 0.25) under an ELA of 3000 m,
grown for 200 years by the converged solver, 5 lattice layers; then coupled steps of 20 years.
"""

from __future__ import annotations

import csv
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from affine import Affine
from tests.conftest import write_geotiff

from unerode_cli.glacier import blatter, cnn_iceflow, coupled
from unerode_cli.glacier.lattice import dof_map, ice_columns_with_halo, layer_elevations
from unerode_cli.grid import Grid

ELA, DT = 3000.0, 20.0
TRANSFORM = Affine(200.0, 0.0, 500000.0, 0.0, -200.0, 5000000.0)
FLOW = blatter.FlowParams(n_layers=5)


def _valley(ny: int = 32, nx: int = 32, dx: float = 200.0) -> tuple[np.ndarray, Grid]:
    y, x = np.mgrid[0:ny, 0:nx] * dx
    bed = 2400.0 + 900.0 * np.exp(-x / 2000.0) + 0.25 * np.abs(y - (ny - 1) * dx / 2)
    return bed, Grid.full((ny, nx), dx)


@pytest.fixture(scope="module")
def glacier() -> tuple[coupled.GlacierState, Grid]:
    bed, grid = _valley()
    params = coupled.CoupledParams(flow=FLOW, flow_rtol=1e-2)
    stepping = coupled.Stepping(coupled.GlacierState(bed, np.zeros_like(bed)), grid, params, ELA,
                                coupled.step_times(200.0, DT))
    while not stepping.finished:
        stepping.advance()
    return stepping.state, grid


def _run_cnn(state: coupled.GlacierState, grid: Grid, model: cnn_iceflow.CnnIceflow,
             steps: int) -> tuple[coupled.GlacierState, coupled.StepReport]:
    params = coupled.CoupledParams(flow=FLOW, iceflow="cnn", cnn=model)
    assert cnn_iceflow.model_of(params) is model
    for _ in range(steps):
        state, report = coupled.step(state, grid, params, ELA, DT)
    return state, report


def _surface_error(solution: blatter.FlowSolution, reference: blatter.FlowSolution, ice: np.ndarray) -> float:
    """Relative L2 error of the surface speed over the ice."""
    speed, ref = np.hypot(*solution.surface_velocity())[ice], np.hypot(*reference.surface_velocity())[ice]
    return float(np.linalg.norm(speed - ref) / np.linalg.norm(ref))


# --- without PyTorch ------------------------------------------------------------------------------

def test_without_torch_cnn_is_refused_in_one_sentence_with_exit_2(tmp_path, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "torch", None)  # `import torch` raises ImportError
    with pytest.raises(ValueError, match=r"^--iceflow cnn needs PyTorch: pip install 'unerode-cli\[cnn\]'$"):
        coupled.CoupledParams(iceflow="cnn").validate((4, 4))
    bed, _ = _valley(12, 16)
    dem = write_geotiff(tmp_path / "valley.tif", bed.astype(np.float32), TRANSFORM)
    out = tmp_path / "bed.tif"
    script = ("import sys; sys.modules['torch'] = None; sys.argv[0] = 'unerode-cli'; "
              "from unerode_cli.cli.app import main; main()")
    command = [sys.executable, "-c", script, "glaciate", str(dem), str(out), "--ela", "3000",
               "--duration", "40", "--iceflow", "cnn"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 2, result.stderr
    assert result.stderr.strip().splitlines() == ["error: --iceflow cnn needs PyTorch: pip install "
                                                  "'unerode-cli[cnn]'."]
    assert not out.exists()


# --- the map from the network's nodes to the lattice's unknowns ------------------------------------

def test_node_gradient_is_the_adjoint_of_the_node_to_unknown_map() -> None:
    """<node_gradient(g), w> = <g, unknowns_of(w)> for any node values w: the pull-back the weights'
    update uses is exact, collapsed levels (thin ice) and frozen nodes included."""
    rng = np.random.default_rng(3)
    bed = 1000.0 + 50.0 * rng.random((9, 11))
    h = np.where(rng.random((9, 11)) > 0.3, 40.0 * rng.random((9, 11)), 0.0)  # thin: collapsed levels
    zeta = layer_elevations(bed, h, 6, 2.0)
    frozen = rng.random((9, 11)) > 0.7
    dof, n = dof_map(zeta, ice_columns_with_halo(h, False), frozen)
    count = cnn_iceflow.node_counts(dof, n)
    assert count.sum() == np.sum(dof >= 0) and count.max() > 1
    w = rng.standard_normal((2, *dof.shape))
    g = rng.standard_normal(2 * n)
    lhs = float(np.sum(cnn_iceflow.node_gradient(g, dof, count) * w))
    rhs = float(g @ cnn_iceflow.unknowns_of(w[0], w[1], dof, count))
    assert lhs == pytest.approx(rhs, rel=1e-12)


def test_gaussian_stack_keeps_a_constant_and_smooths_a_spike() -> None:
    stack = cnn_iceflow.gaussian_stack(np.full((20, 28), 3.0))
    assert stack.shape == (cnn_iceflow.STACK_LEVELS, 20, 28)
    np.testing.assert_allclose(stack, 3.0, rtol=1e-6)
    spike = np.zeros((32, 32))
    spike[16, 16] = 1.0
    stack = cnn_iceflow.gaussian_stack(spike, periodic=True)
    # level 0 is the field; every level keeps the spike's sum within 10 % (a ×4 copy for every
    # decimation by 4; σ = 1 cell lets some aliasing through: measured 1.03–1.07), and each
    # level is flatter than the one before
    assert stack[0, 16, 16] == 1.0
    np.testing.assert_allclose(stack.sum(axis=(1, 2)), 1.0, rtol=0.1)
    assert np.all(np.diff(stack.max(axis=(1, 2))) < 0)


# --- with PyTorch ---------------------------------------------------------------------------------

def test_refined_velocities_approach_the_converged_solve_and_the_result_meets_its_tolerance(glacier) -> None:
    """After 8 coupled steps, the refined velocities (prediction + 2 L-BFGS iterations, before
    any takeover) are within 5 % (surface speed over the ice) and the energy within 1 % of a
    solve to 1e-6 of the same geometry; the step's result meets FLOW_RTOL (takeover)."""
    pytest.importorskip("torch")
    start, grid = glacier
    model = cnn_iceflow.CnnIceflow(seed=0, train_steps=30)
    state, report = _run_cnn(start, grid, model, 7)
    reference = blatter.solve(state.bed, state.thickness, grid, FLOW, rtol=1e-6, initial=state.lattice)
    _, report = _run_cnn(state, grid, model, 1)
    refined = model.last.refined
    ice = state.thickness > 1.0
    assert _surface_error(refined, reference, ice) < 0.05
    assert abs(refined.energy - reference.energy) < 0.01 * abs(reference.energy)
    assert report.flow.residual <= coupled.FLOW_RTOL and report.flow.converged
    speed = np.hypot(*report.flow.surface)[ice]
    ref_speed = np.hypot(*reference.surface_velocity())[ice]
    assert np.linalg.norm(speed - ref_speed) < 0.005 * np.linalg.norm(ref_speed)
    assert model.steps == 8 and model.takeovers <= 8


def test_takeover_engages_and_gives_the_converged_solution(glacier) -> None:
    """A fresh network, no training and no refinement: the prediction is u = 0 (the last layer
    starts at zero), whose residual is exactly 1 (∇E(0) is the driving force), so the converged
    solver takes over and its result is that of blatter.solve within its tolerance."""
    pytest.importorskip("torch")
    state, grid = glacier
    model = cnn_iceflow.CnnIceflow(refine_iter=0, train_steps=0)
    solution = model.solve(state.bed, state.thickness, grid, FLOW, rtol=coupled.FLOW_RTOL)
    assert model.last.predicted_residual == pytest.approx(1.0, rel=1e-12)
    assert model.takeovers == 1 and model.last.takeover and model.last.refine_iterations == 0
    assert solution.converged and solution.residual <= coupled.FLOW_RTOL
    reference = blatter.solve(state.bed, state.thickness, grid, FLOW, rtol=1e-6)
    assert _surface_error(solution, reference, state.thickness > 1.0) < 0.005
    assert solution.energy == pytest.approx(reference.energy, rel=1e-4)


def test_same_seed_same_velocities_bit_for_bit(glacier) -> None:
    pytest.importorskip("torch")
    start, grid = glacier
    runs = [_run_cnn(start, grid, cnn_iceflow.CnnIceflow(seed=seed, train_steps=3), 2)[0]
            for seed in (7, 7, 8)]
    for a, b in zip(runs[0].lattice, runs[1].lattice, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(runs[0].thickness, runs[1].thickness)
    # another seed: other weights, the same velocities within the guard's tolerance
    assert not np.array_equal(runs[0].lattice[0], runs[2].lattice[0])
    np.testing.assert_allclose(runs[0].thickness, runs[2].thickness, atol=0.5)


def test_seed_sets_the_initial_weights() -> None:
    """The same seed gives the same initial weights bit for bit, another seed others (the last
    layer of both starts at zero); the caller's random state is left as it was."""
    torch = pytest.importorskip("torch")
    torch.manual_seed(123)
    expected = torch.rand(3)
    torch.manual_seed(123)
    nets = [cnn_iceflow.CnnIceflow(seed=seed)._network(30, 8, False) for seed in (5, 5, 6)]
    np.testing.assert_array_equal(torch.rand(3).numpy(), expected.numpy())
    first = [net[0].weight.detach().numpy() for net in nets]
    np.testing.assert_array_equal(first[0], first[1])
    assert float(np.abs(first[0] - first[2]).max()) > 0.01  # uniform in ±1/√(30·9) ≈ ±0.06
    assert not nets[2][-1].weight.detach().numpy().any()
    with pytest.raises(ValueError, match="seed"):
        cnn_iceflow.CnnIceflow(seed=-1)


def test_a_checkpointed_network_goes_on_as_the_uninterrupted_one(glacier, tmp_path) -> None:
    """The network's weights, Adam's state and counters through a checkpoint file
    (``CnnIceflow.saved``, ``io.checkpoints``) and back: the next steps are bit for bit those of
    the network that was never stopped, and those of a fresh network of the same seed are not."""
    pytest.importorskip("torch")
    from unerode_cli.io.checkpoints import read_state_checkpoint, write_state_checkpoint

    start, grid = glacier
    straight = cnn_iceflow.CnnIceflow(seed=4, train_steps=3)
    state, _ = _run_cnn(start, grid, straight, 2)
    write_state_checkpoint(tmp_path / "state.npz", "run", 2, straight.saved())
    _, _, saved = read_state_checkpoint(tmp_path / "state.npz")
    resumed = cnn_iceflow.CnnIceflow(seed=4, train_steps=3)
    resumed.restore(saved)
    assert resumed.steps == straight.steps == 2 and resumed.takeovers == straight.takeovers
    with pytest.raises(ValueError, match="seed"):
        cnn_iceflow.CnnIceflow(seed=5, train_steps=3).restore(saved)
    runs = [_run_cnn(state, grid, model, 2)[0] for model in (straight, resumed,
                                                             cnn_iceflow.CnnIceflow(seed=4, train_steps=3))]
    for a, b in zip(runs[0].lattice, runs[1].lattice, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(runs[0].thickness, runs[1].thickness)
    assert not np.array_equal(runs[0].lattice[0], runs[2].lattice[0])


def _takeover_counts(summary: str) -> tuple[int, int, int]:
    """(met on their own, predictions, takeovers) from the summary's CNN clause."""
    match = re.search(r"CNN: (\d+) of its (\d+) predictions met it on their own, the converged solver took "
                      r"over (\d+)\)", summary)
    assert match, summary
    return int(match[1]), int(match[2]), int(match[3])


def test_glaciate_runs_with_iceflow_cnn(tmp_path, cli) -> None:
    """A glaciate run with ``--iceflow cnn --seed 5``: the summary and the sidecar count the
    solves the network met the tolerance in on its own and those the converged solver took over,
    as the timeline's rows show them (a takeover iterates past the refinement's REFINE_ITER
    L-BFGS iterations; the first step starts without ice, so the network has nothing to
    predict); the history records the seed."""
    pytest.importorskip("torch")
    bed, _ = _valley(12, 16)
    dem = write_geotiff(tmp_path / "valley.tif", bed.astype(np.float32), TRANSFORM)
    out, ice, timeline = tmp_path / "bed.tif", tmp_path / "ice.tif", tmp_path / "t.csv"
    result = cli("glaciate", dem, out, "--ela", ELA, "--duration", 40, "--dt", 20, "--layers", 3,
                 "--iceflow", "cnn", "--seed", 5, "--ice", ice, "--timeline", timeline)
    assert result.returncode == 0, result.stderr
    from unerode_cli.io.rasters import read_terrain

    thickness = read_terrain(ice).elevation
    assert 1.0 < float(np.nanmax(thickness)) < 200.0
    own, predicted, takeovers = _takeover_counts(result.stdout + result.stderr)
    sidecar = json.loads(out.with_name("bed.tif.json").read_text())
    stats = sidecar["statistics"]
    counts = (stats["cnn_met_tolerance"], stats["cnn_solves"], stats["cnn_takeovers"])
    assert counts == (own, predicted, takeovers)
    rows = list(csv.DictReader(timeline.open()))
    volumes = [0.0] + [float(row["ice_volume_m3"]) for row in rows]
    assert predicted == sum(v > 0 for v in volumes[:-1]) == len(rows) - 1 >= 2
    assert takeovers == sum(int(row["flow_iterations"]) > cnn_iceflow.REFINE_ITER for row in rows)
    assert own + takeovers == predicted
    assert sidecar["seed"] == sidecar["parameters"]["seed"] == 5


@pytest.mark.slow
def test_glaciate_cnn_resumed_ends_as_uninterrupted_and_the_seed_matters(tmp_path, cli) -> None:
    """``--iceflow cnn``: a run stopped after 2 steps (``--max-steps``) and resumed ends bit for bit
    where an uninterrupted one of the same seed does (the checkpoint keeps the network); another
    seed gives other outputs, the same within the takeover's tolerance."""
    pytest.importorskip("torch")
    from unerode_cli.io.rasters import read_terrain

    bed, _ = _valley(12, 16)
    dem = write_geotiff(tmp_path / "valley.tif", bed.astype(np.float32), TRANSFORM)

    def run(name: str, seed: int, *extra: object) -> tuple[Path, str]:
        folder = tmp_path / name
        folder.mkdir(exist_ok=True)
        result = cli("glaciate", dem, folder / "bed.tif", "--ela", ELA, "--duration", 80, "--dt", 20,
                     "--layers", 3, "--iceflow", "cnn", "--seed", seed, "--ice", folder / "ice.tif", *extra)
        assert result.returncode == 0, result.stderr
        return folder, result.stdout + result.stderr

    straight, summary = run("straight", 5)
    resumed, stopped = run("resumed", 5, "--max-steps", 2, "--checkpoint-every", 1)
    assert "stopped after step 2" in stopped
    resumed, summary_resumed = run("resumed", 5, "--resume")
    other, _ = run("other", 6)
    for name in ("bed.tif", "ice.tif"):
        a, b = (read_terrain(folder / name).elevation for folder in (straight, resumed))
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert _takeover_counts(summary) == _takeover_counts(summary_resumed)
    ice, ice_other = (read_terrain(folder / "ice.tif").elevation for folder in (straight, other))
    assert not np.array_equal(ice, ice_other)
    np.testing.assert_allclose(ice, ice_other, atol=0.5)
