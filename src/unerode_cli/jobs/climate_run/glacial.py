"""climate-run with glaciers (``--process glacial[,hillslope,debris,fluvial]``): the coupled
glacier model (001 §3–6, ``run.glacial``, as glaciate runs it) forward from ``--from`` to
``--to``, its ELA from the chronology (linear in the proxy between ``--ela-present`` and
``--ela-glacial``) and the sea level of the same chronology as the base level of the ground
without ice (one chronology, both forcings). Writes OUTPUT, OUTPUT_timeline.csv and
OUTPUT_chronology.png (and ``--preview``).
"""

from __future__ import annotations

from dataclasses import asdict
from typing import TYPE_CHECKING

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.glacier import cycle
from unerode_cli.glacier.cnn_iceflow import DEFAULT_SEED
from unerode_cli.io.paths import OutputPlan
from unerode_cli.jobs.climate_run.forcing import read_sea_level, step_count, timeline_path
from unerode_cli.jobs.climate_run.options import OPTIONS
from unerode_cli.jobs.climate_run.plan import GLACIER_ONLY_PARAMETERS, flag, is_table
from unerode_cli.processes.parameters import UPLIFT
from unerode_cli.run.glacial.options import GlacierRun
from unerode_cli.run.glacial.plan import PreparedGlacierRun, plan_glacier
from unerode_cli.run.job import Progress
from unerode_cli.run.registry import GLACIAL

if TYPE_CHECKING:
    from unerode_cli.jobs.climate_run.job import ClimateJob

#: Glacier steps (y) longer than this get a note (001 §5: 10–100 y).
GLACIER_DT_NOTE = 100.0
#: What ``--process`` may list with ``glacial``: glaciate's processes of ice-free ground (001 §6).
GLACIAL_PROCESSES = (GLACIAL, "hillslope", "debris", "fluvial")
#: Every parameter a run with glaciers takes: the glacier model's, the ice-free processes' and
#: the uplift.
GLACIAL_PARAMETERS = frozenset(spec.name for spec in (*GLACIER_ONLY_PARAMETERS, *cycle.PARAMETERS))
#: climate-run's options that mean nothing to the glacier model: option → (field, why), refused
#: when given (``_check_glacial_options``).
_NOT_GLACIAL = {
    "--params": ("schedule_file", "the glacier model has no schedule of parameters by climate phase"),
    "--downstream-below": ("downstream_below", "its rivers erode and do not deposit"),
    "--downstream-mask": ("downstream_mask", "its rivers erode and do not deposit"),
    "--uplift-map": ("uplift_map", "its uplift is a number or a raster, not a table through time"),
    "--dirichlet": ("dirichlet", "its base level is the map's edges and the sea"),
    "--coast": ("coast", "its base level is the map's edges and the sea"),
    "--edge-base": ("edge_base", "its base level is the map's edges and the sea"),
    "--outlets": ("outlets", "its base level is all the map's edges and the sea"),
    "--inflow": ("inflow", "rivers entering the map feed the fluvial model of 000 only"),
    "--inflow-from": ("inflow_from", "rivers entering the map feed the fluvial model of 000 only"),
    "--write-fluxes": ("write_fluxes", "the nesting rasters come from the fluvial model of 000 only"),
    "--scheme": ("scheme", "it sets the slope of backward steps, and glaciers run forward only"),
    "--thermal-constraints": ("thermal_constraints", "thermal erosion does not run with glaciers"),
    "--method": ("method", "the rivers of ice-free ground follow steepest descent (D8)"),
    "--snapshots": ("snapshots_ka", "the glacier run writes the bed at --to and one timeline row per step"),
}


def is_glacial(process: str) -> bool:
    """Whether ``--process`` lists the glacier model (``glacial``)."""
    return GLACIAL in (name.strip().lower() for name in process.split(","))


def plan_glacial(job: ClimateJob, outputs: OutputPlan, progress: Progress) -> PreparedGlacierRun:
    """Check a climate-run with glaciers before any work, read the sea level along it, and plan
    the glacier run (``run.glacial.plan``: the ELA's chronology, outputs, parameter values)."""
    names = _glacial_names(job.process)
    if job.backward:
        raise InputError("glaciers run forward in time only, so --to must be younger than --from: ice "
                         "flow and glacial erosion cannot be reversed, and the ice that once covered "
                         "the DEM is not known to start from.")
    if job.ela_present is None or job.ela_glacial is None:
        raise InputError("--process glacial needs --ela-present and --ela-glacial (today's ELA and the "
                         "ELA at the last glacial maximum, m) to turn the chronology into the ELA.")
    _check_glacial_options(job)
    if job.dt > GLACIER_DT_NOTE:
        progress.note(f"note: --dt {job.dt:g} y is long for glaciers: 001 §5 steps them 10–100 y (its Fig. "
                      "11: the ice volume within 1 % at 10–20 y, about 10 % at 100 y).")
    values = _glacial_values(job)
    step_count(job)
    if job.sea_level_file is not None:
        outputs.read(job.sea_level_file)
    _, sea = read_sea_level(job, progress.note)
    try:
        sea.at(np.array([job.from_ka, job.to_ka]))  # the table covers the run
    except ValueError as exc:
        raise InputError(f"{str(exc).rstrip('.')}.") from None
    mapping = None if sea.d18o is None else asdict(sea.mapping)
    context = {"process": job.process, "chronology_kind": job.chronology_kind,
               "sea_level_file": job.sea_level_file, "d18o_to_sea": mapping, "sea_outlets": job.sea_outlets}
    run = GlacierRun(
        source=job.source, output=job.output, dt=job.dt, no_substep=job.no_substep,
        no_hillslope="hillslope" not in names, no_debris="debris" not in names,
        no_fluvial="fluvial" not in names,
        timeline=timeline_path(job.output), ela_chronology=job.chronology, ela_kind=job.chronology_kind,
        ela_present=job.ela_present, ela_glacial=job.ela_glacial, from_ka=job.from_ka, to_ka=job.to_ka,
        dtype=job.dtype, cog=job.cog, co=job.co, overwrite=job.overwrite, preview=job.preview,
        force=job.force, checkpoint_every=job.checkpoint_every, resume=job.resume, max_steps=job.max_steps,
        iceflow=job.iceflow or "blatter", seed=DEFAULT_SEED if job.seed is None else job.seed, **values)
    sea_level = sea.since(job.from_ka) if job.sea_outlets else None
    return plan_glacier(run, outputs, sea_level, job.COMMAND, context)


def _glacial_names(process: str) -> list[str]:
    """The names of ``--process`` with ``glacial``, each one of ``GLACIAL_PROCESSES``, once."""
    names = [name.strip().lower() for name in process.split(",") if name.strip()]
    for name in names:
        if name.startswith("thermal"):
            raise InputError(f"{name} cannot run with glacial: the glacier model couples only hillslope, "
                             "debris and fluvial (001 §6), and its debris flow takes the place of thermal "
                             "erosion on slopes steeper than the critical angle.")
        if name not in GLACIAL_PROCESSES:
            raise InputError(f"unknown process '{name}'; with glacial choose among "
                             f"{', '.join(GLACIAL_PROCESSES[1:])}.")
    if len(set(names)) != len(names):
        raise InputError(f"--process names a process twice: {process}.")
    return names


def _check_glacial_options(job: ClimateJob) -> None:
    """Refuse the options of ``_NOT_GLACIAL`` that differ from their default: given, or for the
    few with a default value (e.g. ``--outlets all``), given another value."""
    defaults = {opt.name: opt.default for opt in OPTIONS}
    for option, (name, why) in _NOT_GLACIAL.items():
        if getattr(job, name) != defaults[name]:
            raise InputError(f"{option} does not apply with --process glacial ({why}); drop it.")


def _glacial_values(job: ClimateJob) -> dict[str, str]:
    """The given parameter values (name → text), each one of the glacier model's
    (``GLACIAL_PARAMETERS``); the uplift a number or a raster."""
    given = {name: text for name, text in job.parameter_values().items() if text is not None}
    for name in given:
        if name not in GLACIAL_PARAMETERS:
            raise InputError(f"{flag(name)} does not apply with --process glacial, whose rivers erode by "
                             "k_f·A^m·S^n (--k-f, 001 §6.3) and whose other parameters are the mass "
                             "balance, glacial erosion, hillslope, debris-flow and uplift ones; drop it.")
    if is_table(given.get(UPLIFT.name)):
        raise InputError("--uplift with --process glacial is a number (m/y) or a raster, not a table "
                         "through time.")
    return given
