"""The `synth` job: a reproducible synthetic DEM with a CRS, written with its sidecar."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from affine import Affine

from unerode_cli.errors import InputError
from unerode_cli.io.cellsize import CellSize, cell_size_metres
from unerode_cli.io.gdal_io import write_bytes_per_cell
from unerode_cli.io.georef import centred_transform, parse_crs
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.synth.options import OPTIONS
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.memory import check_fits
from unerode_cli.run.outputs import Outputs, save
from unerode_cli.synthetic import relief_for_extent, shape_of

#: Peak bytes per cell of making the elevations (``synthetic.shape_of``: the spectrum, its
#: inverse transform and, for a mountain range, the ridges and bands), measured with tracemalloc
#: (32 and 70) and rounded up (the default relief's gradients after it: 30–37); then the
#: elevations kept while written, and a preview's hillshade.
SYNTH_BYTES_PER_CELL = {"fractal": 40, "mountain": 80}
KEPT_BYTES_PER_CELL = 8
PREVIEW_BYTES_PER_CELL = 48


@dataclass
class PlannedSynth:
    """The grid of the DEM: CRS (WKT), affine transform, cell size (m) and the cleared outputs."""

    crs_wkt: str
    transform: Affine
    cell: CellSize
    outputs: Outputs


@dataclass
class Synthesized:
    """The elevations (m; NaN below 0 m with ``sea_nodata``) and the land relief (m) they have."""

    elevation: np.ndarray
    relief: float


@declared("synth", OPTIONS)
class SynthJob(Job):
    """``size`` cells square of ``dx`` metres, ``relief`` metres of land (None: 2000 m, or less
    so that the land's median slope is at most 30°: ``synthetic.relief_for_extent``), in ``crs``
    around ``centre`` ("X,Y" in CRS units; None: the CRS's area of use)."""

    def plan(self, outputs: OutputPlan) -> PlannedSynth:
        """Clear the outputs and place the grid (CRS, transform, cell size in metres)."""
        written = Outputs.from_cli(self.output, self.dtype, self.cog, self.co, self.overwrite, self.preview)
        written.check()
        if not self.dx > 0:
            raise InputError(f"--dx must be a positive cell size in metres, got {self.dx}.")
        crs = parse_crs(self.crs)
        shape = (self.size, self.size)
        transform = centred_transform(crs, shape, self.dx, parse_centre(self.centre))
        wkt = crs.to_wkt()
        cell = cell_size_metres(wkt, transform, shape, str(self.output))
        making = SYNTH_BYTES_PER_CELL.get(self.kind, max(SYNTH_BYTES_PER_CELL.values()))
        per_cell = (making + KEPT_BYTES_PER_CELL + write_bytes_per_cell(written.path)
                    + (PREVIEW_BYTES_PER_CELL if self.preview else 0))
        check_fits(float(self.size) ** 2 * per_cell, f"a {self.size:,} × {self.size:,} {self.kind} DEM",
                   "give a smaller --size")
        return PlannedSynth(wkt, transform, cell, written)

    def run(self, planned: PlannedSynth, progress: Progress) -> tuple[PlannedSynth, Synthesized]:
        """The elevations, at ``relief`` or, without one, at the relief the extent allows (the
        grid's cell sizes in metres, geographic CRSs included)."""
        relative = shape_of(self.kind, (self.size, self.size), self.seed)
        relief = self.relief
        if relief is None:
            relief = relief_for_extent(relative, planned.cell.dx, planned.cell.dy)
        elevation = relief * relative
        if self.sea_nodata:
            elevation = np.where(elevation < 0.0, np.nan, elevation)
        return planned, Synthesized(elevation, relief)

    def write(self, result: tuple[PlannedSynth, Synthesized], outputs: OutputPlan) -> str:
        """Write the DEM with its history (the relief it has, and the seed), sidecar and preview."""
        planned, made = result
        terrain = Terrain(made.elevation, planned.cell.dx, planned.cell.dy, planned.crs_wkt,
                          planned.transform, -9999.0 if self.sea_nodata else None,
                          {"AREA_OR_POINT": "Area", "UNIT": "metre"})
        save(terrain, planned.outputs, self.COMMAND, {**self.provenance(), "relief": made.relief},
             seed=self.seed)
        return ""


def parse_centre(text: str | None) -> tuple[float, float] | None:
    """``"X,Y"`` → (x, y); None stays None."""
    if text is None:
        return None
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--centre expects X,Y (two numbers), got '{text}'.") from None
    return (x, y)
