"""The `hypsometry` job: elevation histograms of DEMs (001 Fig. 15), printed as a table of
their statistics and written as a CSV table and a PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from unerode_cli.analysis.hypsometry import Hypsometry, hypsometry
from unerode_cli.errors import InputError
from unerode_cli.io.csv_tables import write_table
from unerode_cli.io.paths import OutputPlan, atomic_path
from unerode_cli.io.rasters import read_terrain
from unerode_cli.jobs.hypsometry.options import OPTIONS
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.memory import check_fits
from unerode_cli.run.outputs import check_png
from unerode_cli.viz.hypsometry_plot import save_hypsometry_plot

CSV_COLUMNS = ["dem", "bin", "lower", "upper", "centre", "area_fraction", "area_above_fraction"]
#: Peak bytes per bin and DEM: the histogram's arrays (counts, edges in metres and normalised,
#: centres, fractions, area above: about 8 float64 values).
BYTES_PER_BIN = 64
#: Peak bytes per row of the CSV (one per DEM and bin) while it is built: a dict of seven
#: values and their text.
BYTES_PER_CSV_ROW = 1200


@declared("hypsometry", OPTIONS)
class HypsometryJob(Job):
    """The hypsometry of each of ``dems`` in ``bins`` bins of elevation (normalised by
    ``normalise``: max, range or none), into ``csv`` and ``plot`` when given."""

    def plan(self, outputs: OutputPlan) -> list[tuple[Path, np.ndarray]]:
        """Clear the CSV and the plot, estimate the memory of ``bins`` bins (refused when it does
        not fit), then read the elevations (m) of each DEM."""
        per_bin = BYTES_PER_BIN + (BYTES_PER_CSV_ROW if self.csv is not None else 0)
        check_fits(float(self.bins) * len(self.dems) * per_bin,
                   f"a hypsometry of {self.bins:,} bins", "give fewer --bins (the default is 50)")
        for dem in self.dems:
            outputs.read(dem)
        if self.csv is not None:
            outputs.check_output(self.csv, self.overwrite)
        if self.plot is not None:
            check_png(self.plot, self.overwrite)
        return [(dem, read_terrain(dem, georef=input_georef(self)).elevation) for dem in self.dems]

    def run(self, planned: list[tuple[Path, np.ndarray]],
            progress: Progress) -> list[tuple[Path, Hypsometry]]:
        """The hypsometry of each DEM, printed as a table: min, max, mean and mode (m) and the
        hypsometric integral HI = (mean − min)/(max − min)."""
        results = []
        for dem, elevation in planned:
            try:
                results.append((dem, hypsometry(elevation, self.bins, self.normalise)))
            except ValueError as exc:
                raise InputError(f"{dem}: {exc}.") from None
        progress.data("dem\tmin_m\tmax_m\tmean_m\tmode_m\tHI")
        for dem, result in results:
            progress.data(f"{dem.name}\t{result.minimum_m:.6g}\t{result.maximum_m:.6g}\t{result.mean_m:.6g}\t"
                          f"{result.mode_m:.6g}\t{result.integral:.4f}")
        return results

    def write(self, result: list[tuple[Path, Hypsometry]], outputs: OutputPlan) -> str:
        """Write the long-form CSV (one row per DEM and bin) and the plot, atomically."""
        if self.csv is not None:
            rows = [dict(zip(CSV_COLUMNS, (dem.name, k, hyps.edges[k], hyps.edges[k + 1], hyps.centres[k],
                                            fraction, hyps.area_above[k]), strict=True))
                    for dem, hyps in result for k, fraction in enumerate(hyps.fraction)]
            write_table(self.csv, CSV_COLUMNS, rows)
        if self.plot is not None:
            curves = [(dem.name, hyps.centres, hyps.fraction) for dem, hyps in result]
            with atomic_path(self.plot) as tmp:
                save_hypsometry_plot(tmp, curves, result[0][1].normalise, "hypsometry")
        return ""
