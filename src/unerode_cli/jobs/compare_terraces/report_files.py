"""The report folder of `compare-terraces`: terraces.csv, profiles.csv, summary.json,
profiles.png, and with incision rates incision.csv and incision.png."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.analysis.history import RiverHistory
from unerode_cli.analysis.incision import IncisionResult
from unerode_cli.analysis.terraces import TerraceResult
from unerode_cli.io.csv_tables import write_table
from unerode_cli.io.json_files import write_json
from unerode_cli.io.paths import atomic_path
from unerode_cli.viz.terrace_plots import Levels, save_incision_plot, save_profiles_plot

TERRACE_TABLE = ["line", "name", "age_ka", "chainage_m", "distance_to_river_m", "observed_m",
                 "uncertainty_m", "simulated_m", "residual_m", "within_uncertainty"]


def report_names(incision: bool) -> list[str]:
    """The files of a report (with those of incision rates when ``incision``)."""
    names = ["terraces.csv", "profiles.csv", "summary.json", "profiles.png"]
    return names + ["incision.csv", "incision.png"] if incision else names


def _optional(value: float | None) -> float | None:
    return None if value is None else float(value)


def terrace_rows(results: list[TerraceResult]) -> list[dict[str, Any]]:
    """One row per terrace: observed and simulated heights above today's riverbed (m)."""
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


def incision_rows(results: list[IncisionResult]) -> list[dict[str, Any]]:
    """One row per period: observed and simulated incision rates (mm/ka)."""
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


def write_report(folder: Path, name: str, summary: dict[str, Any], history: RiverHistory,
                 terrace_results: list[TerraceResult], with_incision: bool) -> None:
    """Write the report files (cleared by the plan) into ``folder`` (created if missing),
    atomically, those of incision rates ``with_incision``; ``name`` (the present DEM's file
    name) titles the plots."""
    folder.mkdir(exist_ok=True)
    rows = summary["terraces"]["rows"]
    write_table(folder / "terraces.csv", list(rows[0]) if rows else TERRACE_TABLE, rows)
    profile_columns = ["chainage_m"] + [f"height_{age:g}ka_m" for age in history.ages_ka]
    profile_rows = [dict(zip(profile_columns, values, strict=True))
                    for values in np.column_stack([history.chainage, history.heights.T]).tolist()]
    write_table(folder / "profiles.csv", profile_columns, profile_rows)
    write_json(folder / "summary.json", summary)
    levels = Levels(
        age_ka=np.array([r.terrace.age_ka for r in terrace_results]),
        chainage_m=np.array([np.nan if r.terrace.chainage_m is None else r.terrace.chainage_m
                             for r in terrace_results]),
        observed_m=np.array([r.terrace.height_m for r in terrace_results]),
        simulated_m=np.array([r.simulated_m for r in terrace_results]),
        uncertainty_m=np.array([np.nan if r.terrace.uncertainty_m is None else r.terrace.uncertainty_m
                                for r in terrace_results]),
    )
    title = f"{name}: riverbeds of {len(history.ages_ka) - 1} snapshots"
    with atomic_path(folder / "profiles.png") as tmp:
        save_profiles_plot(tmp, history.chainage, history.ages_ka, history.heights, levels, title)
    if with_incision:
        incision = summary["incision"]
        _write_incision(folder, name, incision["periods"], incision["snapshot_intervals"])


def _write_incision(folder: Path, name: str, periods: list[dict[str, Any]],
                    intervals: list[dict[str, Any]]) -> None:
    """incision.csv and incision.png: observed and simulated rates per period (mm/ka)."""
    write_table(folder / "incision.csv", list(periods[0]), periods)
    with atomic_path(folder / "incision.png") as tmp:
        save_incision_plot(
            tmp,
            np.array([[p["from_ka"], p["to_ka"]] for p in periods]),
            np.array([p["observed_mm_per_ka"] for p in periods]),
            np.array([np.nan if p["uncertainty_mm_per_ka"] is None else p["uncertainty_mm_per_ka"]
                      for p in periods]),
            np.array([p["simulated_mm_per_ka"] for p in periods]),
            np.array([[i["from_ka"], i["to_ka"]] for i in intervals]).reshape(-1, 2),
            np.array([i["simulated_mm_per_ka"] for i in intervals]),
            f"{name}: incision rates",
        )
