"""001 Fig. 11 (left) on a valley glacier, with the converged Blatter–Pattyn solver and with
``--iceflow cnn``: the ice volume under a cooling climate for time steps of 10 and 20 y against
a 5-year reference (001: "time steps of 10 or 20 years show errors below 1%").

Valley: the synthetic V valley of ``glacier_u_valley.py`` (30° walls 565 m high, floor graded
at 0.1 from 2000 m with a 300 m headwall) on ``--shape`` cells of ``--dx`` m (default 20 × 64 of
100 m: the same 2 × 6.4 km valley as that bench's 40 × 128 of 50 m, at half its resolution),
open edges. Start: the glacier grown from no ice under a constant ELA ``ela_start`` (2100 m) for
``spinup_years`` (600 y) in steps of 20 y by the converged solver, the same start for every run.
Then, without erosion, the ELA falls linearly to ``ela_end`` (1900 m) over ``cooling_years``
(600 y) and holds there to ``years`` (800 y): a cooling climate, then a steadying glacier, as in
001 Fig. 11 (ELA 1600 → 900 m over 70 ky, then 30 ky steady), shortened to the response time of
a 6-km valley glacier. Each solver (``blatter``, and ``cnn``: a new network of seed ``--seed``
per run, trained on the fly along it, its misses of the residual 1e-3 finished by the converged
solver) runs the climate with each of ``DTS`` (5, 10, 20 y).

Measure: the ice volume V (m³, ``coupled.ice_volume``) every ``SAMPLE_EVERY`` (50 y; every run
ends a step there), and the relative error (V_dt − V_5)/V_5 of each run against the 5-year run
of the same solver: the largest |error| over the samples and the error at the end. Also the
CNN's volume against the converged solver's at the same dt, the solves in which the network
predicted and the takeovers among them, and each run's wall time.

Usage: ``NUMBA_NUM_THREADS=1 .venv/bin/python bench/glacier_fig11_cnn.py [--iceflow blatter cnn]
[--dts 5 10 20] [--spinup 600] [--cooling 600] [--years 800] [--ela-end 1900] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import glacier_u_valley as uv  # noqa: E402
from unerode_cli.glacier import coupled  # noqa: E402
from unerode_cli.grid import Grid  # noqa: E402
from unerode_cli.hydro.outlets import outlet_mask  # noqa: E402

#: Time steps (y); the first is the reference.
DTS = (5.0, 10.0, 20.0)
#: Interval of the volume samples (y).
SAMPLE_EVERY = 50.0


@dataclass(frozen=True)
class Case:
    """The valley, its start and its climate (metres, years)."""

    valley: uv.Valley = field(default_factory=lambda: uv.Valley(ny=20, nx=64, dx=100.0))
    ela_start: float = 2100.0
    ela_end: float = 1900.0
    spinup_years: float = 600.0
    spinup_dt: float = 20.0
    cooling_years: float = 600.0
    years: float = 800.0
    seed: int = 0


def params(grid: Grid, iceflow: str, seed: int = 0) -> coupled.CoupledParams:
    """Open edges, no erosion; ``iceflow="cnn"`` with a new network of ``seed``."""
    cnn = None
    if iceflow == "cnn":
        from unerode_cli.glacier import cnn_iceflow

        cnn = cnn_iceflow.CnnIceflow(seed=seed)
    return coupled.CoupledParams(iceflow=iceflow, erosion=False, edge_cells=outlet_mask(grid, "all"), cnn=cnn)


def spin_up(case: Case) -> tuple[coupled.GlacierState, Grid]:
    """The start of every run: the glacier grown from no ice by the converged solver."""
    bed = case.valley.bed()
    grid = Grid.full(bed.shape, case.valley.dx)
    result = coupled.run(coupled.GlacierState(bed, np.zeros_like(bed)), grid, params(grid, "blatter"),
                         case.ela_start, coupled.step_times(case.spinup_years, case.spinup_dt))
    return result.state, grid


def run_dt(case: Case, start: coupled.GlacierState, grid: Grid, iceflow: str, dt: float) -> dict:
    """One run of the cooling climate with steps of ``dt`` (y): the volumes (m³) at the sample
    times (y since the start of the cooling), the CNN's counts and the wall time (s)."""
    t0 = start.time
    ela = coupled.ElaTable(np.array([t0, t0 + case.cooling_years]), np.array([case.ela_start, case.ela_end]))
    samples = np.arange(SAMPLE_EVERY, case.years + 0.5 * SAMPLE_EVERY, SAMPLE_EVERY)
    started = time.perf_counter()
    result = coupled.run(start, grid, params(grid, iceflow, case.seed), ela,
                         t0 + coupled.step_times(case.years, dt, samples))
    seconds = time.perf_counter() - started
    by_time = {round(t - t0, 6): v for t, v in zip(result.times, result.volumes, strict=True)}
    return {"iceflow": iceflow, "dt": dt, "times": samples.tolist(),
            "volumes": [by_time[round(float(s), 6)] for s in samples], "steps": result.steps,
            "unconverged": result.unconverged, "cnn_solves": result.cnn_solves,
            "cnn_takeovers": result.cnn_takeovers, "seconds": seconds}


def relative_errors(run: dict, reference: dict) -> np.ndarray:
    """(V_run − V_ref)/V_ref at the sample times."""
    v, ref = np.array(run["volumes"]), np.array(reference["volumes"])
    return (v - ref) / ref


def experiment(case: Case, iceflows: tuple[str, ...] = ("blatter", "cnn"), dts: tuple[float, ...] = DTS,
               verbose: bool = True) -> dict:
    """Every (solver, dt) run from the shared start; per run its errors against the first dt of
    its solver (``error_max``: largest |error|, ``error_end``) and, for ``cnn``, against
    ``blatter`` at the same dt (``vs_blatter_max``)."""
    started = time.perf_counter()
    start, grid = spin_up(case)
    out: dict = {"start_volume_m3": coupled.ice_volume(start.thickness, grid),
                 "spinup_seconds": time.perf_counter() - started, "runs": []}
    for iceflow in iceflows:
        for dt in dts:
            row = run_dt(case, start, grid, iceflow, dt)
            out["runs"].append(row)
            if verbose:
                print(f"  {iceflow} dt {dt:g} y: V_end {row['volumes'][-1] / 1e9:.5f} km³, "
                      f"{row['steps']} steps, "
                      f"CNN taken over in {row['cnn_takeovers']} of {row['cnn_solves']} solves, "
                      f"{row['seconds']:.0f} s", flush=True)
    runs = {(r["iceflow"], r["dt"]): r for r in out["runs"]}
    for row in out["runs"]:
        errors = relative_errors(row, runs[(row["iceflow"], dts[0])])
        row["error_max"], row["error_end"] = float(np.max(np.abs(errors))), float(errors[-1])
        if row["iceflow"] == "cnn" and ("blatter", row["dt"]) in runs:
            row["vs_blatter_max"] = float(np.max(np.abs(relative_errors(row, runs[("blatter", row["dt"])]))))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--iceflow", nargs="+", default=["blatter", "cnn"], choices=("blatter", "cnn", "sia"))
    ap.add_argument("--dts", type=float, nargs="+", default=list(DTS))
    ap.add_argument("--shape", type=int, nargs=2, default=(Case().valley.ny, Case().valley.nx))
    ap.add_argument("--dx", type=float, default=Case().valley.dx)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--spinup", type=float, default=Case.spinup_years)
    ap.add_argument("--cooling", type=float, default=Case.cooling_years)
    ap.add_argument("--years", type=float, default=Case.years)
    ap.add_argument("--ela-end", type=float, default=Case.ela_end)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    case = Case(valley=uv.Valley(ny=args.shape[0], nx=args.shape[1], dx=args.dx), seed=args.seed,
                spinup_years=args.spinup, cooling_years=args.cooling, years=args.years, ela_end=args.ela_end)
    out = experiment(case, tuple(args.iceflow), tuple(args.dts))
    print(f"start: {out['start_volume_m3'] / 1e9:.4f} km³ ({out['spinup_seconds']:.0f} s)")
    print("| solver | dt (y) | V end (km³) | max |V − V_5|/V_5 | at the end | CNN takeovers | wall (s) |")
    for r in out["runs"]:
        print(f"| {r['iceflow']} | {r['dt']:g} | {r['volumes'][-1] / 1e9:.5f} | {100 * r['error_max']:.2f} % "
              f"| {100 * r['error_end']:+.2f} % | {r['cnn_takeovers']}/{r['cnn_solves']} "
              f"| {r['seconds']:.0f} |")
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
