"""The `glaciate` job (001 §3–6): plan (check everything, read inputs), then run the coupled
glacier model (``run.glacial``: time steps with checkpoints and resume) or solve the velocity of
a given geometry once (``--diagnostic``), and write.

The diagnostic solve takes the DEM as the bed and ``--ice-thickness`` as the ice, iterates the
velocity to a relative residual of ``DIAGNOSTIC_RTOL`` (1e-5) and writes ``--velocity`` (two
bands vx, vy, m/y), ``--sliding`` (m/y) and OUT (the bed unchanged, with the solver's statistics
in its sidecar).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

from unerode_cli.glacier import coupled
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.rasters import read_header
from unerode_cli.jobs.glaciate.options import OPTIONS
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.glacial.options import GlacierRun
from unerode_cli.run.glacial.outputs import flow_statistics, run_seed, write_flow, write_glacier
from unerode_cli.run.glacial.plan import (
    DIAGNOSTIC_MAX_ITER,
    DIAGNOSTIC_RTOL,
    PreparedGlacierRun,
    duration,
    plan_glacier,
)
from unerode_cli.run.glacial.steps import GlacierOutcome, run_glacier
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.memory import check_fits
from unerode_cli.run.outputs import Outputs, save
from unerode_cli.run.stepping import check_step_count

#: Peak bytes per cell and lattice level of the Blatter–Pattyn solve (001 §4.2): the levels'
#: elevations, the two velocity components, their gradients and the solver's work vectors
#: (about 15 float64 arrays of (layers + 1) × rows × columns).
BLATTER_BYTES_PER_LEVEL_CELL = 120


@declared("glaciate", OPTIONS)
class GlacierJob(GlacierRun, Job):
    """Grow glaciers on a DEM and erode its bed, or solve the velocity of a geometry once."""

    def plan(self, outputs: OutputPlan) -> PreparedGlacierRun:
        check_sizes(self)
        return plan_glacier(self, outputs)

    def run(self, planned: PreparedGlacierRun, progress: Progress) -> tuple[PreparedGlacierRun, Any]:
        if self.diagnostic:
            return planned, solve_diagnostic(planned)
        return planned, run_glacier(planned, progress)

    def write(self, result: tuple[PreparedGlacierRun, Any], outputs: OutputPlan) -> str:
        prepared, outcome = result
        if isinstance(outcome, Diagnostic):
            return write_diagnostic(prepared, outcome)
        assert isinstance(outcome, GlacierOutcome)
        return write_glacier(prepared, outcome)


def check_sizes(run: GlacierJob) -> None:
    """Refuse (InputError), before anything is allocated, a run of more time steps or snapshots
    than ``stepping.MAX_STEPS`` and a Blatter–Pattyn lattice of ``--layers`` that does not fit in
    memory. Values out of their ranges are left to ``plan_glacier``'s checks."""
    span = duration(run)
    if not run.diagnostic and span is not None and math.isfinite(span) and span > 0:
        if math.isfinite(run.dt) and run.dt > 0:
            check_step_count(span / run.dt, f"a run of {span:g} y in steps of --dt {run.dt:g} y")
        every = run.snapshot_every
        if every is not None and math.isfinite(every) and every > 0:
            check_step_count(span / every, f"--snapshot-every {every:g} y over {span:g} y",
                             "give a larger --snapshot-every")
    if run.iceflow == "blatter" and run.layers >= 1:
        header = read_header(run.source, band=run.band, georef=input_georef(run))
        levels = float(run.layers) + 1.0
        check_fits(levels * header.cells * BLATTER_BYTES_PER_LEVEL_CELL,
                   f"the ice-flow lattice of --layers {run.layers:,} on {header.size_text()}",
                   "give fewer --layers (the default is 10)")


@dataclass
class Diagnostic:
    """The velocity of the given geometry (``coupled.FlowField``) and the solve's wall time (s)."""

    flow: coupled.FlowField
    wall: float


def solve_diagnostic(prepared: PreparedGlacierRun) -> Diagnostic:
    """Solve the velocity of the DEM (bed) + ``--ice-thickness`` once."""
    terrain = prepared.terrain
    start = time.perf_counter()
    bed = coupled.fill_outside(terrain.elevation, terrain.grid.valid)
    flow = coupled.flow_field(bed, prepared.thickness, terrain.grid, prepared.params, rtol=DIAGNOSTIC_RTOL,
                              max_iter=DIAGNOSTIC_MAX_ITER, energy_rtol=0.0)
    return Diagnostic(flow, time.perf_counter() - start)


def write_diagnostic(prepared: PreparedGlacierRun, diagnostic: Diagnostic) -> str:
    """Write the asked outputs of a diagnostic solve; the one-line summary."""
    run, terrain, flow = prepared.run, prepared.terrain, diagnostic.flow
    stats = {"flow": flow_statistics(flow), "wall_time_s": diagnostic.wall}
    if run.output is not None:
        save(terrain.with_elevation(terrain.elevation), Outputs(run.output, prepared.write, run.overwrite,
                                                                run.preview),
             prepared.command, prepared.parameters, stats, run_seed(prepared))
    write_flow(prepared, flow, stats)
    state = "converged" if flow.converged else "NOT converged"
    written = ", ".join(str(p) for p in (run.velocity, run.sliding, run.output) if p is not None)
    return (f"{prepared.command} --diagnostic: velocity solved with {run.iceflow} ({state}, residual "
            f"{flow.residual:.3g}, {flow.iterations} iterations); max surface speed "
            f"{stats['flow']['max_surface_speed_m_per_y']:.4g} m/y; wrote {written}")
