"""`unerode-cli landforms DEM --out DIR`: glacial landform measures (001 §7.1, Fig. 15) as a
short table, landforms.json and landforms.png."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import InputDem, Outlets, Overwrite, Quiet, Verbose
from unerode_cli.cli.values import Number

MEASURES = "Measures"


def landforms(
    dem: InputDem,
    out: Annotated[Path, typer.Option("--out", help="Write landforms.json and landforms.png in this folder (created if missing).")],
    before: Annotated[Path | None, typer.Option("--before", help="The DEM before erosion (any grid): its hypsometry is compared with DEM's.")] = None,
    spacing: Annotated[float, typer.Option("--spacing", parser=Number("m", 0.0, above=True), help="Distance between cross-sections along the trunk (m).", rich_help_panel=MEASURES)] = 500.0,
    half_width: Annotated[float, typer.Option("--half-width", parser=Number("m", 0.0, above=True), help="Cross-sections reach this far on each side of the trunk (m).", rich_help_panel=MEASURES)] = 2000.0,
    reach: Annotated[float, typer.Option("--reach", parser=Number("m", 0.0, above=True), help="Tributary steps are measured over their last reach of this length (m).", rich_help_panel=MEASURES)] = 250.0,
    min_step: Annotated[float, typer.Option("--min-step", parser=Number("m", 0.0), help="A tributary whose step reaches this (m) is hanging.", rich_help_panel=MEASURES)] = 20.0,
    min_lake_depth: Annotated[float, typer.Option("--min-lake-depth", parser=Number("m", 0.0), help="A lake is deeper than this somewhere (m); shallower pits are DEM noise.", rich_help_panel=MEASURES)] = 0.5,
    outlets: Outlets = "all",
    overwrite: Overwrite = False,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Measure glacial landforms: the U-shape exponent b of the main valley's cross-sections
    (z = z0 + a|x − x0|^b; b ≈ 2 U, ≈ 1 V), the steps of tributaries at their junctions
    (hanging valleys), the lakes in closed depressions, and the hypsometry (with its shift
    from --before)."""
    with reported_errors(verbose - quiet):
        from unerode_cli.analysis.landforms import Settings
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.jobs.landforms import LandformsJob, check_outputs, compute, table, write

        settings = Settings(spacing_m=spacing, half_width_m=half_width, reach_m=reach, min_step_m=min_step,
                            min_lake_depth_m=min_lake_depth)
        job = LandformsJob(dem=dem, out_dir=out, before=before, outlets=outlets, settings=settings,
                           overwrite=overwrite)
        check_outputs(job)
        terrain, result = compute(job)
        numbers = write(job, terrain, result)
        typer.echo("measure\tvalue")
        for measure, value in table(numbers):
            typer.echo(f"{measure}\t{value}")
        say(f"report written to {out}/", verbose - quiet, SUMMARY)
