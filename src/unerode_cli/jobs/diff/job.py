"""The `diff` job: the difference B − A of two DEMs on the same grid, written as a raster
with its statistics (RMSE, bias, ...) in the sidecar and printed."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from unerode_cli.analysis.difference import DifferenceStats, difference
from unerode_cli.errors import InputError
from unerode_cli.io.grid_rasters import read_on_grid
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.diff.options import OPTIONS
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.outputs import Outputs, check_previewable, field_preview, save


@dataclass
class PlannedDiff:
    """The two DEMs (B read on A's grid) and the cleared outputs."""

    a: Terrain
    b: Terrain
    outputs: Outputs


@dataclass
class Difference:
    """B − A (m, NaN where either is nodata) and its statistics."""

    values: np.ndarray
    stats: DifferenceStats


@declared("diff", OPTIONS)
class DiffJob(Job):
    """``b − a`` (m) into ``output``; the statistics go to the sidecar and the standard output."""

    def plan(self, outputs: OutputPlan) -> PlannedDiff:
        outputs.read(self.a)
        outputs.read(self.b)
        written = Outputs.from_cli(self.output, self.dtype, self.cog, self.co, self.overwrite, self.preview)
        written.check(self.a, self.b)
        a = read_terrain(self.a, georef=input_georef(self))
        a.check_valid(self.a)
        b = read_on_grid(self.b, a, "second DEM", georef=input_georef(self))
        b.check_valid(self.b)
        if self.preview is not None:
            check_previewable(a, self.a)
        return PlannedDiff(a, b, written)

    def run(self, planned: PlannedDiff, progress: Progress) -> tuple[PlannedDiff, Difference]:
        """The difference and its statistics, printed as one line: cells compared, RMSE, mean
        (bias), mean absolute, min, max (m) and the correlation of A and B."""
        try:
            values, stats = difference(planned.a.elevation, planned.b.elevation)
        except ValueError as exc:  # no valid cell in common
            raise InputError(f"{self.a} and {self.b}: {exc}.") from None
        largest = max(abs(stats.min_m), abs(stats.max_m))
        if self.dtype == "float32" and not largest <= float(np.finfo(np.float32).max):
            raise InputError(f"the difference of {self.b} and {self.a} reaches {largest:.3g} m, more than a "
                             "float32 raster holds; write it with --dtype float64.")
        progress.data(f"cells {stats.cells}  RMSE {stats.rmse_m:.6g} m  mean {stats.mean_m:+.6g} m  "
                      f"MAE {stats.mae_m:.6g} m  min {stats.min_m:.6g} m  max {stats.max_m:.6g} m  "
                      f"r {stats.correlation:.6f}")
        return planned, Difference(values, stats)

    def write(self, result: tuple[PlannedDiff, Difference], outputs: OutputPlan) -> str:
        """Write the difference (A's tags without its history) with its sidecar and preview."""
        planned, diff = result
        layer = planned.a.with_elevation(diff.values)
        layer.tags = {key: value for key, value in planned.a.tags.items() if key != "UNERODE_HISTORY"}
        save(layer, planned.outputs, self.COMMAND, {**self.provenance(), "output": "b - a"},
             asdict(diff.stats), elevation_preview=False)
        if self.preview is not None:
            field_preview(diff.values, planned.a, self.preview, "B − A (m)", diverging=True,
                          title=f"{self.b.name} − {self.a.name}")
        return ""
