"""`--iceflow cnn` against the converged Blatter–Pattyn solve of the same steps (001 §4).

State: a 256 × 256 crop (46 m cells) of the Grindelwald DEM (../shared/data/dem/alps_grindelwald,
rows 77–332, columns 88–343: the Wetterhorn–Schreckhorn basin and the valley below), ELA 2900 m,
grown by the converged solver (``SPINUP_RTOL``, default parameters, 10 lattice layers) for
``--spinup`` years in steps of ``--dt``. Then ``--steps`` coupled steps (``coupled.step``) with
``iceflow="cnn"`` (one ``CnnIceflow`` for the whole sequence, so the network learns along it);
at each step's geometry the converged solver (``blatter.solve`` to ``coupled.FLOW_RTOL``,
warm-started from the step before, as ``--iceflow blatter`` runs) solves the same velocities.

Per step: wall time of the CNN step (predict + train + refine + takeover) and of the converged
solve; the residual of the prediction and of the refinement; L-BFGS iterations (refinement,
takeover, converged solve); whether the converged solver took over; the relative L2 error of the
surface speed over the ice thicker than 1 m, of the refined velocities (before any takeover) and of
the step's result, against the converged solve; the refined energy's gap; and the SIA velocities
of the same geometry (``coupled.sia_flow``): their wall time and surface-speed error. Summary:
means, the takeover count.

Usage: ``NUMBA_NUM_THREADS=2 .venv/bin/python bench/glacier_cnn.py [--steps 20] [--size 256]
[--train-steps N] [--refine-iter K]``. PyTorch runs on numba's thread count.

Measured (NUMBA_NUM_THREADS=2 on 2 cores shared with other jobs, load 3.5–7; 14 of the 20 steps,
before the SIA columns were added): CNN step 158 s against the converged solve's 90 s (mean);
14 takeovers in 14 steps; L-BFGS iterations 2 + 87 against 51; the prediction's residual 2.8–5.0;
the refined velocities 37–43 % off the converged surface speed (energy 11–18 % above the
minimum); the steps' results within 0.002 % (docs/glaciate.md, section 8).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from unerode_cli.glacier import blatter, cnn_iceflow, coupled
from unerode_cli.grid import Grid
from unerode_cli.io.rasters import read_terrain

DEM = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "dem" / "alps_grindelwald" / "dem.tif"
ELA = 2900.0
SPINUP_RTOL = 1e-2
ICE_MIN_M = 1.0


def grindelwald(size: int) -> tuple[np.ndarray, Grid]:
    terrain = read_terrain(DEM)
    z = terrain.elevation.astype(np.float64)
    r0, c0 = z.shape[0] - size, z.shape[1] - size
    bed = z[r0:r0 + size, c0:c0 + size].copy()
    return bed, Grid.full(bed.shape, terrain.dx, terrain.dy)


def spin_up(bed: np.ndarray, grid: Grid, years: float, dt: float) -> coupled.GlacierState:
    params = coupled.CoupledParams(flow_rtol=SPINUP_RTOL)
    stepping = coupled.Stepping(coupled.GlacierState(bed, np.zeros_like(bed)), grid, params, ELA,
                                coupled.step_times(years, dt))
    while not stepping.finished:
        stepping.advance()
    return stepping.state


def speed_error(surface: tuple[np.ndarray, np.ndarray], reference: tuple[np.ndarray, np.ndarray],
                ice: np.ndarray) -> float:
    speed, ref = np.hypot(*surface)[ice], np.hypot(*reference)[ice]
    return float(np.linalg.norm(speed - ref) / max(np.linalg.norm(ref), 1e-300))


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--dt", type=float, default=20.0)
    parser.add_argument("--spinup", type=float, default=200.0)
    parser.add_argument("--train-steps", type=int, default=cnn_iceflow.TRAIN_STEPS)
    parser.add_argument("--refine-iter", type=int, default=cnn_iceflow.REFINE_ITER)
    args = parser.parse_args()
    bed, grid = grindelwald(args.size)
    tic = time.perf_counter()
    state = spin_up(bed, grid, args.spinup, args.dt)
    h = state.thickness
    volume = coupled.ice_volume(h, grid) / 1e9
    print(f"# Grindelwald {bed.shape} cells of {grid.dx:.0f} m, {blatter.FlowParams().n_layers} layers, "
          f"spin-up {args.spinup:g} y in {time.perf_counter() - tic:.0f} s: ice {volume:.3f} km³ on "
          f"{np.mean(h > ICE_MIN_M):.0%} of the cells, max {h.max():.0f} m", flush=True)
    model = cnn_iceflow.CnnIceflow(train_steps=args.train_steps, refine_iter=args.refine_iter)
    cnn_params = coupled.CoupledParams(iceflow="cnn", cnn=model)
    blatter_params = coupled.CoupledParams()
    rows = []
    for k in range(args.steps):
        tic = time.perf_counter()
        converged = coupled.flow_field(state.bed, state.thickness, grid, blatter_params, warm=state.lattice)
        t_blatter = time.perf_counter() - tic
        tic = time.perf_counter()
        shallow = coupled.sia_flow(state.bed, state.thickness, grid, blatter_params.flow)
        t_sia = time.perf_counter() - tic
        new, report = coupled.step(state, grid, cnn_params, ELA, args.dt)
        last, ice = model.last, state.thickness > ICE_MIN_M
        row = {"cnn_s": report.flow_seconds, "blatter_s": t_blatter, "pred_res": last.predicted_residual,
               "refined_res": last.refined_residual, "refine_it": last.refine_iterations,
               "takeover": last.takeover, "takeover_it": last.takeover_iterations,
               "blatter_it": converged.iterations,
               "refined_err": speed_error(last.refined.surface_velocity(), converged.surface, ice),
               "result_err": speed_error(report.flow.surface, converged.surface, ice),
               "energy_gap": (last.refined.energy - converged.energy) / abs(converged.energy),
               "sia_s": t_sia, "sia_err": speed_error(shallow.surface, converged.surface, ice)}
        rows.append(row)
        print(f"step {k + 1:2d}: cnn {row['cnn_s']:6.1f} s (prediction res {row['pred_res']:.2g}, refined "
              f"{row['refined_res']:.2g} in {row['refine_it']} it, takeover {row['takeover']!s:5s} "
              f"+{row['takeover_it']} it) | blatter {t_blatter:6.1f} s {row['blatter_it']} it | surface "
              f"speed error refined {row['refined_err']:.2%} result {row['result_err']:.3%}, energy gap "
              f"{row['energy_gap']:.2%} | sia {t_sia:.2f} s, error {row['sia_err']:.0%}", flush=True)
        state = new
    mean = {key: float(np.mean([r[key] for r in rows])) for key in rows[0]}
    print(f"\n# {args.steps} steps of {args.dt:g} y: CNN step {mean['cnn_s']:.1f} s against the "
          f"converged solve {mean['blatter_s']:.1f} s (mean); takeovers {model.takeovers}/{model.steps}; "
          f"L-BFGS iterations a step: refinement {mean['refine_it']:.1f} + takeover "
          f"{mean['takeover_it']:.1f} against {mean['blatter_it']:.1f}; surface-speed error of the refined "
          f"velocities {mean['refined_err']:.2%} (last {rows[-1]['refined_err']:.2%}), of the results "
          f"{mean['result_err']:.3%}; energy gap of the refined {mean['energy_gap']:.2%} (last "
          f"{rows[-1]['energy_gap']:.2%}); SIA {mean['sia_s']:.2f} s, surface-speed error "
          f"{mean['sia_err']:.0%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
