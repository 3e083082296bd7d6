"""`unerode-cli climate-run`: (un)erode a DEM along a paleo-climate chronology (000 §5)."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from unerode_cli.cli import glaciate as glaciate_cli
from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import (
    BOUNDARY_PANEL,
    METRES,
    OUTPUT_PANEL,
    POSITIVE_YEARS,
    CheckpointEvery,
    Coast,
    Cog,
    CreationOptions,
    Dirichlet,
    Dtype,
    DtypeOpt,
    EdgeBase,
    InputDem,
    MaxSteps,
    Method,
    Outlets,
    OutputDem,
    Overwrite,
    Preview,
    Quiet,
    Resume,
    Verbose,
)
from unerode_cli.cli.parameter_options import with_parameter_options
from unerode_cli.cli.values import Number, Numbers
from unerode_cli.jobs.erode.options import INFLOW, PARAMETER_PANELS


class Scheme(str, Enum):
    limiter = "limiter"
    upwind = "upwind"


Inflow = Annotated[Path | None, typer.Option("--inflow", help=INFLOW.help, rich_help_panel=INFLOW.panel)]

if TYPE_CHECKING:
    from unerode_cli.jobs.climate_run import ClimateJob

AGE = Number("ka")
CHRONOLOGY_PANEL = "Chronology and sea level"
RUN_PANEL = "Time steps"
GLACIER_PANEL = "Glaciers (--process glacial)"
#: The processes' parameters, then the glacier model's (glaciate's panels; a parameter both
#: offer keeps its first panel, so that the glacier panels hold the glacier model's own).
PANELS = {**PARAMETER_PANELS,
          **{f"{title}, with --process glacial": specs for title, specs in glaciate_cli.PARAMETER_PANELS.items()}}
PROCESS_HELP = ("Processes applied in this order within each step: fluvial, thermal, thermal-ca, hillslope, "
                "debris; or glacial (forward only: glaciate's glacier model, 001 §3–6, its ELA from the "
                "chronology) with any of hillslope, debris, fluvial for the ground without ice, "
                "whose base level follows sea level.")


class Direction(str, Enum):
    backward = "backward"
    forward = "forward"


class ChronologyKind(str, Enum):
    d18o = "d18o"
    sea_level = "sea-level"


@with_parameter_options(PANELS)
def climate_run(
    source: InputDem,
    output: OutputDem,
    chronology: Annotated[Path, typer.Option("--chronology", help="Chronology table: an LR04-style δ18O stack (age ka, δ18O ‰), or a sea-level curve with --chronology-kind sea-level.", rich_help_panel=CHRONOLOGY_PANEL)],
    from_ka: Annotated[float, typer.Option("--from", parser=AGE, help="Age of the input DEM (ka; 0 = present).", rich_help_panel=CHRONOLOGY_PANEL)] = 0.0,
    to_ka: Annotated[float, typer.Option("--to", parser=AGE, help="Age to reach (ka): older than --from runs backward (unerosion), younger runs forward.", rich_help_panel=CHRONOLOGY_PANEL)] = 20.0,
    direction: Annotated[Direction | None, typer.Option(help="Checked against --from/--to (optional).", rich_help_panel=CHRONOLOGY_PANEL)] = None,
    chronology_kind: Annotated[ChronologyKind, typer.Option(help="What --chronology holds.", rich_help_panel=CHRONOLOGY_PANEL)] = ChronologyKind.d18o,
    sea_level: Annotated[Path | None, typer.Option("--sea-level", help="Sea-level table (age ka, m relative to present); default: sea level from δ18O by a linear mapping.", rich_help_panel=CHRONOLOGY_PANEL)] = None,
    d18o_to_sea: Annotated[Any, typer.Option(parser=Numbers("SLOPE,INTERCEPT: two numbers separated by a comma", 2), metavar="SLOPE,INTERCEPT", help="SLOPE,INTERCEPT of sea (m) = INTERCEPT + SLOPE × δ18O (‰) (default: fitted on LR04 vs Spratt & Lisiecki 2016).", rich_help_panel=CHRONOLOGY_PANEL)] = None,
    dt: Annotated[float, typer.Option("--dt", parser=POSITIVE_YEARS, help="Time step (years, > 0).", rich_help_panel=RUN_PANEL)] = 1000.0,
    process: Annotated[str, typer.Option(help=PROCESS_HELP, rich_help_panel=RUN_PANEL)] = "fluvial,thermal",
    snapshots: Annotated[Any, typer.Option(parser=Numbers("ages in ka separated by commas"), metavar="AGES", help="Ages (ka, comma-separated) at which to write OUTPUT_<age>ka snapshots.", rich_help_panel=OUTPUT_PANEL)] = None,
    params: Annotated[Path | None, typer.Option("--params", help="YAML schedule: per-phase parameter values (glacial, end-of-glacial, interglacial) and the downstream K_d range.", rich_help_panel=CHRONOLOGY_PANEL)] = None,
    downstream_below: Annotated[float | None, typer.Option(parser=METRES, help="Downstream region (K_d follows sea level, 000 §5.2): cells below this elevation (m) of the input.", rich_help_panel=BOUNDARY_PANEL)] = None,
    downstream_mask: Annotated[Path | None, typer.Option(help="Downstream region as a raster on the DEM's grid (non-zero cells).", rich_help_panel=BOUNDARY_PANEL)] = None,
    uplift_map: Annotated[Path | None, typer.Option(help="Uplift raster (m/y) on the DEM's grid, multiplied through time by the factor of --uplift TABLE.csv (columns age_ka,factor); --uplift also takes a table age_ka,U_m_per_y, linear in age, covering the run.", rich_help_panel=CHRONOLOGY_PANEL)] = None,
    outlets: Outlets = "all",
    dirichlet: Dirichlet = None,
    inflow: Inflow = None,
    sea_outlets: Annotated[bool, typer.Option("--sea-outlets/--no-sea-outlets", help="Cells at or below the current sea level are outlets, and boundary nodes at or below the sea level of --from follow sea level.", rich_help_panel=BOUNDARY_PANEL)] = True,
    coast: Coast = "none",
    edge_base: EdgeBase = None,
    inflow_from: Annotated[Path | None, typer.Option("--inflow-from", help="A coarse climate-run over a larger area, run with --write-fluxes (its output raster or its OUT_fluxes folder): the water and sediment crossing into this map, and the level of its edges, are read off it at each step (000 §6.3.1).", rich_help_panel=BOUNDARY_PANEL)] = None,
    write_fluxes: Annotated[bool, typer.Option("--write-fluxes", help="Also write OUT_fluxes/: elevation, discharge and sediment flux rasters (m, m³/y) at --from, each snapshot and --to, for runs nested in this one (--inflow-from).", rich_help_panel=OUTPUT_PANEL)] = False,
    checkpoint_every: CheckpointEvery = 10,
    resume: Resume = False,
    max_steps: MaxSteps = None,
    no_substep: Annotated[bool, typer.Option("--no-substep", help="Refuse an unstable --dt instead of sub-stepping it.", rich_help_panel=RUN_PANEL)] = False,
    scheme: Annotated[Scheme, typer.Option(help="Slope of backward steps: limiter (000 Eq. 12) or upwind (Eq. 10).", rich_help_panel=RUN_PANEL)] = Scheme.limiter,
    method: Annotated[Method, typer.Option(help="Flow routing: mfd or d8.", rich_help_panel=RUN_PANEL)] = Method.mfd,
    thermal_constraints: Annotated[str, typer.Option(help="Un-deposition constraints of thermal unerosion: slope, convexity, rate, or none.", rich_help_panel=RUN_PANEL)] = "slope,convexity,rate",
    ela_present: Annotated[float | None, typer.Option("--ela-present", parser=Number("m"), help="With --process glacial: today's ELA (m), the ELA at 0 ka; the ELA is linear in the chronology between it and --ela-glacial.", rich_help_panel=GLACIER_PANEL)] = None,
    ela_glacial: Annotated[float | None, typer.Option("--ela-glacial", parser=Number("m"), help="With --process glacial: the ELA at the last glacial maximum (m), where the chronology is most glacial between 14 and 30 ka.", rich_help_panel=GLACIER_PANEL)] = None,
    dtype: DtypeOpt = Dtype.float32,
    cog: Cog = False,
    co: CreationOptions = None,
    overwrite: Overwrite = False,
    preview: Preview = None,
    report: Annotated[bool, typer.Option("--report", help="Also write OUTPUT_report.html when the run finishes: previews at each snapshot, chronology and timeline plots, mass budget, parameters and history (see unerode-cli report).", rich_help_panel=OUTPUT_PANEL)] = False,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
    parameter_values: dict[str, str | None] | None = None,
) -> None:
    """Run the processes along a chronology: per-step sea level, climate phase and parameters
    (000 §5), with a coast that follows sea level. Writes the DEM at --to, snapshots
    (tagged with age, sea level and phase), OUTPUT_timeline.csv and OUTPUT_chronology.png. With
    --process glacial, glaciers grow and erode forward in time (glaciate's model, 001), their ELA
    and the sea level of the ground without ice both from the chronology."""
    with reported_errors(verbose - quiet):
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.cli.progress import progress_bar
        from unerode_cli.jobs.climate_run import ClimateJob, is_glacial, plan, run_climate

        job = ClimateJob(
            source=source, output=output, chronology=chronology, from_ka=from_ka, to_ka=to_ka,
            chronology_kind=chronology_kind.value, sea_level_file=sea_level,
            d18o_mapping=d18o_to_sea, direction=direction.value if direction else None,
            dt=dt, process=process, snapshots_ka=snapshots or (), schedule_file=params,
            downstream_below=downstream_below, downstream_mask=downstream_mask, uplift_map=uplift_map,
            outlets=outlets, dirichlet=dirichlet, sea_outlets=sea_outlets, coast=coast,
            edge_base=edge_base, inflow=inflow, inflow_from=inflow_from, write_fluxes=write_fluxes,
            checkpoint_every=checkpoint_every, resume=resume, max_steps=max_steps,
            allow_substeps=not no_substep, scheme=scheme.value, method=method.value,
            constraints=thermal_constraints, dtype=dtype.value, cog=cog, co=co,
            overwrite=overwrite, preview=preview, ela_present=ela_present, ela_glacial=ela_glacial,
            parameter_values=parameter_values or {},
        )
        report_job = _report_job(output, overwrite or resume) if report else None
        if is_glacial(process):
            _run_glacial(job, verbose - quiet)
            _write_report(report_job, output, verbose - quiet)
            return
        prepared = plan(job, on_note=lambda text: say(text, verbose - quiet))
        with progress_bar(prepared.steps, "climate-run", verbose - quiet) as advance:
            summary = run_climate(prepared, on_step=advance,
                                  on_note=lambda text: say(text, verbose - quiet))
        say(summary, verbose - quiet, SUMMARY)
        _write_report(report_job, output, verbose - quiet)


def _report_job(output: Path, overwrite: bool) -> Any:
    """The report of this run (``--report``), its output checked before the run."""
    from unerode_cli.jobs.report import ReportJob, plan_report, run_report_path

    job = ReportJob(output.parent, run_report_path(output), overwrite, run=output)
    plan_report(job)
    return job


def _write_report(job: Any, output: Path, verbosity: int) -> None:
    """Write the report of a finished run (one stopped by --max-steps leaves its checkpoint
    and has no report yet)."""
    from unerode_cli.cli.common import say
    from unerode_cli.io.checkpoints import checkpoint_path
    from unerode_cli.jobs.report import write_report

    if job is not None and not checkpoint_path(output).exists():
        say(write_report(job), verbosity)


def _run_glacial(job: ClimateJob, verbosity: int) -> None:
    """climate-run with glaciers: glaciate's job (001) from --from to --to along the chronology,
    with the sea level of ``plan_glacial`` as the base level of the ground without ice; writes
    OUTPUT, OUTPUT_timeline.csv and OUTPUT_chronology.png (and --preview)."""
    from unerode_cli.cli.common import SUMMARY, say
    from unerode_cli.cli.progress import simulated_time_bar
    from unerode_cli.jobs.climate_run import COMMAND, plan_glacial, timeline_path
    from unerode_cli.jobs.glaciate import GlacierJob, plan, run_job

    glacial = plan_glacial(job, on_note=lambda text: say(text, verbosity))
    prepared = plan(GlacierJob(
        source=job.source, output=job.output, dt=job.dt, allow_substeps=job.allow_substeps,
        hillslope=glacial.hillslope, debris=glacial.debris, fluvial=glacial.fluvial,
        timeline=timeline_path(job.output), ela_chronology=job.chronology, ela_kind=job.chronology_kind,
        ela_present=job.ela_present, ela_glacial=job.ela_glacial, from_ka=job.from_ka, to_ka=job.to_ka,
        dtype=job.dtype, cog=job.cog, co=job.co, overwrite=job.overwrite, preview=job.preview,
        checkpoint_every=job.checkpoint_every, resume=job.resume, max_steps=job.max_steps,
        parameter_values=glacial.parameter_values, sea_level=glacial.sea_level, command=COMMAND,
        context=glacial.context,
    ))
    with simulated_time_bar(float(prepared.times[-1]), COMMAND, verbosity) as advance:
        summary = run_job(prepared, on_step=advance, on_note=lambda text: say(text, verbosity))
    say(summary, verbosity, SUMMARY)
