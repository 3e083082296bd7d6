"""The `convert` job: a heightfield in any supported format to any other, keeping CRS,
transform and nodata; optionally cropped to a box, resampled and scaled in z."""

from __future__ import annotations

from dataclasses import dataclass

from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.resampling import crop, resample
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.convert.options import OPTIONS
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
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
        change of the values' meaning)."""
        outputs.read(self.source)
        written = Outputs.from_cli(self.output, self.dtype, self.cog, self.co, self.overwrite, self.preview)
        written.check(self.source)
        terrain = read_terrain(self.source, band=self.band, channel=self.channel)
        if self.crop is not None:
            terrain = crop(terrain, self.crop)
        if self.cell_size is not None:
            terrain = resample(terrain, self.cell_size)
        written.check_source(terrain, self.source)
        return PlannedConversion(terrain, written)

    def run(self, planned: PlannedConversion, progress: Progress) -> tuple[PlannedConversion, Terrain]:
        return planned, planned.terrain.with_elevation(planned.terrain.elevation * self.z_scale)

    def write(self, result: tuple[PlannedConversion, Terrain], outputs: OutputPlan) -> str:
        """Write the converted heightfield with its history, sidecar and preview."""
        planned, converted = result
        save(converted, planned.outputs, self.COMMAND, self.provenance())
        return ""
