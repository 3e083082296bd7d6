"""The sections of an ensemble's report (``ensemble.json`` in the run folder):

* **Ensemble**: the spec, how each parameter is swept, the members finished and failed;
* **Members, best first**: the ranking of members.csv, values with their ``${var}`` references
  replaced and paths resolved (:mod:`.spec_values`);
* **Failures**;
* **Summary maps**: for each raster the members wrote (``summary/STEM_p50.tif``), the median and
  the standard deviation of the members, and the past minus the present DEM of the median and of
  the best member, on the axes of the raster's CRS;
* **Terrace fits**: the spread across the members of the simulated height at each dated
  terrace (table and plot), the best and the median member's long profiles, and a link to every
  member's profiles;
* **Parameters against scores**: the matrix of every pair of swept parameters coloured by the
  score, and each parameter against the scores (``summary/scatter_KEY.png``).
"""

from __future__ import annotations

import math
import os
import urllib.parse
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.ensemble.summary import median_position, value_spread
from unerode_cli.io.ensemble_files import (
    ENSEMBLE_FILE,
    FAILURES_FILE,
    MEMBERS_TABLE,
    SUMMARY_FOLDER,
    read_record,
)
from unerode_cli.io.provenance import sidecar_path
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.report_files import read_png, read_rows
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.report.maps import field_png, relief_png
from unerode_cli.jobs.report.spec_values import SpecValues
from unerode_cli.run.outputs import AGE_TAG
from unerode_cli.viz.ensemble_plots import save_pair_matrix
from unerode_cli.viz.report_html import Figure, Link, Section, Table, png_bytes
from unerode_cli.viz.terrace_plots import save_terrace_spread_plot

#: Rows of members.csv shown in an ensemble's ranking.
RANKING_ROWS = 25
#: The scores of members.csv that rank the members (the first one given), with their labels.
SCORES = {"terrace_rmse_m": "terrace RMSE (m)", "incision_rmse_mm_per_ka": "incision-rate error (mm/ka)"}


@dataclass
class EnsembleRun:
    """What the report reads of an ensemble in ``folder``; links are made relative to
    ``page_dir``, the folder of the page."""

    folder: Path
    page_dir: Path

    @cached_property
    def record(self) -> dict[str, Any]:
        return read_record(self.folder / ENSEMBLE_FILE) or {}

    @cached_property
    def values(self) -> SpecValues:
        return SpecValues.of(self.record, self.folder)

    @cached_property
    def table(self) -> tuple[list[str], list[dict[str, str]]]:
        path = self.folder / MEMBERS_TABLE
        return read_rows(path) if path.exists() else ([], [])

    @property
    def rows(self) -> list[dict[str, str]]:
        """members.csv's rows, best first."""
        return self.table[1]

    @cached_property
    def ranked(self) -> list[dict[str, str]]:
        return [r for r in self.rows if r.get("rank")]

    @cached_property
    def score(self) -> str | None:
        """The column that ranks the members (None when no member is scored)."""
        return next((k for k in SCORES if any(_float(r.get(k)) is not None for r in self.rows)), None)

    def member_dir(self, row: dict[str, str]) -> Path:
        return self.folder / row.get("folder", "")

    def terrace_report(self, row: dict[str, str]) -> tuple[Path, dict[str, Any]] | None:
        """The member's first compare-terraces report folder and its summary.json."""
        folder = self.member_dir(row)
        for summary in [folder / "summary.json", *sorted(folder.glob("*/summary.json"))]:
            record = read_record(summary) if summary.is_file() else None
            if record is not None and "terraces" in record:
                return summary.parent, record
        return None

    def link(self, target: Path, text: str) -> Link:
        """A link from the page to ``target``."""
        relative = Path(os.path.relpath(target.resolve(), self.page_dir.resolve())).as_posix()
        return Link(text, urllib.parse.quote(relative))


def ensemble_sections(folder: Path, page_dir: Path | None = None) -> list[Section]:
    """The sections of the ensemble in ``folder`` (see the module docstring)."""
    run = EnsembleRun(folder, page_dir if page_dir is not None else folder)
    sections = [_overview(run), _ranking(run), _failures(run), _summary_maps(run), _terrace_fits(run),
                _parameters(run)]
    return [s for s in sections if s is not None]


def _overview(run: EnsembleRun) -> Section:
    record, values = run.record, run.values
    finished = sum(r.get("status") == "finished" for r in run.rows)
    overview = Section("Ensemble")
    overview.blocks.append(Table(["", ""], [
        ["spec", values.shown(record.get("spec", "?"))], ["run folder", str(run.folder.resolve())],
        ["members", len(record.get("members", []))], ["finished", finished],
        ["failed", len(run.rows) - finished], ["seed", record.get("seed")],
        ["Latin hypercube samples", record.get("samples") or "none (grid only)"]]))
    keys = record.get("keys", [])
    if keys:
        overview.blocks.append(Table(["swept parameter", "swept as"],
                                     [[k, values.swept_as(k)] for k in keys], "The sweep"))
    return overview


def _ranking(run: EnsembleRun) -> Section | None:
    columns, rows = run.table
    if not rows:
        return None
    ranking = Section("Members, best first")
    ranking.blocks.append("Ranked by the terrace RMSE of compare-terraces (else the incision-rate error); "
                          "members.csv has every member. Paths are resolved, relative to the run folder "
                          "when inside it.")
    keys = set(run.record.get("keys", []))
    shown = [[_cell(run.values.shown(r.get(c)) if c in keys else r.get(c)) for c in columns]
             for r in rows[:RANKING_ROWS]]
    ranking.blocks.append(Table(columns, shown, f"The first {len(shown)} of {len(rows)} members"))
    return ranking


def _failures(run: EnsembleRun) -> Section | None:
    path = run.folder / FAILURES_FILE
    if not path.exists():
        return None
    columns, failures = read_rows(path)
    if not failures:
        return None
    failed = Section("Failures")
    failed.blocks.append(Table(columns, [[run.values.shown(r.get(c)) for c in columns] for r in failures]))
    return failed


# ---------------------------------------------------------------------------------------------
# Summary maps

def _summary_maps(run: EnsembleRun) -> Section | None:
    """One subsection per summarised raster: snapshots by age, then the others by name."""
    medians = [(p, read_terrain(p)) for p in (run.folder / SUMMARY_FOLDER).glob("*_p50.tif")]
    if not medians:
        return None
    maps = Section("Summary maps")
    maps.blocks.append("For each raster that every member wrote: the median and the standard deviation "
                       "of the members cell by cell (summary/STEM_p50.tif, STEM_std.tif; the 5 and 95 "
                       "percentiles and the mean are beside them), and the past minus the present DEM of "
                       "the median and of the best member. Axes in the raster's CRS.")
    medians.sort(key=lambda item: (0, _age(item[1]), "") if AGE_TAG in item[1].tags
                 else (1, 0.0, item[0].name))
    for path, median in medians:
        maps.subsections.append(_raster_maps(run, path, median))
    return maps


def _raster_maps(run: EnsembleRun, median_path: Path, median: Terrain) -> Section:
    """The maps of one summarised raster (``STEM_p50.tif``): median, spread and, for an
    elevation, the median's and the best member's past minus the present DEM; a change map's
    median is drawn in diverging colours over the present's relief."""
    stem = median_path.stem[: -len("_p50")]
    statistic = (read_record(sidecar_path(median_path)) or {}).get("parameters", {})
    of = Path(str(statistic.get("of", f"{stem}.tif")))
    finished = [r for r in run.rows if r.get("status") == "finished"]
    first = run.member_dir(finished[0]) / of if finished else None
    sidecar = (read_record(sidecar_path(first)) or {}) if first is not None and first.is_file() else {}
    change = str(sidecar.get("command", "")).endswith("change")
    age = f"{_age(median):g} ka" if AGE_TAG in median.tags else "no age"
    section = Section(f"{of.as_posix()} ({age}), {statistic.get('members', '?')} members")
    present_path = _present_path(run, first, sidecar)
    present = _on_grid(present_path, median)
    what = "change (m)" if change else "elevation (m)"
    caption = f"median {what} of the members ({stem}_p50)"
    if change:
        relief = present if present is not None else median
        png = field_png(median.elevation, relief, what, f"{stem}: median", diverging=True)
    else:
        relief = median
        png = relief_png(median, f"{stem}: median")
    section.blocks.append(Figure(png, caption))
    spread_path = median_path.with_name(f"{stem}_std.tif")
    if spread_path.exists():
        caption = f"standard deviation of the members' {what} ({stem}_std)"
        spread = read_terrain(spread_path).elevation
        section.blocks.append(Figure(field_png(spread, relief, "std (m)", f"{stem}: spread"), caption))
    if change:
        return section
    if present is None or present_path is None:
        section.blocks.append("No present DEM on this grid (neither a compare-terraces report nor an input "
                              "outside the members' folders): no past-minus-present map.")
        return section
    pasts = [("median", "median", median)]
    best = run.member_dir(run.ranked[0]) / of if run.ranked else None
    if best is not None and best.is_file() and (member := read_terrain(best)).shape == present.shape:
        name = f"member {run.ranked[0].get('member')}"
        pasts.append((f"best member ({name}, {of.as_posix()})", f"best, {name}", member))
    for label, short, past in pasts:
        caption = f"{label} minus the present DEM {present_path.name}; red: the past surface above today's"
        png = field_png(past.elevation - present.elevation, present, "past − present (m)",
                        f"{stem}: {short} − present", diverging=True)
        section.blocks.append(Figure(png, caption))
    return section


def _present_path(run: EnsembleRun, first: Path | None, sidecar: dict[str, Any]) -> Path | None:
    """The present DEM of the members: their compare-terraces report's, else the input of the
    raster (``sidecar`` of the first member's) when it lies outside the member's folder (not
    an output of an earlier step)."""
    finished = [r for r in run.rows if r.get("status") == "finished"]
    report = run.terrace_report(finished[0]) if finished else None
    if report is not None and report[1].get("present"):
        return Path(str(report[1]["present"]))
    given = sidecar.get("parameters", {}).get("input")
    if first is None or not given:
        return None
    path = Path(str(given))
    path = path if path.is_absolute() else first.parent / path
    return None if path.resolve().is_relative_to(first.parent.resolve()) else path


def _on_grid(path: Path | None, median: Terrain) -> Terrain | None:
    """The raster at ``path`` when it exists on the median's grid, else None."""
    if path is None or not path.is_file():
        return None
    present = read_terrain(path)
    return present if present.shape == median.shape else None


# ---------------------------------------------------------------------------------------------
# Terrace fits and parameters

def _terrace_fits(run: EnsembleRun) -> Section | None:
    """The spread of the simulated heights at each terrace, the best and median members'
    profiles, and a link to each member's."""
    fits = [(row, *found) for row in run.ranked if (found := run.terrace_report(row)) is not None]
    if not fits:
        return None
    section = Section("Terrace fits")
    terraces = fits[0][2]["terraces"].get("rows", [])
    if terraces:
        section.blocks += _terrace_spread(fits, terraces)
    chosen = [("best member", fits[0])]
    middle = fits[median_position(len(fits))]
    if middle is not fits[0]:
        chosen.append(("median member", middle))
    for label, (row, report, _summary) in chosen:
        if (report / "profiles.png").is_file():
            caption = (f"{label}: {row.get('member')} (rank {row.get('rank')}, {_score_text(run, row)}), "
                       f"{(report / 'profiles.png').relative_to(run.folder).as_posix()}")
            section.blocks.append(Figure(read_png(report / "profiles.png"), caption))
    links = [[_cell(row.get("rank")), row.get("member"), _cell(row.get(run.score or "")),
              *(run.link(report / name, name) if (report / name).is_file() else ""
                for name in ("profiles.png", "terraces.csv"))]
             for row, report, _summary in fits]
    columns = ["rank", "member", SCORES.get(run.score or "", "score"), "profiles", "terraces"]
    section.blocks.append(Table(columns, links, "Every member's terrace fit (files in the run folder)"))
    return section


def _terrace_spread(fits: list, terraces: list[dict[str, Any]]) -> list:
    """Table and plot of the members' simulated heights at each terrace (rows matched by their
    line in the observations)."""
    lines = [t.get("line") for t in terraces]
    values = np.full((len(lines), len(fits)), np.nan)
    for j, (_row, _report, summary) in enumerate(fits):
        by_line = {t.get("line"): t.get("simulated_m") for t in summary["terraces"].get("rows", [])}
        for i, line in enumerate(lines):
            simulated = by_line.get(line)
            values[i, j] = simulated if isinstance(simulated, int | float) else np.nan
    rows = []
    for i, terrace in enumerate(terraces):
        spread = value_spread(list(values[i])) or {}
        rows.append([terrace.get("name"), terrace.get("age_ka"), terrace.get("observed_m"),
                     terrace.get("uncertainty_m"), spread.get("p50"), spread.get("p5"), spread.get("p95"),
                     spread.get("min"), spread.get("max"), spread.get("std"), _float(values[i, 0]),
                     spread.get("members", 0)])
    columns = ["terrace", "age (ka)", "observed (m)", "± (m)", "median (m)", "p5 (m)", "p95 (m)", "min (m)",
               "max (m)", "std (m)", "best member (m)", "members"]
    labels = [f"{t.get('name') or t.get('line')}\n{_finite(t.get('age_ka')):g} ka" for t in terraces]
    observed = np.array([_finite(t.get("observed_m")) for t in terraces], dtype=np.float64)
    uncertainty = np.array([_finite(t.get("uncertainty_m")) for t in terraces], dtype=np.float64)
    title = "past riverbed at each dated terrace, all members"
    plot = png_bytes(lambda f: save_terrace_spread_plot(f, labels, observed, uncertainty, values,
                                                        values[:, 0], title))
    return ["The simulated height of the past riverbed above today's river at each dated terrace, across "
            "the members that compared it (compare-terraces' simulated_m).",
            Table(columns, rows, "Past height at each terrace across the members"),
            Figure(plot, "members' simulated height at each terrace against the observation")]


def _parameters(run: EnsembleRun) -> Section | None:
    """The pair matrix of the swept parameters coloured by the score, and the scatter plots."""
    section = Section("Parameters against scores")
    keys = [k for k in run.record.get("keys", []) if k in run.table[0]]
    finished = [r for r in run.rows if r.get("status") == "finished"]
    if len(keys) >= 2 and run.score is not None and finished:
        parameters = {k: _axis_values([run.values.shown(r.get(k)) for r in finished]) for k in keys}
        scores = [_float(r.get(run.score)) for r in finished]
        best = next((i for i, r in enumerate(finished) if r.get("rank") == "1"), None)
        label = SCORES[run.score]
        png = png_bytes(lambda f: save_pair_matrix(f, parameters, label, scores, run.values.log_keys(), best))
        caption = (f"every pair of swept parameters, each member coloured by its {label} (diagonal: "
                   "the score against the parameter; red circle: the best member)")
        section.blocks.append(Figure(png, caption, wide=True))
    for png in sorted((run.folder / SUMMARY_FOLDER).glob("scatter_*.png")):
        section.blocks.append(Figure(read_png(png), f"{png.stem[len('scatter_'):]} against the scores"))
    return section if section.blocks else None


def _axis_values(values: list[Any]) -> list[Any]:
    """Numbers when every value is one, else the values as text (categories)."""
    numbers = [_float(v) for v in values]
    return numbers if all(n is not None for n in numbers) else [str(v) for v in values]


def _score_text(run: EnsembleRun, row: dict[str, str]) -> str:
    value = _float(row.get(run.score or ""))
    return f"{SCORES[run.score]} {value:.3g}" if run.score and value is not None else "no score"


def _age(terrain: Terrain) -> float:
    try:
        return float(terrain.tags.get(AGE_TAG, "nan"))
    except ValueError:
        return float("nan")


def _float(value: Any) -> float | None:
    """A finite number from a table cell (text), else None."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def _finite(value: Any) -> float:
    number = _float(value)
    return np.nan if number is None else number


def _cell(value: Any) -> Any:
    """A value for a table cell: numbers (text that reads as a non-integer number, e.g. 2e-05)
    as numbers; member numbers and other text as they are."""
    if isinstance(value, str) and value and not value.isdigit():
        number = _float(value)
        return number if number is not None else value
    return value
