"""`unerode-cli climate-run`: (un)erode a DEM along a paleo-climate chronology (000 §5)."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import typer

from unerode_cli.cli.erode import PARAMETER_PANELS, Inflow, Scheme
from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import (
    BOUNDARY_PANEL,
    METRES,
    OUTPUT_PANEL,
    POSITIVE_YEARS,
    Coast,
    Cog,
    CreationOptions,
    Dirichlet,
    Dtype,
    DtypeOpt,
    EdgeBase,
    InputDem,
    Method,
    Outlets,
    OutputDem,
    Overwrite,
    Preview,
    Quiet,
    Verbose,
)
from unerode_cli.cli.parameter_options import with_parameter_options
from unerode_cli.cli.values import Number, Numbers

AGE = Number("ka")
CHRONOLOGY_PANEL = "Chronology and sea level"
RUN_PANEL = "Time steps"


class Direction(str, Enum):
    backward = "backward"
    forward = "forward"


class ChronologyKind(str, Enum):
    d18o = "d18o"
    sea_level = "sea-level"


@with_parameter_options(PARAMETER_PANELS)
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
    process: Annotated[str, typer.Option(help="Processes applied in this order within each step.", rich_help_panel=RUN_PANEL)] = "fluvial,thermal",
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
    checkpoint_every: Annotated[int, typer.Option(min=1, help="Write a checkpoint every this many steps.", rich_help_panel=RUN_PANEL)] = 10,
    resume: Annotated[bool, typer.Option("--resume", help="Continue an interrupted run from its checkpoint (same inputs and options).", rich_help_panel=RUN_PANEL)] = False,
    max_steps: Annotated[int | None, typer.Option(min=1, help="Stop after this many steps of this invocation (checkpointed; continue with --resume).", rich_help_panel=RUN_PANEL)] = None,
    no_substep: Annotated[bool, typer.Option("--no-substep", help="Refuse an unstable --dt instead of sub-stepping it.", rich_help_panel=RUN_PANEL)] = False,
    scheme: Annotated[Scheme, typer.Option(help="Slope of backward steps: limiter (000 Eq. 12) or upwind (Eq. 10).", rich_help_panel=RUN_PANEL)] = Scheme.limiter,
    method: Annotated[Method, typer.Option(help="Flow routing: mfd or d8.", rich_help_panel=RUN_PANEL)] = Method.mfd,
    thermal_constraints: Annotated[str, typer.Option(help="Un-deposition constraints of thermal unerosion: slope, convexity, rate, or none.", rich_help_panel=RUN_PANEL)] = "slope,convexity,rate",
    dtype: DtypeOpt = Dtype.float32,
    cog: Cog = False,
    co: CreationOptions = None,
    overwrite: Overwrite = False,
    preview: Preview = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
    parameter_values: dict[str, str | None] | None = None,
) -> None:
    """Run the processes along a chronology: per-step sea level, climate phase and parameters
    (000 §5), with a coast that follows sea level. Writes the DEM at --to, snapshots
    (tagged with age, sea level and phase), OUTPUT_timeline.csv and OUTPUT_chronology.png."""
    with reported_errors(verbose - quiet):
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.cli.progress import progress_bar
        from unerode_cli.jobs.climate_run import ClimateJob, plan, run_climate

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
            overwrite=overwrite, preview=preview, parameter_values=parameter_values or {},
        )
        prepared = plan(job, on_note=lambda text: say(text, verbose - quiet))
        with progress_bar(prepared.steps, "climate-run", verbose - quiet) as advance:
            summary = run_climate(prepared, on_step=advance,
                                  on_note=lambda text: say(text, verbose - quiet))
        say(summary, verbose - quiet, SUMMARY)
