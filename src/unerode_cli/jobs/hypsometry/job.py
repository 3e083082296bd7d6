"""`hypsometry`: elevation histograms of DEMs as a CSV table and a PNG (001 Fig. 15)."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.analysis.hypsometry import Hypsometry, hypsometry
from unerode_cli.errors import InputError
from unerode_cli.io.csv_tables import write_table
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.io.rasters import read_terrain
from unerode_cli.run.outputs import check_png
from unerode_cli.viz.hypsometry_plot import save_hypsometry_plot

CSV_COLUMNS = ["dem", "bin", "lower", "upper", "centre", "area_fraction", "area_above_fraction"]


def compute(dems: list[Path], bins: int, normalise: str) -> list[tuple[Path, Hypsometry]]:
    """The hypsometry of each DEM (InputError on a bad DEM or setting)."""
    results = []
    for dem in dems:
        try:
            results.append((dem, hypsometry(read_terrain(dem).elevation, bins, normalise)))
        except ValueError as exc:
            raise InputError(f"{dem}: {exc}.") from None
    return results


def check_outputs(dems: list[Path], csv_path: Path | None, plot: Path | None, overwrite: bool) -> None:
    """Clear the CSV and the plot before any DEM is read."""
    if csv_path is not None:
        check_output(csv_path, overwrite, tuple(dems))
    if plot is not None:
        check_png(plot, overwrite, tuple(dems))


def write(results: list[tuple[Path, Hypsometry]], csv_path: Path | None, plot: Path | None) -> None:
    """Write the long-form CSV (one row per DEM and bin) and the plot (cleared by
    :func:`check_outputs`), atomically."""
    if csv_path is not None:
        rows = [dict(zip(CSV_COLUMNS, (dem.name, k, result.edges[k], result.edges[k + 1], result.centres[k],
                                        fraction, result.area_above[k]), strict=True))
                for dem, result in results for k, fraction in enumerate(result.fraction)]
        write_table(csv_path, CSV_COLUMNS, rows)
    if plot is not None:
        curves = [(dem.name, result.centres, result.fraction) for dem, result in results]
        with atomic_path(plot) as tmp:
            save_hypsometry_plot(tmp, curves, results[0][1].normalise, "hypsometry")
