"""The `preview` job: a PNG of a heightfield, hillshade blended with a colour ramp of the
values and a colour bar."""

from __future__ import annotations

from matplotlib import colormaps

from unerode_cli.errors import InputError
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.preview.options import OPTIONS
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job
from unerode_cli.run.outputs import check_previewable, preview


@declared("preview", OPTIONS)
class PreviewJob(Job):
    """Draw ``dem`` into ``png``: colour map ``cmap`` (``sea-land`` or a matplotlib name),
    hillshade exaggerated ``exaggeration`` times, colour bar named ``label``."""

    def plan(self, outputs: OutputPlan) -> Terrain:
        """Clear the PNG, check the colour map, read the DEM and check it can be hill-shaded."""
        outputs.read(self.dem)
        outputs.check_output(self.png, self.overwrite)
        if self.png.suffix.lower() != ".png":
            raise InputError(f"the preview must be a .png file, got {self.png.name}.")
        if self.cmap != "sea-land" and self.cmap not in colormaps:
            raise InputError(f"unknown colour map '{self.cmap}'.")
        terrain = read_terrain(self.dem, band=self.band, channel=self.channel, georef=input_georef(self))
        check_previewable(terrain, self.dem)
        return terrain

    def write(self, result: Terrain, outputs: OutputPlan) -> str:
        """Draw and write the PNG (atomically)."""
        preview(result, self.png, title=self.title if self.title is not None else self.dem.name,
                cmap=self.cmap, vertical_exaggeration=self.exaggeration, label=self.label)
        return ""
