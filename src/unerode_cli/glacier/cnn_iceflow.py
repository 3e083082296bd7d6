"""Ice velocities by a convolutional network trained on the fly on the Blatter–Pattyn energy
(001 §4–5, §7): ``CoupledParams(iceflow="cnn")``.

No data set and no pre-training: the network's loss is the energy E of 001 Eq. 7 itself, so
every step of a run trains it on the geometry of that step. Each call of ``CnnIceflow.solve``
(one glacier step):

1. **Predict**: the network maps the geometry to the horizontal velocities (u, v) at the N + 1
   levels of the lattice (``blatter``, ``lattice``);
2. **Update the weights** with the energy's gradient at the prediction: ∇E with respect to the
   lattice unknowns (``blatter_energy.objective``, analytic, numba) is pulled back to the nodes
   the network wrote (``node_gradient``) and propagated through the network
   (``prediction.backward(gradient=…)``), then one Adam step (learning rate
   ``LEARNING_RATE``); 1–2 are repeated ``TRAIN_STEPS`` times on the same geometry, and the last
   prediction (made before the last update) is the step's warm start. The energy is not
   re-implemented in PyTorch;
3. **Refine**: ``refine_iter`` (``REFINE_ITER`` = 2) L-BFGS iterations of ``blatter.solve``
   warm-started from the prediction (001: "a single step of gradient descent");
4. **Accuracy guard**: a refinement that ends above the residual ``rtol`` (‖∇E‖/‖∇E(0)‖, the
   prognostic runs' ``coupled.FLOW_RTOL`` = 1e-3) is handed to ``blatter.solve``, which goes on
   from the refined velocities to ``rtol`` (at most ``max_iter`` iterations): a *takeover*,
   counted in ``CnnIceflow.takeovers``. Every solution handed back thus meets the tolerance of
   the converged solver (or is reported unconverged exactly as its solves are), whatever the
   network predicted: the network changes the cost of a step, not its result beyond that
   tolerance.

Inputs (001 §4.2): on the nodes of the basal grid, six fields zeroed where there is no ice —
the ice thickness H / ``THICKNESS_SCALE``, the bed slopes towards +x, −x, +y, −y (dimensionless,
the background inclination included), and the sliding parameter ``SLIDING_SCALE`` / C (0 where
the bed is frozen, C = ∞) — each given as a Gaussian stack of ``STACK_LEVELS`` levels
(``gaussian_stack``): 6 × 5 = 30 channels. Network (001 §7): ``CONV_LAYERS`` 3 × 3
convolutions of ``FEATURES`` features with ReLU between them (zero padding; circular on a
periodic domain), the last one linear with 2·(N + 1) output channels: u at levels 0…N then v,
times ``VELOCITY_SCALE`` (m/y). The last layer starts at zero, so an untrained network predicts
u = 0 (residual 1). Collapsed levels of thin ice share one unknown: it takes the mean of their
predicted nodes (``unknowns_of``). float32 in the network, float64 everywhere else.

Determinism: the weights are drawn from ``torch.manual_seed(seed)`` inside
``torch.random.fork_rng`` (the caller's random state is left as it was); the model sets
``torch.use_deterministic_algorithms(True)`` and ``torch.set_num_threads`` to numba's thread
count (``NUMBA_NUM_THREADS``), both process-wide. Two runs with the same seed, PyTorch build,
CPU and thread count give bit-identical velocities; another thread count or CPU may change the
last bits of the convolutions' sums, and so the weights after the first update (the results
stay within the guard's tolerance).

State: ``CnnIceflow`` holds the network, its optimiser and the counters. A run's
``coupled.CoupledParams`` carries one in its field ``cnn`` (``run.glacial.plan`` makes it with
``--seed``; ``model_of``), so the weights persist from step to step of that run and nothing is
global. ``saved``/``restore`` give a checkpoint the weights, Adam's moments and step counts and
the counters, every float exact: a run resumed from one goes on with the same network.

PyTorch is the optional extra ``unerode-cli[cnn]``; it is imported only when a model is made
(``require_torch``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from unerode_cli.glacier import blatter
from unerode_cli.grid import Grid

#: The one sentence that refuses ``--iceflow cnn`` where PyTorch is not installed.
NEEDS_TORCH = "--iceflow cnn needs PyTorch: pip install 'unerode-cli[cnn]'"
#: Gaussian stack (001 §4.2): levels, standard deviation (cells), kernel half-width (σ's).
STACK_LEVELS, STACK_SIGMA, STACK_TRUNCATE = 5, 1.0, 5.0
#: Network (001 §7): convolution layers and features per hidden layer.
CONV_LAYERS, FEATURES = 6, 64
#: Adam's learning rate. 001 §7 uses 1e-4 with one update per step over thousands of steps; on the
#: 32² valley glacier of ``tests/glacier/test_cnn_iceflow.py`` one update per step at 1e-3 still left
#: the refined velocities 72 % off the converged ones after 20 steps (TRAIN_STEPS).
LEARNING_RATE = 1e-3
#: Adam steps per glacier step (each: predict, ∇E at the prediction, back-propagate). Measured on
#: that glacier after 20 steps (surface-speed error of the refined velocities, energy gap): 1 step
#: 72 % / 46 %, 10 steps 5 % / 0.5 %, 50 steps 1.4 % / 0.04 %.
TRAIN_STEPS = 10
#: L-BFGS iterations of the refinement (step 3 of the module docstring). On that glacier after 20
#: steps of 50 Adam steps, the prediction alone is 3 % off the converged surface speed and 2
#: iterations bring it to 1.4 % (with 10 Adam steps, 4–10 % with 1 or 2 iterations alike); no few
#: iterations reach the guard's residual of 1e-3 (0.1–0.3 after 2).
REFINE_ITER = 2
#: Scales of the inputs and outputs: H / THICKNESS_SCALE (m), SLIDING_SCALE / C
#: (C in Pa·(y/m)^(σ−1)), network output × VELOCITY_SCALE (m/y).
THICKNESS_SCALE = 200.0
SLIDING_SCALE = blatter.DEFAULT_SLIDING_C
VELOCITY_SCALE = 100.0
#: Largest SLIDING_SCALE / C fed to the network (C → 0 would make it infinite).
SLIDING_INPUT_MAX = 100.0
DEFAULT_SEED = 0
#: The counters of a ``CnnIceflow`` that ``CnnIceflow.saved`` keeps.
_COUNTERS = ("steps", "takeovers", "refine_iterations", "takeover_iterations")


def require_torch() -> Any:
    """The ``torch`` module; ValueError(``NEEDS_TORCH``) where it cannot be imported."""
    try:
        import torch
    except ImportError:
        raise ValueError(NEEDS_TORCH) from None
    return torch


def gaussian_stack(field: np.ndarray, levels: int = STACK_LEVELS, sigma: float = STACK_SIGMA,
                   periodic: bool = False) -> np.ndarray:
    """The Gaussian stack of ``field`` (float[ny, nx]; 001 §4.2, Lefebvre & Hoppe 2005):
    float32[levels, ny, nx], level i being i alias-free halvings (Gaussian blur of σ cells, then
    every other node) followed by i doublings (nearest copy, then the same blur) cropped to the
    field's shape; level 0 is the field itself."""
    from scipy import ndimage

    mode = "wrap" if periodic else "nearest"

    def blur(a: np.ndarray) -> np.ndarray:
        return ndimage.gaussian_filter(a, sigma, mode=mode, truncate=STACK_TRUNCATE)

    f = np.asarray(field, dtype=np.float64)
    out = np.empty((levels, *f.shape), dtype=np.float32)
    out[0] = f
    coarse = [f]
    for _ in range(1, levels):
        coarse.append(blur(coarse[-1])[::2, ::2])
    for i in range(1, levels):
        a = coarse[i]
        for j in range(i, 0, -1):
            shape = coarse[j - 1].shape
            a = blur(np.repeat(np.repeat(a, 2, axis=0), 2, axis=1)[:shape[0], :shape[1]])
        out[i] = a
    return out


def input_fields(bed: np.ndarray, thickness: np.ndarray, sliding_c: np.ndarray, dx: float, dy: float,
                 tilt: float, periodic: bool) -> np.ndarray:
    """The six input fields, float64[6, ny, nx], 0 where H = 0: H / THICKNESS_SCALE; the bed
    slopes (b(neighbour) − b)/distance towards +x, −x, +y, −y (1; tilt = tan of the background
    inclination along +x, whose true bed is b − x·tilt; across an open edge the outside is taken at
    the edge's b, so only the tilt remains);
    min(SLIDING_SCALE / C, SLIDING_INPUT_MAX) (0 where C = ∞)."""
    b = np.asarray(bed, dtype=np.float64)
    h = np.asarray(thickness, dtype=np.float64)
    pad = np.pad(b, 1, mode="wrap" if periodic else "edge")
    centre = pad[1:-1, 1:-1]
    east = (pad[1:-1, 2:] - centre) / dx - tilt
    west = (pad[1:-1, :-2] - centre) / dx + tilt
    north = (pad[2:, 1:-1] - centre) / dy
    south = (pad[:-2, 1:-1] - centre) / dy
    c = np.asarray(sliding_c, dtype=np.float64)
    with np.errstate(divide="ignore"):
        slide = np.where(np.isinf(c), 0.0, np.minimum(SLIDING_SCALE / c, SLIDING_INPUT_MAX))
    fields = np.stack([h / THICKNESS_SCALE, east, west, north, south, np.broadcast_to(slide, h.shape)])
    return np.where(h > 0, fields, 0.0)


def network_input(bed: np.ndarray, thickness: np.ndarray, sliding_c: np.ndarray, dx: float, dy: float,
                  tilt: float, periodic: bool) -> np.ndarray:
    """float32[6·STACK_LEVELS, ny, nx]: the Gaussian stack of each of ``input_fields``."""
    fields = input_fields(bed, thickness, sliding_c, dx, dy, tilt, periodic)
    return np.concatenate([gaussian_stack(f, periodic=periodic) for f in fields])


def node_counts(dof: np.ndarray, n: int) -> np.ndarray:
    """float64[n]: how many lattice nodes share each unknown (collapsed levels share one)."""
    return np.bincount(dof[dof >= 0], minlength=n).astype(np.float64)


def unknowns_of(u: np.ndarray, v: np.ndarray, dof: np.ndarray, count: np.ndarray) -> np.ndarray:
    """x = [u_dof, v_dof] (m/y): each unknown the mean of the node velocities (u, v)
    float[N+1, ny, nx] that share it (nodes with dof −1 are dropped)."""
    has = dof >= 0
    n = count.size
    safe = np.maximum(count, 1.0)
    xu = np.bincount(dof[has], weights=u[has], minlength=n) / safe
    xv = np.bincount(dof[has], weights=v[has], minlength=n) / safe
    return np.concatenate([xu, xv])


def node_gradient(g: np.ndarray, dof: np.ndarray, count: np.ndarray) -> np.ndarray:
    """∂E/∂(node velocity) float64[2, N+1, ny, nx] of the map ``unknowns_of`` from the gradient g
    = ∂E/∂x (float64[2n]): g of the node's unknown over its node count, 0 on held nodes."""
    n = count.size
    has = dof >= 0
    safe = np.maximum(count, 1.0)
    out = np.zeros((2, *dof.shape))
    out[0][has] = (g[:n] / safe)[dof[has]]
    out[1][has] = (g[n:] / safe)[dof[has]]
    return out


@dataclass
class CnnStep:
    """What one ``CnnIceflow.solve`` did: the relative residual ‖∇E‖/‖∇E(0)‖ of the prediction
    and of the refinement, the refinement's L-BFGS iterations, whether the converged solver took
    over (and its iterations), and the refined velocities (``blatter.FlowSolution``, before any
    takeover)."""

    predicted_residual: float
    refined_residual: float
    refine_iterations: int
    takeover: bool
    takeover_iterations: int
    refined: blatter.FlowSolution


class CnnIceflow:
    """The network, its Adam optimiser and the counters of one run (module docstring).

    Args:
        seed: seed of the initial weights (``torch.manual_seed``), 0 to 2^63 − 1.
        learning_rate: Adam's learning rate.
        refine_iter: L-BFGS iterations of the refinement (0: none).
        train_steps: Adam steps per solve, each on a new prediction of the same geometry (0: the
            weights are left as they are).

    Counters: ``steps`` solved (geometries with a driving stress: the network predicted),
    ``takeovers`` by the converged solver, ``refine_iterations`` and ``takeover_iterations``
    (L-BFGS, summed); ``last`` the ``CnnStep`` of the last solve (None when it had nothing to
    predict: no ice, or no driving stress).
    """

    def __init__(self, seed: int = DEFAULT_SEED, learning_rate: float = LEARNING_RATE,
                 refine_iter: int = REFINE_ITER, train_steps: int = TRAIN_STEPS) -> None:
        if not (0 <= learning_rate < math.inf and refine_iter >= 0 and train_steps >= 0):
            raise ValueError("the CNN's learning rate, refinement iterations and training steps must be ≥ 0")
        if not 0 <= seed < 2**63:
            raise ValueError(f"the CNN's seed must be a whole number from 0 to 2^63 − 1, got {seed}")
        self.seed, self.learning_rate = seed, learning_rate
        self.refine_iter, self.train_steps = refine_iter, train_steps
        self.network: Any = None
        self.optimizer: Any = None
        self.shape: tuple[int, int, bool] | None = None  # (input, output channels, periodic)
        self.steps = self.takeovers = self.refine_iterations = self.takeover_iterations = 0
        self.last: CnnStep | None = None

    def _network(self, channels_in: int, channels_out: int, periodic: bool) -> Any:
        """The network for these channels (made, seeded, on first use; ValueError if a later
        step asks for other channels, e.g. another number of layers)."""
        torch = require_torch()
        torch.use_deterministic_algorithms(True)
        import numba

        torch.set_num_threads(max(1, numba.get_num_threads()))
        shape = (channels_in, channels_out, periodic)
        if self.network is not None:
            if shape != self.shape:
                raise ValueError(f"this CNN ice-flow model was made for {self.shape[1]} output channels, "
                                 f"a step asks for {channels_out}")
            return self.network
        padding = "circular" if periodic else "zeros"
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(self.seed)
            layers: list[Any] = []
            width = channels_in
            for k in range(CONV_LAYERS):
                last = k == CONV_LAYERS - 1
                out = channels_out if last else FEATURES
                layers.append(torch.nn.Conv2d(width, out, 3, padding=1, padding_mode=padding))
                if not last:
                    layers.append(torch.nn.ReLU())
                width = out
            self.network = torch.nn.Sequential(*layers)
            with torch.no_grad():  # the network starts from rest: u = 0 everywhere
                layers[-1].weight.zero_()
                layers[-1].bias.zero_()
        self.optimizer = torch.optim.Adam(self.network.parameters(), lr=self.learning_rate)
        self.shape = shape
        return self.network

    def predict(self, features: np.ndarray, n_levels: int, periodic: bool) -> Any:
        """The network's velocities, a float32 tensor [2, N+1, ny, nx] (m/y; u then v) that
        carries its graph for ``update``."""
        torch = require_torch()
        net = self._network(features.shape[0], 2 * n_levels, periodic)
        out = net(torch.from_numpy(np.ascontiguousarray(features))[None])[0]
        return (out * VELOCITY_SCALE).reshape(2, n_levels, *features.shape[1:])

    def update(self, prediction: Any, gradient: np.ndarray) -> None:
        """One Adam step of the weights along ∂E/∂weights = (∂prediction/∂weights)ᵀ·gradient,
        ``gradient`` float64[2, N+1, ny, nx] (``node_gradient``, scaled)."""
        torch = require_torch()
        self.optimizer.zero_grad()
        prediction.backward(gradient=torch.from_numpy(gradient.astype(np.float32)))
        self.optimizer.step()

    def warm_start(self, fine: Any, features: np.ndarray, drive: float, periodic: bool) -> tuple[
            np.ndarray, float]:
        """Predict and train (steps 1–2 of the module docstring) on the lattice ``fine``
        (``blatter._Level``) with the network input ``features`` (``network_input``) and the
        driving force ‖∇E(0)‖₂ ``drive``. Returns the unknowns x (m/y) of the last prediction
        and its relative residual ‖∇E(x)‖₂ / drive."""
        count = node_counts(fine.dof, fine.n)
        for _ in range(max(self.train_steps, 1)):
            prediction = self.predict(features, fine.dof.shape[0], periodic)
            nodes = prediction.detach().double().numpy()
            x = unknowns_of(nodes[0], nodes[1], fine.dof, count)
            _, g = fine.evaluate(x)
            if self.train_steps:
                # ∇E / ‖∇E(0)‖: dimensionless, so that float32 holds Adam's squared gradients
                self.update(prediction, node_gradient(g / drive, fine.dof, count))
        return x, blatter._norm(g) / drive

    def solve(self, bed: np.ndarray, thickness: np.ndarray, grid: Grid,
              params: blatter.FlowParams | None = None, *, boundary: str = "open",
              background_slope: float = 0.0, initial: tuple[np.ndarray, np.ndarray] | None = None,
              rtol: float = 1e-3, max_iter: int = 5000, energy_rtol: float = 0.0) -> blatter.FlowSolution:
        """Velocities of the geometry (b, H) (arguments as ``blatter.solve``): predict and
        update the weights (``warm_start``), refine, and hand over to ``blatter.solve`` from the
        refined velocities when their residual is above ``rtol`` (module docstring). ``initial``
        (the previous step's velocities) is not used: the prediction is the warm start. The
        solution's ``iterations`` and ``evaluations`` count the refinement and the takeover."""
        from unerode_cli.glacier.blatter_energy import driving_force, expand

        self.last = None
        params = params or blatter.FlowParams()
        periodic, valid, b, h, c_node = blatter._checked_inputs(bed, thickness, grid, params, boundary)
        tilt = math.tan(background_slope)
        fine = blatter._level(b, h, c_node, valid, grid.dx, grid.dy, params, periodic, tilt)
        kwargs = {"boundary": boundary, "background_slope": background_slope}
        drive = 0.0 if fine.n == 0 else blatter._norm(driving_force(
            fine.dof, fine.args[1], grid.dx, grid.dy, tilt, params.rho * params.gravity, periodic, fine.n))
        if drive == 0.0:  # no ice, or no driving stress: nothing to predict
            return blatter.solve(bed, thickness, grid, params, **kwargs)
        features = network_input(b, h, c_node, grid.dx, grid.dy, tilt, periodic)
        x, predicted = self.warm_start(fine, features, drive, periodic)
        refined = blatter.solve(bed, thickness, grid, params, **kwargs, initial=expand(x, fine.dof),
                                rtol=rtol, max_iter=min(self.refine_iter, max_iter))
        solution, extra = refined, 0
        if not refined.converged and max_iter > refined.iterations:
            solution = blatter.solve(bed, thickness, grid, params, **kwargs, initial=(refined.u, refined.v),
                                     rtol=rtol, max_iter=max_iter - refined.iterations,
                                     energy_rtol=energy_rtol)
            extra = solution.iterations
            solution.iterations += refined.iterations
            solution.evaluations += refined.evaluations
        self.steps += 1
        self.takeovers += solution is not refined
        self.refine_iterations += refined.iterations
        self.takeover_iterations += extra
        self.last = CnnStep(predicted, refined.residual, refined.iterations, solution is not refined, extra,
                            refined)
        return solution

    def saved(self) -> dict[str, Any]:
        """The model as a checkpoint keeps it: ``cnn`` (a mapping of numbers: the seed, the
        settings, the counters, and the network's channels ``shape``, None before its first
        prediction) and, once the network exists, its parameters and Adam's state as NumPy
        arrays (``cnn_weight_K``, ``cnn_adam_avg_K``, ``cnn_adam_sq_K``: float32, the shapes of
        the K-th parameter; ``cnn_adam_step``: float32[K]), every bit kept; ``restore`` takes it
        back."""
        meta = {"seed": self.seed, "learning_rate": self.learning_rate, "refine_iter": self.refine_iter,
                "train_steps": self.train_steps, "shape": None if self.shape is None else list(self.shape),
                **{name: getattr(self, name) for name in _COUNTERS}}
        out: dict[str, Any] = {"cnn": meta}
        if self.network is None:
            return out
        state = self.optimizer.state
        steps = []
        for k, weight in enumerate(self.network.parameters()):
            out[f"cnn_weight_{k}"] = weight.detach().numpy().copy()
            moments = state.get(weight, {})
            zero = np.zeros(tuple(weight.shape), dtype=np.float32)
            out[f"cnn_adam_avg_{k}"] = moments["exp_avg"].numpy().copy() if moments else zero
            out[f"cnn_adam_sq_{k}"] = moments["exp_avg_sq"].numpy().copy() if moments else zero
            steps.append(float(moments["step"]) if moments else 0.0)
        out["cnn_adam_step"] = np.array(steps, dtype=np.float32)
        return out

    def restore(self, saved: dict[str, Any]) -> None:
        """Take back what ``saved`` gave (extra keys are ignored): the counters, and the network
        with its weights and Adam's state when it had been made. ValueError when the seed or the
        settings differ from this model's."""
        meta = saved["cnn"]
        mine = (self.seed, self.learning_rate, self.refine_iter, self.train_steps)
        theirs = (meta["seed"], meta["learning_rate"], meta["refine_iter"], meta["train_steps"])
        if tuple(theirs) != mine:
            raise ValueError(f"the checkpoint's CNN (seed, learning rate, refinement, training steps) "
                             f"{tuple(theirs)} is not this run's {mine}")
        for name in _COUNTERS:
            setattr(self, name, int(meta[name]))
        self.network = self.optimizer = self.shape = self.last = None
        if meta["shape"] is None:
            return
        torch = require_torch()
        channels_in, channels_out, periodic = meta["shape"]
        network = self._network(int(channels_in), int(channels_out), bool(periodic))
        weights = list(network.parameters())
        steps = np.asarray(saved["cnn_adam_step"], dtype=np.float32)
        with torch.no_grad():
            for k, weight in enumerate(weights):
                weight.copy_(torch.from_numpy(np.asarray(saved[f"cnn_weight_{k}"], dtype=np.float32)))
        moments = {k: {"step": torch.tensor(steps[k]),
                       "exp_avg": torch.from_numpy(np.array(saved[f"cnn_adam_avg_{k}"], dtype=np.float32)),
                       "exp_avg_sq": torch.from_numpy(np.array(saved[f"cnn_adam_sq_{k}"], dtype=np.float32))}
                   for k in range(len(weights)) if steps[k] > 0}
        fresh = self.optimizer.state_dict()
        self.optimizer.load_state_dict({"state": moments, "param_groups": fresh["param_groups"]})


def model_of(params: Any) -> CnnIceflow:
    """The ``CnnIceflow`` of the run of ``params`` (a ``coupled.CoupledParams``: its field
    ``cnn``); ValueError where it has none."""
    model = params.cnn
    if model is None:
        raise ValueError("iceflow cnn needs its network: CoupledParams(cnn=cnn_iceflow.CnnIceflow(seed))")
    return model
