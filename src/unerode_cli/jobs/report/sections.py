"""The sections of a report: what unerode-cli wrote in a run folder, found by the files it
writes (:func:`find_sources`), and the section of each (:func:`build_sections`):

* an **ensemble** (``ensemble.json``): the sections of :mod:`.ensemble`;
* each **climate-run** (``STEM_timeline.csv`` beside its raster ``STEM.tif``): the previews at
  each snapshot, the chronology and timeline plots, the mass budget, the parameters and the
  history;
* each **compare-terraces** report (a ``summary.json`` of terraces, in the folder or one of
  its subfolders): the fit, the terraces and incision rates, the profile plots;
* any other **output** (a raster with its JSON sidecar): its preview, parameters and history.

Images are drawn in memory and embedded (``viz.report_html``); maps are on the axes of the
raster's CRS (:mod:`.maps`).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from unerode_cli.io.ensemble_files import ENSEMBLE_FILE, read_record
from unerode_cli.io.provenance import history, sidecar_path
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.report_files import read_png, read_rows
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.report.ensemble import ensemble_sections
from unerode_cli.jobs.report.maps import relief_png
from unerode_cli.run.outputs import AGE_TAG, PHASE_TAG, SEA_TAG
from unerode_cli.viz.report_html import Figure, Section, Table, png_bytes
from unerode_cli.viz.report_plots import save_series_panels

RASTER_SUFFIXES = (".tif", ".tiff", ".exr")
_SNAPSHOT = re.compile(r"_(\d+(?:\.\d+)?)ka$")


@dataclass(frozen=True)
class Source:
    """What one part of a report is made of: an ensemble's folder, a climate-run's raster, a
    compare-terraces report folder (with its summary.json ``record``) or any output raster."""

    kind: Literal["ensemble", "climate-run", "compare-terraces", "output"]
    path: Path
    record: dict[str, Any] | None = None


def find_sources(folder: Path) -> list[Source]:
    """What unerode-cli wrote in ``folder`` (see the module docstring), in report order."""
    if (folder / ENSEMBLE_FILE).exists():
        return [Source("ensemble", folder)]
    sources, claimed = [], set()
    for timeline in sorted(folder.glob("*_timeline.csv")):
        raster = _raster_named(folder, timeline.name[: -len("_timeline.csv")])
        if raster is not None:
            sources.append(Source("climate-run", raster))
            claimed |= {raster, *_snapshots(raster)}
    for summary in [folder / "summary.json", *sorted(folder.glob("*/summary.json"))]:
        record = read_record(summary) if summary.exists() else None
        if record is not None and "terraces" in record:
            sources.append(Source("compare-terraces", summary.parent, record))
    for raster in sorted(p for p in folder.iterdir() if p.suffix.lower() in RASTER_SUFFIXES):
        if raster not in claimed and sidecar_path(raster).exists():
            sources.append(Source("output", raster))
    return sources


def build_sections(sources: list[Source], page_dir: Path | None = None) -> list[Section]:
    """The sections of ``sources``, in order (an ensemble gives several); links to files of the
    run are relative to ``page_dir``, the folder of the page (default: the run's folder)."""
    builders: dict[str, Callable[[Source], list[Section]]] = {
        "ensemble": lambda s: ensemble_sections(s.path, page_dir),
        "climate-run": lambda s: [climate_section(s.path)],
        "compare-terraces": lambda s: [terrace_section(s.path, s.record or {})],
        "output": lambda s: [output_section(s.path)],
    }
    return [section for source in sources for section in builders[source.kind](source)]


def _raster_named(folder: Path, stem: str) -> Path | None:
    return next((folder / f"{stem}{s}" for s in RASTER_SUFFIXES if (folder / f"{stem}{s}").exists()), None)


def _snapshots(raster: Path) -> list[Path]:
    """The snapshots ``STEM_<age>ka.EXT`` of a climate-run's output ``STEM.EXT``."""
    found = raster.parent.glob(f"{raster.stem}_*ka{raster.suffix}")
    return sorted(p for p in found if _SNAPSHOT.search(p.stem) and p.stem[len(raster.stem):].count("_") == 1)


# ---------------------------------------------------------------------------------------------
# A climate-run

def climate_section(raster: Path) -> Section:
    """A climate-run: summary, previews by age, chronology, timeline and mass budget,
    parameters and history."""
    sidecar = read_record(sidecar_path(raster)) or {}
    parameters = sidecar.get("parameters", {})
    statistics = sidecar.get("statistics", {})
    section = Section(f"climate-run {raster.name}")
    section.blocks.append(
        f"From {parameters.get('from_ka', '?')} to {parameters.get('to_ka', '?')} ka by steps of "
        f"{parameters.get('dt', '?')} years ({statistics.get('steps', '?')} steps), processes "
        f"{parameters.get('process', '?')}; wall time {_number(statistics.get('wall_time_s'), ' s')}.")
    layers = sorted(((read_terrain(p), p) for p in [*_snapshots(raster), raster]),
                    key=lambda item: _age(item[0]))
    previews = Section("Previews at each snapshot")
    for terrain, path in layers:
        caption = f"{path.name}: {_age_text(terrain)}"
        previews.blocks.append(Figure(_preview(terrain, caption), caption))
    section.subsections.append(previews)
    chronology = raster.with_name(f"{raster.stem}_chronology.png")
    timeline = raster.with_name(f"{raster.stem}_timeline.csv")
    plots = Section("Chronology, timeline and mass budget")
    if chronology.exists():
        plots.blocks.append(Figure(read_png(chronology), f"{chronology.name}: the chronology and the "
                                   "run's sea level, shaded by climate phase"))
    if timeline.exists():
        plots.blocks += _timeline_blocks(timeline)
    section.subsections.append(plots)
    section.subsections.append(_parameters_section(parameters, statistics, layers[-1][0]))
    return section


def _timeline_blocks(timeline: Path) -> list:
    """The timeline's plot (sea level, cumulative eroded and deposited volumes, mean change)
    and the mass budget's totals."""
    columns, rows = read_rows(timeline)
    if not rows or "age_ka" not in columns:
        return []
    data = {c: np.array([_float(r.get(c)) for r in rows]) for c in columns if c != "phase"}
    panels = []
    if "sea_level_m" in data:
        panels.append(("sea level (m)", {"sea level": data["sea_level_m"]}))
    budget = {name: np.cumsum(np.nan_to_num(data[c])) for name, c in
              (("eroded", "eroded_m3"), ("deposited", "deposited_m3"), ("inflow", "inflow_m3")) if c in data}
    if budget:
        panels.append(("cumulative volume (m³)", budget))
    if "mean_abs_dh_m" in data:
        panels.append(("mean |Δh| per step (m)", {"mean |Δh|": data["mean_abs_dh_m"]}))
    blocks: list = []
    if panels:
        png = png_bytes(lambda f: save_series_panels(f, data["age_ka"], "age (ka)", panels, timeline.name))
        blocks.append(Figure(png, f"{timeline.name}: sea level, mass budget and change per step"))
    if budget:
        totals = [[name, float(values[-1])] for name, values in budget.items()]
        if "eroded" in budget and "deposited" in budget:
            totals.append(["eroded − deposited (left through outlets, or gained backward)",
                           float(budget["eroded"][-1] - budget["deposited"][-1])])
        blocks.append(Table(["mass budget", "volume (m³)"], totals, "Mass budget over the run"))
    return blocks


# ---------------------------------------------------------------------------------------------
# compare-terraces and other outputs

def terrace_section(folder: Path, summary: dict[str, Any]) -> Section:
    """A compare-terraces report: the fit, the terraces and incision periods, the plots."""
    section = Section(f"compare-terraces {folder.name}/")
    terraces = summary.get("terraces", {})
    section.blocks.append(Table(["", ""], [
        ["terraces compared", terraces.get("count")], ["RMSE (m)", terraces.get("rmse_m")],
        ["bias (m)", terraces.get("bias_m")],
        ["within uncertainty", f"{terraces.get('within_uncertainty')} of {terraces.get('with_uncertainty')}"],
        ["uplift (m/y)", summary.get("uplift_m_per_y")]], "Fit"))
    rows = terraces.get("rows", [])
    if rows:
        columns = ["name", "age_ka", "observed_m", "simulated_m", "residual_m", "uncertainty_m"]
        section.blocks.append(Table(columns, [[r.get(c) for c in columns] for r in rows], "Terraces"))
    periods = summary.get("incision", {}).get("periods", [])
    if periods:
        columns = ["name", "from_ka", "to_ka", "observed_mm_per_ka", "simulated_mm_per_ka",
                   "residual_mm_per_ka"]
        section.blocks.append(Table(columns, [[p.get(c) for c in columns] for p in periods],
                                    "Incision rates"))
    for name in ("profiles.png", "incision.png"):
        if (folder / name).exists():
            section.blocks.append(Figure(read_png(folder / name), name))
    return section


def output_section(raster: Path) -> Section:
    """Any raster with its sidecar: preview, parameters and history."""
    terrain = read_terrain(raster)
    sidecar = read_record(sidecar_path(raster)) or {}
    section = Section(f"{sidecar.get('command', 'output')} {raster.name}")
    section.blocks.append(Figure(_preview(terrain, raster.name), raster.name))
    section.subsections.append(_parameters_section(sidecar.get("parameters", {}),
                                                   sidecar.get("statistics", {}), terrain))
    return section


def _parameters_section(parameters: dict[str, Any], statistics: dict[str, Any], terrain: Terrain) -> Section:
    section = Section("Parameters and history")
    given = [[k, _cell(v)] for k, v in parameters.items() if v is not None and v is not False]
    if given:
        section.blocks.append(Table(["parameter", "value"], given, "Parameters"))
    numbers = [[k, _cell(v)] for k, v in statistics.items() if not isinstance(v, dict | list)]
    if numbers:
        section.blocks.append(Table(["statistic", "value"], numbers, "Run statistics"))
    entries = history(terrain)
    if entries:
        section.blocks.append(Table(
            ["#", "command", "version", "time (UTC)", "command line"],
            [[i, e.get("command"), e.get("version"), e.get("time"), " ".join(map(str, e.get("argv", [])[1:]))]
             for i, e in enumerate(entries, 1)], "History of the raster (UNERODE_HISTORY)"))
    return section


def _preview(terrain: Terrain, title: str) -> bytes:
    return relief_png(terrain, title)


def _age(terrain: Terrain) -> float:
    try:
        return float(terrain.tags.get(AGE_TAG, "nan"))
    except ValueError:
        return float("nan")


def _age_text(terrain: Terrain) -> str:
    parts = [f"{_age(terrain):g} ka" if AGE_TAG in terrain.tags else "no age"]
    if SEA_TAG in terrain.tags:
        parts.append(f"sea level {float(terrain.tags[SEA_TAG]):+.1f} m")
    if PHASE_TAG in terrain.tags:
        parts.append(terrain.tags[PHASE_TAG])
    return ", ".join(parts)


def _float(text: str | None) -> float:
    try:
        return float(text) if text else float("nan")
    except ValueError:
        return float("nan")


def _cell(value: Any) -> Any:
    """A value for a table cell: numbers as numbers, lists joined."""
    if isinstance(value, list):
        return ", ".join(map(str, value))
    if isinstance(value, str):
        number = _float(value)
        return number if value and np.isfinite(number) and not value.isdigit() else value
    return value


def _number(value: Any, unit: str) -> str:
    return f"{value:.3g}{unit}" if isinstance(value, int | float) else "?"
