"""Options shared by several subcommands, with units in their help (DESIGN §5)."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer


class Dtype(str, Enum):
    float32 = "float32"
    float64 = "float64"


class Method(str, Enum):
    """Flow routing: multiple flow directions ∝ slope (000 Eq. 6) or steepest descent (D8)."""

    mfd = "mfd"
    d8 = "d8"


InputDem = Annotated[Path, typer.Argument(help="Input heightfield (GeoTIFF, any GDAL raster, or .exr), metres.")]
OutputDem = Annotated[Path, typer.Argument(help="Output heightfield; the format follows the extension (.tif, .exr, ...).")]
Band = Annotated[int | None, typer.Option("--band", help="Band to read from a multi-band raster (1-based).")]
Channel = Annotated[str | None, typer.Option("--channel", help="EXR channel to read (default: Y, else R, else the only float channel).")]
Overwrite = Annotated[bool, typer.Option("--overwrite", help="Replace an existing output.")]
Verbose = Annotated[int, typer.Option("--verbose", "-v", count=True, help="More messages (-vv: debug); tracebacks on errors.")]
Quiet = Annotated[int, typer.Option("--quiet", "-q", count=True, help="Fewer messages.")]
DtypeOpt = Annotated[Dtype, typer.Option("--dtype", help="Output sample type of GDAL outputs.")]
Cog = Annotated[bool, typer.Option("--cog", help="Write a Cloud-Optimized GeoTIFF.")]
CreationOptions = Annotated[list[str] | None, typer.Option("--co", help="GDAL creation option KEY=VALUE (repeatable).")]
Preview = Annotated[Path | None, typer.Option("--preview", help="Also write a hillshade preview PNG of the output.")]
Seed = Annotated[int, typer.Option("--seed", help="Random seed (recorded in the output's history).")]


Outlets = Annotated[str, typer.Option("--outlets", help="Domain edges that drain out: all, none, or a comma list of N,E,S,W.")]
SeaLevel = Annotated[float | None, typer.Option("--sea-level", help="Cells at or below this elevation (m) are outlets.")]
Dirichlet = Annotated[Path | None, typer.Option("--dirichlet", help="Raster on the DEM's grid; non-zero cells are fixed-elevation outlet nodes.")]
