"""`unerode-cli preview DEM OUT.png`: hillshade blended with an elevation colour ramp."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import Band, Channel, InputDem, Overwrite, Quiet, Verbose
from unerode_cli.cli.values import Number


def preview(
    dem: InputDem,
    png: Annotated[Path, typer.Argument(help="Output PNG.")],
    title: Annotated[str | None, typer.Option(help="Title (default: the DEM's file name).")] = None,
    cmap: Annotated[str, typer.Option(help="Colour map: sea-land (blues below 0 m) or any matplotlib one.")] = "sea-land",
    exaggeration: Annotated[float, typer.Option(parser=Number(minimum=0.0, above=True), help="Vertical exaggeration of the hillshade (> 0).")] = 1.0,
    label: Annotated[str, typer.Option(help="Name of the colour bar, e.g. 'ice thickness (m)'.")] = "elevation (m)",
    band: Band = None,
    channel: Channel = None,
    overwrite: Overwrite = False,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Write a PNG: hillshade on a colour ramp of the values, colour bar in metres (``--label``)."""
    with reported_errors(verbose - quiet):
        from matplotlib import colormaps

        from unerode_cli.cli.common import load
        from unerode_cli.errors import InputError
        from unerode_cli.io.paths import check_output
        from unerode_cli.run.outputs import check_previewable
        from unerode_cli.run.outputs import preview as write_preview

        check_output(png, overwrite, (dem,))
        if png.suffix.lower() != ".png":
            raise InputError(f"the preview must be a .png file, got {png.name}.")
        if cmap != "sea-land" and cmap not in colormaps:
            raise InputError(f"unknown colour map '{cmap}'.")
        terrain = load(dem, band, channel)
        check_previewable(terrain, dem)
        write_preview(terrain, png, title=title if title is not None else dem.name,
                       cmap=cmap, vertical_exaggeration=exaggeration, label=label)
