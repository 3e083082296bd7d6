"""`unerode-cli diff A B OUT`: the difference B − A of two DEMs and its RMSE."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import Cog, CreationOptions, Dtype, DtypeOpt, Overwrite, Preview, Quiet, Verbose


def diff(
    a: Annotated[Path, typer.Argument(help="First DEM (A), metres.")],
    b: Annotated[Path, typer.Argument(help="Second DEM (B) on the same grid (shape, transform, CRS).")],
    output: Annotated[Path, typer.Argument(help="Output raster of B − A (m): positive where B is higher.")],
    dtype: DtypeOpt = Dtype.float32,
    cog: Cog = False,
    co: CreationOptions = None,
    overwrite: Overwrite = False,
    preview: Preview = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Difference of two DEMs; prints cells compared, RMSE, mean (bias), mean absolute, min, max
    (m) and the correlation of A and B, also kept in the JSON sidecar."""
    with reported_errors(verbose - quiet):
        from unerode_cli.jobs.diff import run_diff
        from unerode_cli.run.outputs import Outputs

        stats = run_diff(a, b, Outputs.from_cli(output, dtype.value, cog, co, overwrite, preview))
        typer.echo(f"cells {stats.cells}  RMSE {stats.rmse_m:.6g} m  mean {stats.mean_m:+.6g} m  "
                   f"MAE {stats.mae_m:.6g} m  min {stats.min_m:.6g} m  max {stats.max_m:.6g} m  "
                   f"r {stats.correlation:.6f}")
