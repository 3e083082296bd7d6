"""`unerode-cli erode` and `unerode-cli unerode`: run surface processes forward or backward."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import (
    BOUNDARY_PANEL,
    POSITIVE_YEARS,
    Band,
    Channel,
    Cog,
    CreationOptions,
    Dirichlet,
    Dtype,
    DtypeOpt,
    InputDem,
    Method,
    Outlets,
    OutputDem,
    Overwrite,
    Preview,
    Quiet,
    SeaLevel,
    Verbose,
)
from unerode_cli.cli.parameter_options import with_parameter_options
from unerode_cli.processes import debris, fluvial, hillslope, thermal


class Scheme(str, Enum):
    limiter = "limiter"
    upwind = "upwind"


PARAMETER_PANELS = {
    "Fluvial parameters (000 §3)": fluvial.PARAMETERS,
    "Thermal parameters (000 §4; thermal and thermal-ca)": thermal.PARAMETERS,
    "Hillslope parameters (001 §6.4)": hillslope.PARAMETERS,
    "Debris-flow parameters (001 Eq. 8)": debris.PARAMETERS,
}
Inflow = Annotated[Path | None, typer.Option("--inflow", help="CSV of rivers entering the map, columns x,y,discharge_m3_per_y,sediment_m3_per_y (DEM's CRS; m³/y): each point is snapped to the nearest valid cell, within one cell of the edge or of nodata and not an outlet, where its water joins the discharge and its sediment the fluvial sediment flux. climate-run also takes an age_ka column: each river's rows at several ages, linear in age.", rich_help_panel=BOUNDARY_PANEL)]
PROCESS_HELP = ("Process(es), comma-separated, applied in this order within each step (operator "
                "splitting): fluvial, thermal, thermal-ca (forward only), hillslope (forward only), "
                "debris (forward only).")


def _command(backward: bool):
    verb = "unerode" if backward else "erode"

    @with_parameter_options(PARAMETER_PANELS)
    def command(
        source: InputDem,
        output: OutputDem,
        process: Annotated[str, typer.Option(help=PROCESS_HELP)] = "fluvial",
        params: Annotated[Path | None, typer.Option("--params", help="YAML file of parameter values (name or symbol → number or raster path, optionally grouped under process names); command-line values win.")] = None,
        dt: Annotated[float, typer.Option("--dt", parser=POSITIVE_YEARS, help="Time step (years, > 0; unerode runs it backward).")] = 1000.0,
        duration: Annotated[float | None, typer.Option(parser=POSITIVE_YEARS, help="Simulated time (years); or give --steps.")] = None,
        steps: Annotated[int | None, typer.Option(min=1, help="Number of time steps; or give --duration.")] = None,
        no_substep: Annotated[bool, typer.Option("--no-substep", help="Refuse an unstable --dt instead of sub-stepping it.")] = False,
        snapshot_every: Annotated[float | None, typer.Option(parser=POSITIVE_YEARS, help="Write a numbered snapshot OUTPUT_k every this many simulated years.")] = None,
        change_map: Annotated[Path | None, typer.Option(help="Write the signed change (m) due to the processes (uplift excluded): < 0 erosion, > 0 deposition.")] = None,
        scheme: Annotated[Scheme, typer.Option(help="Slope of backward fluvial and thermal steps: limiter (000 Eq. 12) or upwind (Eq. 10).")] = Scheme.limiter,
        thermal_constraints: Annotated[str, typer.Option(help="Un-deposition constraints of thermal unerosion (000 §4.2): any of slope (Eq. 16), convexity (Eq. 17), rate (max un-deposition), or none.")] = "slope,convexity,rate",
        method: Annotated[Method, typer.Option(help="Flow routing: mfd (multiple flow directions) or d8.")] = Method.mfd,
        outlets: Outlets = "all",
        sea_level: SeaLevel = None,
        dirichlet: Dirichlet = None,
        inflow: Inflow = None,
        band: Band = None,
        channel: Channel = None,
        dtype: DtypeOpt = Dtype.float32,
        cog: Cog = False,
        co: CreationOptions = None,
        overwrite: Overwrite = False,
        preview: Preview = None,
        verbose: Verbose = 0,
        quiet: Quiet = 0,
        parameter_values: dict[str, str | None] | None = None,
    ) -> None:
        with reported_errors(verbose - quiet):
            from unerode_cli.cli.common import SUMMARY, say
            from unerode_cli.cli.progress import progress_bar
            from unerode_cli.jobs.erode import ErosionJob, plan, run_job

            job = ErosionJob(
                backward=backward, source=source, output=output, process=process, dt=dt,
                duration=duration, steps=steps, allow_substeps=not no_substep,
                snapshot_every=snapshot_every, change_map=change_map, scheme=scheme.value,
                method=method.value, outlets=outlets, sea_level=sea_level, dirichlet=dirichlet,
                band=band, channel=channel, dtype=dtype.value, cog=cog, co=co,
                overwrite=overwrite, preview=preview, parameter_values=parameter_values or {},
                params_file=params, constraints=thermal_constraints, inflow=inflow,
            )
            prepared = plan(job)
            with progress_bar(prepared.steps, verb, verbose - quiet) as advance:
                summary = run_job(prepared, on_step=advance,
                                  on_note=lambda text: say(text, verbose - quiet))
            say(summary, verbose - quiet, SUMMARY)

    command.__name__ = verb
    command.__doc__ = (
        "Unerode a DEM: run the processes backward in time (000 §3.2, slope limiter)."
        if backward else
        "Erode a DEM: run the processes forward in time (fluvial, thermal, hillslope, debris flow)."
    )
    return command


erode = _command(backward=False)
unerode = _command(backward=True)
