"""The `convert` job: a heightfield in any supported format to any other, keeping CRS,
transform and nodata; optionally cropped to a box, resampled and scaled in z."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.gdal_io import write_bytes_per_cell
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.rasters import is_exr, read_header, read_terrain
from unerode_cli.io.resampling import RESAMPLE_BYTES_PER_CELL, crop, crop_window, resample, resampled_shape
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.convert.options import OPTIONS
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.memory import check_fits
from unerode_cli.run.outputs import Outputs, save


@dataclass
class PlannedConversion:
    """The source on the output's grid (cropped, resampled) and the cleared outputs."""

    terrain: Terrain
    outputs: Outputs


@declared("convert", OPTIONS)
class ConvertJob(Job):
    """Convert ``source`` to ``output`` (the format follows its extension), elevations times
    ``z_scale``; ``crop`` is (xmin, ymin, xmax, ymax) and ``cell_size`` a cell size, both in the
    CRS's units."""

    def plan(self, outputs: OutputPlan) -> PlannedConversion:
        """Clear the outputs, then read the source on the output's grid: the cells whose
        centres lie in ``crop``, resampled to ``cell_size`` (a window and a change of grid, no
        change of the values' meaning).

        Only the window of ``crop`` is read from a GDAL raster (an EXR is read whole); the
        memory of the read, of the resampled grid and of writing it is estimated and refused
        (InputError) before it is allocated, and so are elevations that ``z_scale`` would take
        past the output type's finite range."""
        outputs.read(self.source)
        written = Outputs.from_cli(self.output, self.dtype, self.cog, self.co, self.overwrite, self.preview)
        written.check(self.source)
        header = read_header(self.source, band=self.band, georef=input_georef(self))
        window = None
        if self.crop is not None and header.transform is not None and not is_exr(self.source):
            window = crop_window(header.transform, header.shape, self.crop)
        terrain = read_terrain(self.source, band=self.band, channel=self.channel, window=window,
                               georef=input_georef(self))
        if self.crop is not None and window is None:
            terrain = crop(terrain, self.crop)
        if self.cell_size is not None:
            rows, cols = resampled_shape(terrain.transform, terrain.shape, self.cell_size)
            per_cell = RESAMPLE_BYTES_PER_CELL + write_bytes_per_cell(written.path)
            check_fits(float(rows) * cols * per_cell,
                       f"resampling {self.source} to --cell-size {self.cell_size:g} ({rows:,} × {cols:,} "
                       "cells)",
                       "give a larger --cell-size or --crop a smaller area first")
            terrain = resample(terrain, self.cell_size)
        check_scaled(terrain, self.z_scale, written.options.dtype)
        written.check_source(terrain, self.source)
        return PlannedConversion(terrain, written)

    def run(self, planned: PlannedConversion, progress: Progress) -> tuple[PlannedConversion, Terrain]:
        return planned, planned.terrain.with_elevation(planned.terrain.elevation * self.z_scale)

    def write(self, result: tuple[PlannedConversion, Terrain], outputs: OutputPlan) -> str:
        """Write the converted heightfield with its history, sidecar and preview."""
        planned, converted = result
        save(converted, planned.outputs, self.COMMAND, self.provenance())
        return ""


def check_scaled(terrain: Terrain, z_scale: float, dtype: str) -> None:
    """Refuse (InputError) a ``z_scale`` that takes a valid elevation past what the output type
    holds (a float type's finite range; for an integer type, float64's): the cells would turn
    into nodata or infinities."""
    valid = ~terrain.nodata_mask
    if not valid.any():
        return
    z = terrain.elevation[valid]
    biggest = float(np.abs(z).max()) * abs(z_scale)
    kind = np.dtype(dtype)
    limit = float(np.finfo(kind).max) if kind.kind == "f" else float(np.finfo(np.float64).max)
    if not biggest <= limit:  # inf and NaN included
        made = f"of up to {biggest:.3g} m" if np.isfinite(biggest) else "that are not finite numbers"
        raise InputError(f"--z-scale {z_scale:g} makes elevations {made}, beyond the largest finite "
                         f"{kind.name} ({limit:.3g}); give a smaller --z-scale.")
