"""The `climate-run` job: (un)erode a DEM step by step along a paleo-climate chronology (000 §5,
DESIGN §7), with boundary nodes that follow their base level (the sea for the coast, else
fixed, uplifted or from a table), snapshots at asked ages, a timeline, checkpoints and resume.

Ages are in ka at the edges (options, files, tags) and converted to years inside. With
``glacial`` in ``--process`` the run is the coupled glacier model (001 §3–6) instead, forward
only, with the ELA and the sea level from the same chronology (``glacial``).

Modules: ``options`` (declarations), ``forcing`` (steps, sea level, phases), ``plan``, ``steps``
and ``outputs`` (the runner's processes), ``glacial`` (the glacier model).
"""

from __future__ import annotations

from typing import Any

from unerode_cli.io.paths import OutputPlan
from unerode_cli.jobs.climate_run.forcing import report_path
from unerode_cli.jobs.climate_run.glacial import is_glacial, plan_glacial
from unerode_cli.jobs.climate_run.options import OPTIONS
from unerode_cli.jobs.climate_run.outputs import write_climate
from unerode_cli.jobs.climate_run.plan import PreparedClimateRun, plan
from unerode_cli.jobs.climate_run.steps import ClimateResult, run_steps
from unerode_cli.run.boundaries import COARSE
from unerode_cli.run.declare import declared
from unerode_cli.run.glacial.outputs import write_glacier
from unerode_cli.run.glacial.plan import PreparedGlacierRun
from unerode_cli.run.glacial.steps import GlacierOutcome, run_glacier
from unerode_cli.run.job import Job, Progress


@declared("climate-run", OPTIONS)
class ClimateJob(Job):
    """A run along a chronology from ``--from`` to ``--to`` (ka), by ``--dt`` years."""

    @property
    def backward(self) -> bool:
        return self.to_ka > self.from_ka

    @property
    def replaces(self) -> bool:
        """Whether existing outputs may be replaced: --overwrite, or --resume (the outputs of the
        run being continued)."""
        return self.overwrite or self.resume

    @property
    def snapshot_ages(self) -> tuple[float, ...]:
        """The ages (ka) of ``--snapshots``."""
        return tuple(self.snapshots_ka or ())

    @property
    def edge_base_choice(self) -> str:
        """``--edge-base``, by default "coarse" for a nested run (``--inflow-from``), else "fixed"."""
        if self.edge_base is not None:
            return self.edge_base
        return COARSE if self.inflow_from is not None else "fixed"

    def kept_ages(self) -> list[float]:
        """Ages (ka) of the nesting rasters of ``--write-fluxes``: the start, the snapshots and
        the end."""
        return sorted({self.from_ka, *self.snapshot_ages, self.to_ka})

    def plan(self, outputs: OutputPlan) -> tuple[list[str], Any]:
        """The plan of the run (of the glacier model with ``glacial`` in ``--process``) and the
        notes it gave (rows of the chronology left out or sorted, a long glacier step), said
        when the run starts. The report of ``--report`` (written after the job by its front
        door, ``report_path``) is cleared here, before any work."""
        notes = _Notes()
        if self.report:
            outputs.check_output(report_path(self.output), self.replaces)
        if is_glacial(self.process):
            return notes.said, plan_glacial(self, outputs, notes)
        return notes.said, plan(self, outputs, notes)

    def run(self, planned: tuple[list[str], Any], progress: Progress) -> tuple[Any, Any]:
        notes, prepared = planned
        for text in notes:
            progress.note(text)
        if isinstance(prepared, PreparedGlacierRun):
            return prepared, run_glacier(prepared, progress)
        return prepared, run_steps(prepared, progress)

    def write(self, result: tuple[Any, Any], outputs: OutputPlan) -> str:
        prepared, outcome = result
        if isinstance(outcome, GlacierOutcome):
            return write_glacier(prepared, outcome)
        assert isinstance(prepared, PreparedClimateRun) and isinstance(outcome, ClimateResult)
        return write_climate(prepared, outcome)


class _Notes(Progress):
    """The notes of a plan, kept to be said when the run starts (``Job.plan`` has no progress)."""

    def __init__(self) -> None:
        super().__init__()
        self.said: list[str] = []

    def note(self, text: str) -> None:
        self.said.append(text)
