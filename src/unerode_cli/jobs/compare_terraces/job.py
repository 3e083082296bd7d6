"""The `compare-terraces` job: simulated riverbeds of climate-run snapshots against dated
terraces and incision rates (000 §6.3). Reads the inputs (:mod:`.inputs`), runs
``unerode_cli.analysis`` and writes the report folder (:mod:`.report_files`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.analysis.history import RiverHistory, river_history
from unerode_cli.analysis.incision import IncisionPeriod, compare_incision, snapshot_rates
from unerode_cli.analysis.river import RiverPath, bed_profile
from unerode_cli.analysis.terraces import Terrace, TerraceResult, compare_terraces, fit
from unerode_cli.errors import InputError
from unerode_cli.io.observation_files import read_incision, read_terraces
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.compare_terraces.inputs import (
    expanded,
    main_river,
    parse_point,
    placed_terraces,
    river_from_line,
    snapshot_beds,
    snapshot_files,
)
from unerode_cli.jobs.compare_terraces.options import EXIT_ABOVE_THRESHOLD, OPTIONS
from unerode_cli.jobs.compare_terraces.report_files import (
    incision_rows,
    report_names,
    terrace_rows,
    write_report,
)
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress, Summary


@dataclass
class PlannedComparison:
    """Everything read: the present DEM, the river along which heights are compared, today's
    riverbed (m), the (age ka, riverbed m) of each snapshot and the snapshots used, the observed
    terraces placed along the river and the observed incision periods."""

    present: Terrain
    river: RiverPath
    present_bed: np.ndarray
    beds: list[tuple[float, np.ndarray]]
    snapshots: list[dict[str, Any]]
    terraces: list[Terrace]
    periods: list[IncisionPeriod]


@dataclass
class Comparison:
    """The numbers of summary.json, the heights of past riverbeds above today's and the
    simulated height of each terrace."""

    summary: dict[str, Any]
    history: RiverHistory
    terrace_results: list[TerraceResult]


@declared("compare-terraces", OPTIONS)
class TerraceJob(Job):
    """Compare the riverbeds of the ``snapshots`` (rasters, folders of them or glob patterns;
    ages from their UNERODE_AGE_KA tag, or from a name ending in ``_<age>ka``) with today's
    (``present``) along a river (``river``, a line file, or ``auto_river`` from
    ``river_start``, X,Y in the DEM's CRS), against the ``observations`` (terraces) and
    ``incision`` rates; ``uplift`` (m/y) is added back to the past beds. The report goes to the
    folder ``out`` (created if missing); ``fail_above`` (m) makes a larger terrace RMSE end the
    command with exit code 3."""

    def report_files(self) -> list[Path]:
        return [self.out / name for name in report_names(self.incision is not None)]

    def plan(self, outputs: OutputPlan) -> PlannedComparison:
        """Check the options, clear the report files, then read the present DEM, the river, the
        riverbed of each snapshot and the observations (InputError on any bad input)."""
        entries = expanded(self.snapshots)
        for path in (self.present, self.observations, self.incision, self.river, *entries):
            if path is not None:
                outputs.read(path)
        self._check()
        if self.out.exists() and not self.out.is_dir():
            raise InputError(f"the report folder {self.out} is a file.")
        if self.out.is_dir():
            for path in self.report_files():
                outputs.check_output(path, self.overwrite)
        elif not self.out.parent.exists():
            raise InputError(f"the folder above the report folder {self.out} does not exist.")
        georef = input_georef(self)
        present = read_terrain(self.present, georef=georef)
        present.check_valid(self.present)
        # a radius past the DEM's diagonal reaches no further cell than the diagonal itself
        ny, nx = present.shape
        radius = min(self.search_radius, float(np.hypot(ny * present.dy, nx * present.dx)))
        if self.river is not None:
            river = river_from_line(self.river, present, radius)
        else:
            river = main_river(present, parse_point(self.river_start), self.outlets, self.sea_level,
                               self.min_area_fraction)
        files = snapshot_files(entries, self.present)
        beds, listed = snapshot_beds(files, present, river, radius, georef)
        present_bed = bed_profile(present.elevation, river, present.dx, present.dy, radius)
        if not np.isfinite(present_bed).any():
            raise InputError("the river lies entirely on nodata cells of the present DEM.")
        terraces = ([] if self.observations is None else
                    placed_terraces(read_terraces(self.observations), present, river, self.observations))
        periods = [] if self.incision is None else read_incision(self.incision)
        return PlannedComparison(present, river, present_bed, beds, listed, terraces, periods)

    def _check(self) -> None:
        """Refuse options that contradict each other or are out of range."""
        if self.fail_above is not None and self.observations is None:
            raise InputError("--fail-above gates the terrace RMSE: it needs --observations.")
        if self.observations is None and self.incision is None:
            raise InputError("give --observations, --incision or both: there is nothing to compare.")
        if (self.river is None) == (not self.auto_river):
            raise InputError("give the river as --river LINE or ask for --auto-river (one of them).")
        if not self.snapshots:
            raise InputError("give at least one snapshot with --snapshots.")
        if not (np.isfinite(self.search_radius) and self.search_radius >= 0):
            raise InputError(f"--search-radius must be ≥ 0 m, got {self.search_radius:g}.")
        if not (np.isfinite(self.uplift)):
            raise InputError("--uplift must be a finite rate in m/y.")
        if not 0.0 < self.min_area_fraction < 1.0:
            raise InputError(f"--min-area-fraction must lie between 0 and 1, got {self.min_area_fraction:g}.")

    def run(self, planned: PlannedComparison, progress: Progress) -> Comparison:
        """Heights of the past beds, the simulated terraces and incision rates, their fit;
        prints the terraces' RMSE and each period's rates."""
        try:
            history = river_history(planned.river.chainage, planned.present_bed, planned.beds, self.uplift)
        except ValueError as exc:
            raise InputError(f"{exc}.") from None
        terrace_results: list[TerraceResult] = []
        incision_results = []
        if self.observations is not None:
            terrace_results = _compared(self.observations, compare_terraces, history, planned.terraces)
        if self.incision is not None:
            incision_results = _compared(self.incision, compare_incision, history, planned.periods)
        old, young, rates = snapshot_rates(history)
        overall = fit(terrace_results)
        river = planned.river
        present = planned.present
        summary = {
            "present": str(self.present),
            "grid": {"crs_wkt": present.crs_wkt, "transform": list(present.transform)[:6],
                     "cell_size_m": [present.dx, present.dy]},
            "snapshots": planned.snapshots,
            "river": {"source": river.source, "length_m": river.length, "samples": int(river.chainage.size),
                      "search_radius_m": self.search_radius},
            "uplift_m_per_y": self.uplift,
            "terraces": {"count": overall.count, "rmse_m": overall.rmse_m, "bias_m": overall.bias_m,
                         "within_uncertainty": overall.within, "with_uncertainty": overall.with_uncertainty,
                         "rows": terrace_rows(terrace_results)},
            "incision": {"periods": incision_rows(incision_results),
                         "snapshot_intervals": [
                             {"from_ka": float(o), "to_ka": float(y), "simulated_mm_per_ka": float(r)}
                             for o, y, r in zip(old, young, rates, strict=True)]},
        }
        _print_fit(summary, progress)
        return Comparison(summary, history, terrace_results)

    def write(self, result: Comparison, outputs: OutputPlan) -> Summary:
        """Write the report; the summary ends the command with exit code 3 when the terrace
        RMSE is above ``fail_above``."""
        write_report(self.out, self.present.name, result.summary, result.history, result.terrace_results,
                     self.incision is not None)
        text = f"report written to {self.out}/"
        rmse = result.summary["terraces"]["rmse_m"]
        if self.fail_above is not None and rmse > self.fail_above:
            return Summary(f"{text}; terrace RMSE {rmse:.3g} m is above --fail-above {self.fail_above:g} m.",
                           EXIT_ABOVE_THRESHOLD)
        return Summary(text)


def _compared(source: Path, compare: Callable[[RiverHistory, list], list], history: RiverHistory,
              items: list) -> list:
    """``compare(history, items)``, its errors (which name a line) prefixed with the file."""
    try:
        return compare(history, items)
    except ValueError as exc:
        raise InputError(f"{source}, {exc}.") from None


def _print_fit(summary: dict[str, Any], progress: Progress) -> None:
    """The terraces' RMSE, bias and agreement, and each period's simulated and observed rate."""
    terraces = summary["terraces"]
    if terraces["count"]:
        progress.data(f"terraces: {terraces['count']}, RMSE {terraces['rmse_m']:.3g} m, "
                      f"bias {terraces['bias_m']:+.3g} m, within uncertainty "
                      f"{terraces['within_uncertainty']} of {terraces['with_uncertainty']}")
    for period in summary["incision"]["periods"]:
        progress.data(f"incision {period['from_ka']:g}-{period['to_ka']:g} ka: simulated "
                      f"{period['simulated_mm_per_ka']:.3g} mm/ka, observed "
                      f"{period['observed_mm_per_ka']:.3g} mm/ka")
