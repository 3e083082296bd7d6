"""`landforms`: glacial landform measures of a DEM (001 §7.1, Fig. 15) — U-shape of the main
valley's cross-sections, hanging tributaries, lakes, hypsometry and its shift from an earlier
DEM. Reads the DEMs, runs :mod:`unerode_cli.analysis.landforms` and writes the report folder:
landforms.json and landforms.png."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.analysis.hypsometry import Hypsometry
from unerode_cli.analysis.landforms import Landforms, Settings, measure_landforms
from unerode_cli.errors import InputError
from unerode_cli.hydro import outlet_mask
from unerode_cli.hydro.depressions import lake_labels
from unerode_cli.io.json_files import write_json
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.outputs import check_png
from unerode_cli.viz.landforms_plot import JunctionMark, SectionCurve, save_landforms_plot

JSON_NAME = "landforms.json"
PNG_NAME = "landforms.png"


@dataclass(frozen=True)
class LandformsJob:
    """What the user asked for.

    Attributes:
        dem: the DEM measured.
        out_dir: the report folder (created if missing).
        before: the DEM before erosion, whose hypsometry is compared (any grid), or None.
        outlets: domain edges where water leaves ("all", "none" or e.g. "N,W"); nodata borders
            always drain.
        settings: how the landforms are measured.
        overwrite: replace existing reports.
    """

    dem: Path
    out_dir: Path
    before: Path | None = None
    outlets: str = "all"
    settings: Settings = field(default_factory=Settings)
    overwrite: bool = False

    def outputs(self) -> dict[str, Path]:
        return {name: self.out_dir / name for name in (JSON_NAME, PNG_NAME)}

    def inputs(self) -> tuple[Path, ...]:
        return (self.dem,) if self.before is None else (self.dem, self.before)


def check_outputs(job: LandformsJob) -> None:
    """Refuse, before any DEM is read, a report folder that is a file or has no parent folder,
    and reports that exist (without ``overwrite``) or are inputs."""
    if job.out_dir.exists() and not job.out_dir.is_dir():
        raise InputError(f"the report folder {job.out_dir} is a file.")
    if job.out_dir.is_dir():
        outputs = job.outputs()
        check_output(outputs[JSON_NAME], job.overwrite, job.inputs())
        check_png(outputs[PNG_NAME], job.overwrite, job.inputs())
    elif not job.out_dir.parent.exists():
        raise InputError(f"the folder above the report folder {job.out_dir} does not exist.")


def compute(job: LandformsJob) -> tuple[Terrain, Landforms]:
    """Read the DEMs and measure (InputError on a bad DEM or setting)."""
    terrain = read_terrain(job.dem)
    terrain.check_valid(job.dem)
    before = None
    if job.before is not None:
        earlier = read_terrain(job.before)
        earlier.check_valid(job.before)
        before = earlier.elevation
    try:
        job.settings.check()
        outlets = outlet_mask(terrain.grid, job.outlets)
        return terrain, measure_landforms(terrain.elevation, terrain.grid, outlets, before, job.settings)
    except ValueError as exc:
        raise InputError(f"{job.dem}: {exc}.") from None


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


def write(job: LandformsJob, terrain: Terrain, landforms: Landforms) -> dict[str, Any]:
    """Write landforms.json and landforms.png (cleared by :func:`check_outputs`), atomically;
    returns the numbers written."""
    numbers = summary(job, terrain, landforms)
    outputs = job.outputs()
    job.out_dir.mkdir(exist_ok=True)
    write_json(outputs[JSON_NAME], numbers)
    labels, _ = lake_labels(landforms.lake_depth, job.settings.min_lake_depth_m)
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
    with atomic_path(outputs[PNG_NAME]) as tmp:
        save_landforms_plot(tmp, terrain.elevation, terrain.dx, terrain.dy,
                            np.where(labels > 0, landforms.lake_depth, 0.0), landforms.trunk.rows,
                            landforms.trunk.cols, sections, marks, curves, title)
    return numbers
