"""`compare-terraces`: simulated riverbeds of climate-run snapshots against dated terraces and
incision rates (000 §6.3). Reads the inputs, runs ``unerode_cli.analysis`` and writes the
report folder: terraces.csv, profiles.csv, incision.csv, summary.json, profiles.png and
incision.png."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.analysis.history import RiverHistory, river_history
from unerode_cli.analysis.incision import IncisionResult, compare_incision, snapshot_rates
from unerode_cli.analysis.river import (
    RiverPath,
    auto_river,
    bed_profile,
    downstream_first,
    path_from_vertices,
)
from unerode_cli.analysis.terraces import Terrace, TerraceResult, compare_terraces, fit
from unerode_cli.errors import InputError
from unerode_cli.hydro import outlet_mask
from unerode_cli.io.csv_tables import write_table
from unerode_cli.io.grid_rasters import read_on_grid
from unerode_cli.io.json_files import write_json
from unerode_cli.io.observation_files import TerraceRow, read_incision, read_terraces
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.river_files import read_river_line
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.outputs import AGE_TAG
from unerode_cli.viz.terrace_plots import Levels, save_incision_plot, save_profiles_plot

RASTER_SUFFIXES = (".tif", ".tiff", ".exr", ".vrt", ".img", ".asc")
_AGE_IN_NAME = re.compile(r"_(\d+(?:\.\d+)?)ka$")


@dataclass(frozen=True)
class TerraceJob:
    """What the user asked for.

    Attributes:
        present: today's DEM.
        snapshots: snapshot rasters or folders of them (ages from their UNERODE_AGE_KA tag, or
            from a name ending in ``_<age>ka``).
        out_dir: the report folder (created if missing).
        observations / incision: the observation tables (at least one).
        river: a river line file; None with ``auto_river``.
        river_start: (x, y) in the DEM's CRS where the automatic river starts, or None for the
            main stem of the largest catchment.
        min_area_fraction: the automatic main stem stops where its donors drain less than this
            share of the catchment.
        search_radius: the bed is the lowest cell within this distance of the river (m).
        uplift: rock uplift rate since each age (m/y), added back to the past beds.
        outlets, sea_level: where water leaves the present DEM (automatic river only).
    """

    present: Path
    snapshots: tuple[Path, ...]
    out_dir: Path
    observations: Path | None = None
    incision: Path | None = None
    river: Path | None = None
    auto_river: bool = False
    river_start: tuple[float, float] | None = None
    min_area_fraction: float = 0.01
    search_radius: float = 0.0
    uplift: float = 0.0
    outlets: str = "all"
    sea_level: float | None = None
    overwrite: bool = False

    def outputs(self) -> dict[str, Path]:
        names = ["terraces.csv", "profiles.csv", "summary.json", "profiles.png"]
        if self.incision is not None:
            names += ["incision.csv", "incision.png"]
        return {name: self.out_dir / name for name in names}


@dataclass(frozen=True)
class Report:
    """The numbers of a comparison (``summary`` is what summary.json holds)."""

    summary: dict[str, Any]
    outputs: dict[str, Path]

    @property
    def rmse_m(self) -> float:
        return self.summary["terraces"]["rmse_m"]


def _check_job(job: TerraceJob) -> None:
    if job.observations is None and job.incision is None:
        raise InputError("give --observations, --incision or both: there is nothing to compare.")
    if (job.river is None) == (not job.auto_river):
        raise InputError("give the river as --river LINE or ask for --auto-river (one of them).")
    if not job.snapshots:
        raise InputError("give at least one snapshot with --snapshots.")
    if not (np.isfinite(job.search_radius) and job.search_radius >= 0):
        raise InputError(f"--search-radius must be ≥ 0 m, got {job.search_radius:g}.")
    if not (np.isfinite(job.uplift)):
        raise InputError("--uplift must be a finite rate in m/y.")
    if not 0.0 < job.min_area_fraction < 1.0:
        raise InputError(f"--min-area-fraction must lie between 0 and 1, got {job.min_area_fraction:g}.")
    if job.out_dir.exists() and not job.out_dir.is_dir():
        raise InputError(f"the report folder {job.out_dir} is a file.")
    if job.out_dir.is_dir():
        for path in job.outputs().values():
            check_output(path, job.overwrite)
    elif not job.out_dir.parent.exists():
        raise InputError(f"the folder above the report folder {job.out_dir} does not exist.")


def snapshot_files(entries: tuple[Path, ...], present: Path) -> list[Path]:
    """The snapshot rasters: files as given, folders expanded to their rasters (the present
    DEM excluded), sorted by name."""
    files: list[Path] = []
    for entry in entries:
        if entry.is_dir():
            found = sorted(p for p in entry.iterdir() if p.suffix.lower() in RASTER_SUFFIXES
                           and not p.name.startswith(".") and p.resolve() != present.resolve())
            if not found:
                raise InputError(f"the snapshot folder {entry} holds no raster.")
            files += found
        elif entry.exists():
            files.append(entry)
        else:
            raise InputError(f"the snapshot {entry} does not exist.")
    return files


def snapshot_age(layer: Terrain, path: Path) -> float | None:
    """Age (ka) of a snapshot: its UNERODE_AGE_KA tag, else a name ending in ``_<age>ka``."""
    tag = layer.tags.get(AGE_TAG)
    if tag is not None:
        try:
            return float(tag)
        except ValueError:
            raise InputError(f"snapshot {path} has a malformed {AGE_TAG} tag '{tag}'.") from None
    match = _AGE_IN_NAME.search(path.stem)
    return float(match.group(1)) if match else None


def _cell_of(terrain: Terrain, x: float, y: float) -> tuple[float, float]:
    """(row, col) cell coordinates of the CRS point (x, y); cell centres are integers."""
    col, row = ~terrain.transform @ (x, y)
    return row - 0.5, col - 0.5


def _inside(terrain: Terrain, row: float, col: float) -> bool:
    ny, nx = terrain.shape
    return -0.5 <= row <= ny - 0.5 and -0.5 <= col <= nx - 0.5


def _river(job: TerraceJob, present: Terrain) -> RiverPath:
    grid = present.grid
    if job.river is not None:
        xs, ys = read_river_line(job.river)
        rows, cols = _cell_of(present, xs, ys)
        outside = ~(((rows >= -0.5) & (rows <= grid.shape[0] - 0.5))
                    & ((cols >= -0.5) & (cols <= grid.shape[1] - 0.5)))
        if outside.any():
            k = int(np.argmax(outside))
            raise InputError(f"vertex {k + 1} of the river line ({xs[k]:g}, {ys[k]:g}) lies outside the DEM.")
        try:
            path = path_from_vertices(rows, cols, grid.dx, grid.dy, min(grid.dx, grid.dy),
                                      f"line {job.river}")
        except ValueError as exc:
            raise InputError(f"{exc} ({job.river}).") from None
        return downstream_first(path, bed_profile(present.elevation, path, grid.dx, grid.dy,
                                                  job.search_radius))
    start = None
    if job.river_start is not None:
        row, col = _cell_of(present, *job.river_start)
        if not _inside(present, row, col):
            raise InputError(f"the river start {job.river_start} lies outside the DEM.")
        start = (int(round(row)), int(round(col)))
    try:
        outlets = outlet_mask(grid, job.outlets, elevation=present.elevation, sea_level=job.sea_level)
        return auto_river(present.elevation, grid, outlets, start, job.min_area_fraction)
    except ValueError as exc:
        raise InputError(f"{exc}.") from None


def _terraces(rows: list[TerraceRow], present: Terrain, river: RiverPath, source: Path) -> list[Terrace]:
    terraces = []
    for row in rows:
        chainage, distance = row.chainage_m, None
        if row.x is not None:
            r, c = _cell_of(present, row.x, row.y)
            if not _inside(present, r, c):
                raise InputError(
                    f"{source}, line {row.line}: the point ({row.x:g}, {row.y:g}) lies outside the DEM."
                )
            chainage, distance = river.locate(r, c, present.dx, present.dy)
        elif chainage is not None and chainage > river.length:
            raise InputError(f"{source}, line {row.line}: chainage {chainage:g} m is beyond the river's "
                             f"end ({river.length:.6g} m).")
        terraces.append(Terrace(row.line, row.age_ka, row.height_m, row.uncertainty_m, row.name,
                                chainage, distance))
    return terraces


def _history(job: TerraceJob, present: Terrain, river: RiverPath) -> tuple[RiverHistory, list[dict]]:
    beds, listed = [], []
    for path in snapshot_files(job.snapshots, job.present):
        layer = read_on_grid(path, present, "snapshot")
        age = snapshot_age(layer, path)
        if age is None:
            raise InputError(f"snapshot {path} has no age: it lacks the {AGE_TAG} tag of climate-run "
                             "and its name does not end in _<age>ka.")
        bed = bed_profile(layer.elevation, river, present.dx, present.dy, job.search_radius)
        if any(age == seen and np.array_equal(bed, other, equal_nan=True) for seen, other in beds):
            continue  # climate-run's final output repeats the snapshot at its age
        beds.append((age, bed))
        listed.append({"path": str(path), "age_ka": age})
    present_bed = bed_profile(present.elevation, river, present.dx, present.dy, job.search_radius)
    if not np.isfinite(present_bed).any():
        raise InputError("the river lies entirely on nodata cells of the present DEM.")
    try:
        history = river_history(river.chainage, present_bed, beds, job.uplift)
    except ValueError as exc:
        raise InputError(f"{exc}.") from None
    return history, sorted(listed, key=lambda item: item["age_ka"])


def _compared(source: Path, compare, history: RiverHistory, items: list) -> list:
    """``compare(history, items)``, its errors (which name a line) prefixed with the file."""
    try:
        return compare(history, items)
    except ValueError as exc:
        raise InputError(f"{source}, {exc}.") from None


def _optional(value: float | None) -> float | None:
    return None if value is None else float(value)


def _terrace_rows(results: list[TerraceResult]) -> list[dict[str, Any]]:
    return [{
        "line": r.terrace.line,
        "name": r.terrace.name,
        "age_ka": r.terrace.age_ka,
        "chainage_m": _optional(r.terrace.chainage_m),
        "distance_to_river_m": _optional(r.terrace.distance_m),
        "observed_m": r.terrace.height_m,
        "uncertainty_m": _optional(r.terrace.uncertainty_m),
        "simulated_m": r.simulated_m,
        "residual_m": r.residual_m,
        "within_uncertainty": r.within_uncertainty,
    } for r in results]


def _incision_rows(results: list[IncisionResult]) -> list[dict[str, Any]]:
    return [{
        "line": r.period.line,
        "name": r.period.name,
        "from_ka": r.period.old_ka,
        "to_ka": r.period.young_ka,
        "observed_mm_per_ka": r.period.rate_mm_per_ka,
        "uncertainty_mm_per_ka": _optional(r.period.uncertainty_mm_per_ka),
        "simulated_mm_per_ka": r.simulated_mm_per_ka,
        "residual_mm_per_ka": r.residual_mm_per_ka,
    } for r in results]


def run_compare(job: TerraceJob) -> Report:
    """Compare and write the report; returns its numbers. Raises InputError on bad input
    (before anything is written)."""
    _check_job(job)
    present = read_terrain(job.present)
    present.check_valid(job.present)
    river = _river(job, present)
    history, listed = _history(job, present, river)
    terrace_results, incision_results = [], []
    if job.observations is not None:
        terraces = _terraces(read_terraces(job.observations), present, river, job.observations)
        terrace_results = _compared(job.observations, compare_terraces, history, terraces)
    if job.incision is not None:
        incision_results = _compared(job.incision, compare_incision, history, read_incision(job.incision))
    old, young, rates = snapshot_rates(history)
    overall = fit(terrace_results)
    summary = {
        "present": str(job.present),
        "snapshots": listed,
        "river": {"source": river.source, "length_m": river.length, "samples": int(river.chainage.size),
                  "search_radius_m": job.search_radius},
        "uplift_m_per_y": job.uplift,
        "terraces": {"count": overall.count, "rmse_m": overall.rmse_m, "bias_m": overall.bias_m,
                     "within_uncertainty": overall.within, "with_uncertainty": overall.with_uncertainty,
                     "rows": _terrace_rows(terrace_results)},
        "incision": {"periods": _incision_rows(incision_results),
                     "snapshot_intervals": [
                         {"from_ka": float(o), "to_ka": float(y), "simulated_mm_per_ka": float(r)}
                         for o, y, r in zip(old, young, rates, strict=True)]},
    }
    outputs = job.outputs()
    job.out_dir.mkdir(exist_ok=True)
    _write_report(job, summary, history, terrace_results, outputs)
    return Report(summary, outputs)


def _write_report(job: TerraceJob, summary: dict[str, Any], history: RiverHistory,
                  terrace_results: list[TerraceResult], outputs: dict[str, Path]) -> None:
    rows = summary["terraces"]["rows"]
    write_table(outputs["terraces.csv"], list(rows[0]) if rows else
                ["line", "name", "age_ka", "chainage_m", "distance_to_river_m", "observed_m",
                 "uncertainty_m", "simulated_m", "residual_m", "within_uncertainty"], rows)
    profile_columns = ["chainage_m"] + [f"height_{age:g}ka_m" for age in history.ages_ka]
    profile_rows = [dict(zip(profile_columns, values, strict=True))
                    for values in np.column_stack([history.chainage, history.heights.T]).tolist()]
    write_table(outputs["profiles.csv"], profile_columns, profile_rows)
    write_json(outputs["summary.json"], summary)
    title = f"{job.present.name}: riverbeds of {len(history.ages_ka) - 1} snapshots"
    levels = Levels(
        age_ka=np.array([r.terrace.age_ka for r in terrace_results]),
        chainage_m=np.array([np.nan if r.terrace.chainage_m is None else r.terrace.chainage_m
                             for r in terrace_results]),
        observed_m=np.array([r.terrace.height_m for r in terrace_results]),
        simulated_m=np.array([r.simulated_m for r in terrace_results]),
        uncertainty_m=np.array([np.nan if r.terrace.uncertainty_m is None else r.terrace.uncertainty_m
                                for r in terrace_results]),
    )
    with atomic_path(outputs["profiles.png"]) as tmp:
        save_profiles_plot(tmp, history.chainage, history.ages_ka, history.heights, levels, title)
    if "incision.csv" in outputs:
        periods = summary["incision"]["periods"]
        write_table(outputs["incision.csv"], list(periods[0]), periods)
        intervals = summary["incision"]["snapshot_intervals"]
        with atomic_path(outputs["incision.png"]) as tmp:
            save_incision_plot(
                tmp,
                np.array([[p["from_ka"], p["to_ka"]] for p in periods]),
                np.array([p["observed_mm_per_ka"] for p in periods]),
                np.array([np.nan if p["uncertainty_mm_per_ka"] is None else p["uncertainty_mm_per_ka"]
                          for p in periods]),
                np.array([p["simulated_mm_per_ka"] for p in periods]),
                np.array([[i["from_ka"], i["to_ka"]] for i in intervals]).reshape(-1, 2),
                np.array([i["simulated_mm_per_ka"] for i in intervals]),
                f"{job.present.name}: incision rates",
            )
