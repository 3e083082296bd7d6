"""The `landforms` job: glacial landform measures of a DEM (001 §7.1, Fig. 15) — U-shape of the
main valley's cross-sections, hanging tributaries, lakes, hypsometry and its shift from an
earlier DEM. Reads the DEMs, runs :mod:`unerode_cli.analysis.landforms`, prints a short table
and writes the report folder: landforms.json and landforms.png."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.analysis.hypsometry import Hypsometry
from unerode_cli.analysis.landforms import Landforms, Settings, measure_landforms
from unerode_cli.errors import InputError
from unerode_cli.hydro import outlet_mask
from unerode_cli.hydro.depressions import lake_labels
from unerode_cli.io.json_files import write_json
from unerode_cli.io.paths import OutputPlan, atomic_path
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.landforms.options import OPTIONS
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.memory import check_fits
from unerode_cli.run.outputs import check_png
from unerode_cli.viz.landforms_plot import JunctionMark, SectionCurve, save_landforms_plot

#: Peak bytes per sample of one cross-section (positions along it, rows, columns, elevations,
#: the valley window and the interpolation's temporaries: about ten float64 values).
BYTES_PER_SECTION_SAMPLE = 80

JSON_NAME = "landforms.json"
PNG_NAME = "landforms.png"


@dataclass
class PlannedLandforms:
    """The DEM read, the elevations (m) of the DEM before erosion (None without ``before``)
    and the cells where water leaves the DEM."""

    terrain: Terrain
    before: np.ndarray | None
    outlets: np.ndarray


@dataclass
class MeasuredLandforms:
    """The landforms measured and the numbers of landforms.json."""

    landforms: Landforms
    numbers: dict[str, Any]


@declared("landforms", OPTIONS)
class LandformsJob(Job):
    """Measure the landforms of ``dem`` into the report folder ``out`` (created if missing);
    ``before``: the DEM before erosion, whose hypsometry is compared (any grid); ``outlets``:
    domain edges where water leaves ("all", "none" or e.g. "N,W"; nodata borders always drain).
    The other options are the :class:`Settings` of the measures (m)."""

    @property
    def settings(self) -> Settings:
        """How the landforms are measured (the remaining settings at their defaults)."""
        return Settings(spacing_m=self.spacing, half_width_m=self.half_width, reach_m=self.reach,
                        min_step_m=self.min_step, min_lake_depth_m=self.min_lake_depth)

    def report_files(self) -> dict[str, Path]:
        """landforms.json and landforms.png in the report folder, by name."""
        return {name: self.out / name for name in (JSON_NAME, PNG_NAME)}

    def plan(self, outputs: OutputPlan) -> PlannedLandforms:
        """Clear the report folder and its files, read the DEMs, check the settings and the
        outlets (InputError on a bad DEM or setting)."""
        for path in (self.dem, self.before):
            if path is not None:
                outputs.read(path)
        check_folder(self.out)
        if self.out.is_dir():
            files = self.report_files()
            outputs.check_output(files[JSON_NAME], self.overwrite)
            check_png(files[PNG_NAME], self.overwrite)
        terrain = read_terrain(self.dem, georef=input_georef(self))
        terrain.check_valid(self.dem)
        before = None
        if self.before is not None:
            earlier = read_terrain(self.before, georef=input_georef(self))
            earlier.check_valid(self.before)
            before = earlier.elevation
        try:
            self.settings.check()
            outlets = outlet_mask(terrain.grid, self.outlets)
        except ValueError as exc:
            raise InputError(f"{self.dem}: {exc}.") from None
        check_sections(self.spacing, self.half_width, terrain)
        return PlannedLandforms(terrain, before, outlets)

    def run(self, planned: PlannedLandforms,
            progress: Progress) -> tuple[PlannedLandforms, MeasuredLandforms]:
        """Measure, and print the short table of the measures (``measure<TAB>value`` lines)."""
        terrain = planned.terrain
        try:
            landforms = measure_landforms(terrain.elevation, terrain.grid, planned.outlets, planned.before,
                                          self.settings)
        except ValueError as exc:
            raise InputError(f"{self.dem}: {exc}.") from None
        numbers = summary(self, terrain, landforms)
        progress.data("measure\tvalue")
        for measure, value in table(numbers):
            progress.data(f"{measure}\t{value}")
        return planned, MeasuredLandforms(landforms, numbers)

    def write(self, result: tuple[PlannedLandforms, MeasuredLandforms], outputs: OutputPlan) -> str:
        planned, measured = result
        write_report(self, planned.terrain, measured)
        return f"report written to {self.out}/"


def check_sections(spacing: float, half_width: float, terrain: Terrain) -> None:
    """Refuse (InputError) cross-sections closer than one cell of ``terrain`` (``spacing``, m:
    they would sample the same cells again, and their number grows without bound), and a
    ``half_width`` (m) whose samples, one per cell size, do not fit in memory."""
    step = min(terrain.dx, terrain.dy)
    if spacing < step:
        raise InputError(f"--spacing {spacing:g} m is finer than the DEM's cells ({step:g} m), so its "
                         f"cross-sections would sample the same cells again; give at least {step:g} m.")
    samples = 2.0 * (half_width // step) + 1.0
    check_fits(samples * BYTES_PER_SECTION_SAMPLE,
               f"a cross-section of --half-width {half_width:g} m sampled every {step:g} m "
               f"({samples:.3g} samples)",
               "give a smaller --half-width (the valley's width is enough)")


def check_folder(folder: Path) -> None:
    """Refuse a report folder that is a file, or whose parent folder does not exist."""
    if folder.exists() and not folder.is_dir():
        raise InputError(f"the report folder {folder} is a file.")
    if not folder.exists() and not folder.parent.exists():
        raise InputError(f"the folder above the report folder {folder} does not exist.")


def _place(terrain: Terrain, row: float, col: float) -> dict[str, float]:
    """A cell position as row, col and x, y in the DEM's CRS (cell centres)."""
    x, y = terrain.transform * (col + 0.5, row + 0.5)
    return {"row": float(row), "col": float(col), "x": float(x), "y": float(y)}


def _hypsometry(result: Hypsometry | None) -> dict[str, float] | None:
    if result is None:
        return None
    return {"min_m": result.minimum_m, "max_m": result.maximum_m, "mean_m": result.mean_m,
            "mode_m": result.mode_m, "integral": result.integral}


def summary(job: LandformsJob, terrain: Terrain, landforms: Landforms) -> dict[str, Any]:
    """The numbers of landforms.json."""
    trunk, u_shape, hanging = landforms.trunk, landforms.u_shape, landforms.hanging
    hyps = landforms.hypsometry
    return {
        "dem": str(job.dem),
        "before": None if job.before is None else str(job.before),
        "grid": {"rows": terrain.shape[0], "cols": terrain.shape[1], "dx_m": terrain.dx, "dy_m": terrain.dy},
        "settings": asdict(job.settings) | {"outlets": job.outlets},
        "trunk": {"length_m": trunk.length, "cells": int(trunk.chainage.size), "source": trunk.source,
                  "mouth": _place(terrain, trunk.rows[0], trunk.cols[0]),
                  "head": _place(terrain, trunk.rows[-1], trunk.cols[-1])},
        "u_shape": {
            "median_b": u_shape.median_b,
            "sections_fitted": len(u_shape.sections),
            "sections_tried": u_shape.tried,
            "sections": [{"chainage_m": s.chainage_m, **_place(terrain, s.row, s.col), "b": s.b, "a": s.a,
                          "x0_m": s.x0_m, "z0_m": s.z0_m, "relief_m": s.relief_m, "width_m": s.width_m,
                          "rmse_m": s.rmse_m} for s in u_shape.sections],
        },
        "hanging_valleys": {
            "tributaries": len(hanging.junctions),
            "hanging": len(hanging.hanging),
            "min_area_m2": hanging.min_area_m2,
            "steps_m": hanging.steps_m,
            "junctions": [{"chainage_m": j.chainage_m, **_place(terrain, j.row, j.col), "area_m2": j.area_m2,
                           "length_m": j.length_m, "drop_m": j.drop_m, "trunk_gradient": j.trunk_gradient,
                           "step_m": j.step_m, "hanging": j.step_m >= hanging.min_step_m}
                          for j in hanging.junctions],
        },
        "lakes": asdict(landforms.lakes),
        "hypsometry": {"dem": _hypsometry(hyps.after), "before": _hypsometry(hyps.before),
                       "mode_shift_m": hyps.mode_shift_m, "mean_shift_m": hyps.mean_shift_m,
                       "integral_shift": hyps.integral_shift},
    }


def table(numbers: dict[str, Any]) -> list[tuple[str, str]]:
    """(measure, value) rows of the short table printed by the command."""
    u_shape, hanging, lakes = numbers["u_shape"], numbers["hanging_valleys"], numbers["lakes"]
    hyps = numbers["hypsometry"]
    median_b = f"{u_shape['median_b']:.2f}" if u_shape["sections_fitted"] else "-"
    steps = ", ".join(f"{step:.0f}" for step in hanging["steps_m"]) or "-"
    rows = [
        ("trunk length (m)", f"{numbers['trunk']['length_m']:.0f}"),
        ("U-shape exponent b, median", median_b),
        ("cross-sections fitted", f"{u_shape['sections_fitted']} of {u_shape['sections_tried']}"),
        ("tributaries / hanging", f"{hanging['tributaries']} / {hanging['hanging']}"),
        ("tributary steps (m)", steps),
        ("lakes", f"{lakes['count']}"),
        ("lake area (m²)", f"{lakes['area_m2']:.4g}"),
        ("lake volume (m³)", f"{lakes['volume_m3']:.4g}"),
        ("largest lake (m²)", f"{lakes['largest_area_m2']:.4g}"),
        ("hypsometric maximum (m)", f"{hyps['dem']['mode_m']:.0f}"),
        ("hypsometric integral", f"{hyps['dem']['integral']:.3f}"),
    ]
    if hyps["before"] is not None:
        rows += [("hypsometric maximum before (m)", f"{hyps['before']['mode_m']:.0f}"),
                 ("shift of the maximum (m)", f"{hyps['mode_shift_m']:+.0f}"),
                 ("shift of the integral", f"{hyps['integral_shift']:+.3f}")]
    return rows


def write_report(job: LandformsJob, terrain: Terrain, measured: MeasuredLandforms) -> None:
    """Write landforms.json and landforms.png (cleared by the plan) in the report folder,
    atomically."""
    landforms = measured.landforms
    files = job.report_files()
    job.out.mkdir(exist_ok=True)
    write_json(files[JSON_NAME], measured.numbers)
    labels, _ = lake_labels(landforms.lake_depth, job.min_lake_depth)
    sections = [SectionCurve(s.rows, s.cols, s.distance_m, s.elevation_m, s.fitted(s.distance_m), s.z0_m,
                             s.chainage_m, s.b) for s in landforms.u_shape.sections]
    marks = [JunctionMark(j.row, j.col, j.chainage_m, j.step_m, j.step_m >= landforms.hanging.min_step_m)
             for j in landforms.hanging.junctions]
    hyps = landforms.hypsometry
    curves = [(job.dem.name, hyps.after.centres, hyps.after.fraction)]
    if hyps.before is not None and job.before is not None:
        curves.insert(0, (f"{job.before.name} (before)", hyps.before.centres, hyps.before.fraction))
    shape = "no cross-section fitted"
    if sections:
        shape = f"b = {landforms.u_shape.median_b:.2f} (median of {len(sections)} sections)"
    title = (f"{job.dem.name}: {shape}, {len(landforms.hanging.hanging)} hanging of {len(marks)} "
             f"tributaries, {landforms.lakes.count} lakes")
    with atomic_path(files[PNG_NAME]) as tmp:
        save_landforms_plot(tmp, terrain.elevation, terrain.dx, terrain.dy,
                            np.where(labels > 0, landforms.lake_depth, 0.0), landforms.trunk.rows,
                            landforms.trunk.cols, sections, marks, curves, title)
