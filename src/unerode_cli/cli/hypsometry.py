"""`unerode-cli hypsometry DEM...`: elevation histograms (001 Fig. 15) as CSV and PNG."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import Overwrite, Quiet, Verbose


class Normalise(str, Enum):
    max = "max"
    range = "range"
    none = "none"


def hypsometry(
    dems: Annotated[list[Path], typer.Argument(help="One or more DEMs (GeoTIFF, any GDAL raster, or .exr), metres.")],
    csv: Annotated[Path | None, typer.Option("--csv", help="Write the histograms here: one row per DEM and bin.")] = None,
    plot: Annotated[Path | None, typer.Option("--plot", help="Write the curves of all DEMs on one PNG.")] = None,
    bins: Annotated[int, typer.Option("--bins", min=1, help="Number of elevation bins.")] = 50,
    normalise: Annotated[Normalise, typer.Option("--normalise", help="max: elevation / highest elevation (001 Fig. 15); range: (h − min)/(max − min) (Strahler); none: metres.")] = Normalise.max,
    overwrite: Overwrite = False,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Distribution of elevations: share of the area per elevation bin, hypsometric integral
    HI = (mean − min)/(max − min) and hypsometric maximum (the fullest bin), printed per DEM."""
    with reported_errors(verbose - quiet):
        from unerode_cli.jobs.hypsometry import check_outputs, compute, write

        check_outputs(dems, csv, plot, overwrite)
        results = compute(dems, bins, normalise.value)
        write(results, csv, plot)
        typer.echo("dem\tmin_m\tmax_m\tmean_m\tmode_m\tHI")
        for dem, result in results:
            typer.echo(f"{dem.name}\t{result.minimum_m:.6g}\t{result.maximum_m:.6g}\t{result.mean_m:.6g}\t"
                       f"{result.mode_m:.6g}\t{result.integral:.4f}")
