"""`unerode-cli compare-terraces`: simulated past riverbeds against dated terraces and incision
rates (000 §6.3)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import Outlets, Overwrite, Quiet, SeaLevel, Verbose
from unerode_cli.cli.values import Number

#: Exit code when the terrace RMSE exceeds --fail-above (a gate for Makefiles).
EXIT_ABOVE_THRESHOLD = 3


def _point(text: str | None) -> tuple[float, float] | None:
    from unerode_cli.errors import InputError

    if text is None:
        return None
    try:
        x, y = (float(part) for part in text.split(","))
    except ValueError:
        raise InputError(f"--river-start expects X,Y in the DEM's CRS, got '{text}'.") from None
    return x, y


def _expanded(entries: list[str]) -> tuple[Path, ...]:
    """Snapshot entries: files, folders, or glob patterns (quoted so the shell leaves them)."""
    import glob

    paths: list[Path] = []
    for entry in entries:
        matches = sorted(glob.glob(entry)) if glob.has_magic(entry) else [entry]
        paths += [Path(match) for match in matches] or [Path(entry)]
    return tuple(paths)


def compare_terraces(
    present: Annotated[Path, typer.Option("--present", help="Today's DEM, the reference of the heights.", rich_help_panel="Inputs")],
    snapshots: Annotated[list[str], typer.Option("--snapshots", help="Snapshot raster, folder of snapshots, or quoted glob ('runs/past_*ka.tif'); repeatable. Ages come from climate-run's UNERODE_AGE_KA tag, else a name ending in _<age>ka.", rich_help_panel="Inputs")],
    out: Annotated[Path, typer.Option("--out", help="Write the report in this folder: terraces.csv, profiles.csv, summary.json, profiles.png (+ incision.csv, incision.png).", rich_help_panel="Inputs")],
    observations: Annotated[Path | None, typer.Option("--observations", help="CSV of dated terraces with the columns age_ka and height_above_river_m, and optionally uncertainty_m, x and y (DEM's CRS) or chainage_m, and name.", rich_help_panel="Inputs")] = None,
    incision: Annotated[Path | None, typer.Option("--incision", help="CSV of incision rates with the columns from_ka, to_ka and rate_mm_per_ka, and optionally uncertainty_mm_per_ka and name.", rich_help_panel="Inputs")] = None,
    river: Annotated[Path | None, typer.Option("--river", help="River line in the DEM's CRS: GeoJSON or WKT LINESTRING (either direction).", rich_help_panel="River")] = None,
    auto_river: Annotated[bool, typer.Option("--auto-river", help="Extract the main channel by steepest descent instead of --river.", rich_help_panel="River")] = False,
    river_start: Annotated[str | None, typer.Option("--river-start", help="X,Y (DEM's CRS) where the automatic river starts; default: up the main stem of the largest catchment.", rich_help_panel="River")] = None,
    min_area_fraction: Annotated[float, typer.Option("--min-area-fraction", parser=Number(minimum=0.0, maximum=1.0, above=True), help="The automatic main stem ends where its tributaries drain less than this share of the catchment.", rich_help_panel="River")] = 0.01,
    search_radius: Annotated[float, typer.Option("--search-radius", parser=Number("m", 0.0), help="Riverbed = lowest cell within this distance (m) of the river line; 0: the cell under it.", rich_help_panel="River")] = 0.0,
    outlets: Outlets = "all",
    sea_level: SeaLevel = None,
    uplift: Annotated[float, typer.Option("--uplift", parser=Number("m/y"), help="Rock uplift rate since each age (m/y): a terrace formed at age a now stands U·a higher than its simulated bed.", rich_help_panel="Comparison")] = 0.0,
    fail_above: Annotated[float | None, typer.Option("--fail-above", parser=Number("m", 0.0), help=f"Exit with code {EXIT_ABOVE_THRESHOLD} when the terrace RMSE exceeds this (m), after writing the report.", rich_help_panel="Comparison")] = None,
    overwrite: Overwrite = False,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Compare the riverbeds of climate-run snapshots with dated terraces and incision rates.

    Heights are those of each snapshot's riverbed above today's, along the river; each
    observation is compared at its place (x,y or chainage) or with the river's mean.
    """
    with reported_errors(verbose - quiet):
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.errors import InputError
        from unerode_cli.jobs.compare_terraces import TerraceJob, run_compare

        if fail_above is not None and observations is None:
            raise InputError("--fail-above gates the terrace RMSE: it needs --observations.")
        job = TerraceJob(
            present=present, snapshots=_expanded(snapshots), out_dir=out, observations=observations,
            incision=incision, river=river, auto_river=auto_river, river_start=_point(river_start),
            min_area_fraction=min_area_fraction, search_radius=search_radius, uplift=uplift,
            outlets=outlets, sea_level=sea_level, overwrite=overwrite,
        )
        report = run_compare(job)
        summary = report.summary
        terraces = summary["terraces"]
        if terraces["count"]:
            typer.echo(f"terraces: {terraces['count']}, RMSE {terraces['rmse_m']:.3g} m, "
                       f"bias {terraces['bias_m']:+.3g} m, within uncertainty "
                       f"{terraces['within_uncertainty']} of {terraces['with_uncertainty']}")
        for period in summary["incision"]["periods"]:
            typer.echo(f"incision {period['from_ka']:g}-{period['to_ka']:g} ka: simulated "
                       f"{period['simulated_mm_per_ka']:.3g} mm/ka, observed {period['observed_mm_per_ka']:.3g} mm/ka")
        say(f"report written to {out}/", verbose - quiet, SUMMARY)
        if fail_above is not None and report.rmse_m > fail_above:
            say(f"terrace RMSE {report.rmse_m:.3g} m is above --fail-above {fail_above:g} m.", 0)
            raise typer.Exit(EXIT_ABOVE_THRESHOLD)
