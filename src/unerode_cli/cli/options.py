"""Options shared by several subcommands, with units in their help (DESIGN §5)."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.values import Number

#: Parsers of kinds of numbers that several options share: a time span (years, > 0) and an
#: elevation (m).
POSITIVE_YEARS = Number("years", 0.0, above=True)
METRES = Number("m")

#: Help panels of the shared options: a few short panels keep long option names whole in an
#: 80-column help (rich sizes the columns of each panel on its own rows).
BOUNDARY_PANEL = "Boundaries"
OUTPUT_PANEL = "Outputs"


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
Overwrite = Annotated[bool, typer.Option("--overwrite", help="Replace an existing output.", rich_help_panel=OUTPUT_PANEL)]
Verbose = Annotated[int, typer.Option("--verbose", "-v", count=True, help="-v: one line per step and the traceback of an error; -vv: also each step's wall time (debug).")]
Quiet = Annotated[int, typer.Option("--quiet", "-q", count=True, help="-q: no notes (summaries and errors remain); -qq: errors only.")]
DtypeOpt = Annotated[Dtype, typer.Option("--dtype", help="Output sample type of GDAL outputs.", rich_help_panel=OUTPUT_PANEL)]
Cog = Annotated[bool, typer.Option("--cog", help="Write a Cloud-Optimized GeoTIFF.", rich_help_panel=OUTPUT_PANEL)]
CreationOptions = Annotated[list[str] | None, typer.Option("--co", help="GDAL creation option KEY=VALUE (repeatable).", rich_help_panel=OUTPUT_PANEL)]
Preview = Annotated[Path | None, typer.Option("--preview", help="Also write a hillshade preview PNG of the output.", rich_help_panel=OUTPUT_PANEL)]
CHECKPOINT_PANEL = "Checkpoints"
CheckpointEvery = Annotated[int, typer.Option(min=1, help="Write a checkpoint (.OUT.checkpoint.npz beside OUT) every this many steps.", rich_help_panel=CHECKPOINT_PANEL)]
Resume = Annotated[bool, typer.Option("--resume", help="Continue an interrupted run from its checkpoint (same inputs and options).", rich_help_panel=CHECKPOINT_PANEL)]
MaxSteps = Annotated[int | None, typer.Option(min=1, help="Stop after this many steps of this invocation (checkpointed; continue with --resume).", rich_help_panel=CHECKPOINT_PANEL)]
Seed = Annotated[int, typer.Option("--seed", help="Random seed (recorded in the output's history).")]


Outlets = Annotated[str, typer.Option("--outlets", help="Domain edges that drain out: all, none, or a comma list of N,E,S,W.", rich_help_panel=BOUNDARY_PANEL)]
SeaLevel = Annotated[float | None, typer.Option("--sea-level", parser=METRES, help="Cells at or below this elevation (m) are outlets.", rich_help_panel=BOUNDARY_PANEL)]
Dirichlet = Annotated[Path | None, typer.Option("--dirichlet", help="Raster on the DEM's grid; non-zero cells are fixed-elevation outlet nodes.", rich_help_panel=BOUNDARY_PANEL)]
Coast = Annotated[str, typer.Option("--coast", help="Sea edges, whose cells follow sea level: none, all, or a comma list of N,E,S,W and nodata (nodata borders).", rich_help_panel=BOUNDARY_PANEL)]
EdgeBase = Annotated[str | None, typer.Option("--edge-base", help="Base level of the other boundary nodes: fixed (keep their elevation; the default), uplift (rise with U), coarse (follow the surface of the coarse run of --inflow-from; the default with it), or FILE, a CSV table of age_ka, elevation_m (move as it does since --from).", rich_help_panel=BOUNDARY_PANEL)]
