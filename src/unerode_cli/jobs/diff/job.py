"""`diff`: the difference B − A of two DEMs on the same grid, written as a raster with its
statistics (RMSE, bias, ...) in the sidecar."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

from unerode_cli.analysis.difference import DifferenceStats, difference
from unerode_cli.errors import InputError
from unerode_cli.io.grid_rasters import read_on_grid
from unerode_cli.io.rasters import read_terrain
from unerode_cli.run.outputs import Outputs, check_previewable, field_preview, save


def run_diff(first: Path, second: Path, outputs: Outputs) -> DifferenceStats:
    """Write ``second − first`` (m) to ``outputs`` and return its statistics."""
    outputs.check(first, second)
    a = read_terrain(first)
    a.check_valid(first)
    b = read_on_grid(second, a, "second DEM")
    b.check_valid(second)
    if outputs.preview is not None:
        check_previewable(a, first)
    try:
        values, stats = difference(a.elevation, b.elevation)
    except ValueError as exc:  # no valid cell in common
        raise InputError(f"{first} and {second}: {exc}.") from None
    layer = a.with_elevation(values)
    layer.tags = {key: value for key, value in a.tags.items() if key != "UNERODE_HISTORY"}
    save(layer, outputs, "diff", {"a": first, "b": second, "output": "b - a"}, asdict(stats),
         elevation_preview=False)
    if outputs.preview is not None:
        field_preview(values, a, outputs.preview, "B − A (m)", diverging=True,
                      title=f"{second.name} − {first.name}")
    return stats
