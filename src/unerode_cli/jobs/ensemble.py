"""The summary of an ensemble (``OUT_DIR/summary/`` and ``OUT_DIR/members.csv``) from the
outputs of its finished members.

* **Rasters.** For each raster output of the members' pipeline that every finished member
  wrote (an elevation, a snapshot at an age, a change map …), ``summary/STEM_STAT.tif`` for
  STAT in mean, std, p5, p50, p95 (``ensemble.summary``), as cloud-optimised GeoTIFFs with the
  members' grid and CRS and, for a snapshot, its age tag (``UNERODE_AGE_KA``). The
  statistics of the snapshots (rasters with an age) also go into one CF-1.8 NetCDF time
  series, ``summary/snapshots.nc`` (``io.netcdf_files``): variables ``elevation_STAT`` (m) on
  the ``time``/``age`` axis, the mean and standard deviation with the CF cell methods
  ``realization: mean`` and ``realization: standard_deviation``.
* **Scores.** When the pipeline runs ``compare-terraces``, each member's scores from its
  report's summary.json (the first such report): the terrace RMSE and bias (m) and the RMS of
  the incision-rate residuals (mm/ka). Members are ranked by the terrace RMSE (else the
  incision error); ``members.csv`` lists every member, best first, with its parameters and
  scores; ``summary/best.json`` the best ones; ``summary/scatter_KEY.png`` each swept
  parameter against the scores. With ``SOURCE_DATE_EPOCH`` set (reproducible outputs) the
  members' wall times are left empty in members.csv.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.ensemble.summary import STATISTICS, cell_statistics, ranks
from unerode_cli.io.ensemble_files import MEMBERS_TABLE, SUMMARY_FOLDER, read_record, write_record, write_rows
from unerode_cli.io.gdal_io import WriteOptions
from unerode_cli.io.netcdf_files import write_variables
from unerode_cli.io.netcdf_raster import Quantity
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.io.provenance import fixed_epoch
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.outputs import AGE_TAG, Outputs, save
from unerode_cli.viz.ensemble_plots import save_scatter

COMMAND = "ensemble"
#: The scores of a member (members.csv columns), with their labels in plots.
SCORES = {"terrace_rmse_m": "terrace RMSE (m)", "terrace_bias_m": "terrace bias (m)",
          "incision_rmse_mm_per_ka": "incision-rate error (mm/ka)"}
#: How many of the best members summary/best.json lists.
BEST = 5
#: The snapshots' statistics as one NetCDF time series, in the summary folder.
SNAPSHOTS_NC = "snapshots.nc"
#: Long names and CF cell methods of the statistics' NetCDF variables.
STATISTIC_TEXTS = {"mean": ("members' mean of the surface elevation", "realization: mean"),
                   "std": ("standard deviation of the members' surface elevation",
                           "realization: standard_deviation"),
                   "p5": ("5th percentile of the members' surface elevation", ""),
                   "p50": ("median of the members' surface elevation", "realization: median"),
                   "p95": ("95th percentile of the members' surface elevation", "")}


@dataclass(frozen=True)
class MemberResult:
    """A member as the summary sees it: its folder, swept values and how its run ended."""

    index: int
    folder: Path
    parameters: dict[str, Any]
    finished: bool
    wall_s: float | None = None
    step: str | None = None
    error: str | None = None


@dataclass(frozen=True)
class SummaryJob:
    """``rasters`` and ``reports``: paths in a member's folder of its raster outputs and of
    its compare-terraces report folders; ``log_keys``: parameters sampled log-uniformly."""

    out_dir: Path
    keys: tuple[str, ...]
    log_keys: frozenset[str]
    rasters: tuple[Path, ...]
    reports: tuple[Path, ...]
    members: tuple[MemberResult, ...]

    @property
    def folder(self) -> Path:
        return self.out_dir / SUMMARY_FOLDER


def summarise(job: SummaryJob, on_note: Callable[[str], None] = lambda text: None) -> str:
    """Write members.csv and the summary folder; returns a one-line account."""
    job.folder.mkdir(exist_ok=True)
    finished = [m for m in job.members if m.finished]
    scores = {m.index: member_scores(m, job.reports) for m in finished}
    order = _ranked(job.members, scores)
    _write_members_table(job, scores, order)
    summarised = _write_rasters(job, finished, on_note) if finished else {}
    rasters = len(summarised) * len(STATISTICS)
    aged = _write_snapshot_series(job, summarised)
    best = [m for m in order if scores.get(m.index, {}).get("rank") is not None][:BEST]
    if best:
        write_record(job.folder / "best.json", {"members": [
            {"member": m.index, "folder": str(m.folder), "parameters": m.parameters,
             **{k: v for k, v in scores[m.index].items()}} for m in best]})
        _write_scatters(job, finished, scores, best[0])
    text = f"{COMMAND}: {len(finished)} of {len(job.members)} member(s) finished"
    if len(finished) < len(job.members):
        text += f", {len(job.members) - len(finished)} failed (see failures.csv)"
    text += f"; {rasters} summary raster(s) in {job.folder}"
    if aged:
        text += f" ({aged} age(s) also in {SNAPSHOTS_NC})"
    if best:
        b = best[0]
        shown = ", ".join(f"{k}={_short(v)}" for k, v in b.parameters.items())
        text += f"; best member {b.folder.name} ({shown}) with {_score_text(scores[b.index])}"
    return text


def member_scores(member: MemberResult, reports: tuple[Path, ...]) -> dict[str, float | None]:
    """The scores of a finished member from its first compare-terraces report (empty when the
    pipeline has none)."""
    for report in reports:
        summary = read_record(member.folder / report / "summary.json")
        if summary is None:
            continue
        terraces = summary.get("terraces", {})
        periods = summary.get("incision", {}).get("periods", [])
        residuals = [p["residual_mm_per_ka"] for p in periods if p.get("residual_mm_per_ka") is not None]
        compared = bool(terraces.get("count"))
        return {"terrace_rmse_m": terraces.get("rmse_m") if compared else None,
                "terrace_bias_m": terraces.get("bias_m") if compared else None,
                "incision_rmse_mm_per_ka": _rms(residuals) if residuals else None}
    return {}


def _rms(values: list[float]) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def _ranked(members: Sequence[MemberResult], scores: dict[int, dict[str, Any]]) -> list[MemberResult]:
    """Members best first (rank by the terrace RMSE, else the incision error), then the
    unranked ones in order; each score dict gains its ``rank``."""
    key = next((k for k in ("terrace_rmse_m", "incision_rmse_mm_per_ka")
                if any(s.get(k) is not None for s in scores.values())), None)
    keyed = [scores.get(m.index, {}).get(key) if key else None for m in members]
    for member, rank in zip(members, ranks(keyed), strict=True):
        if member.index in scores:
            scores[member.index]["rank"] = rank
    return sorted(members, key=lambda m: (scores.get(m.index, {}).get("rank") or math.inf, m.index))


def _write_members_table(job: SummaryJob, scores: dict[int, dict[str, Any]],
                         order: list[MemberResult]) -> None:
    scored = [name for name in SCORES if any(s.get(name) is not None for s in scores.values())]
    columns = ["rank", "member", "status", *job.keys, *scored, "wall_s", "folder"]
    rows = [{"rank": scores.get(m.index, {}).get("rank"), "member": m.index,
             "status": "finished" if m.finished else "failed", **m.parameters,
             **{k: scores.get(m.index, {}).get(k) for k in scored},
             "wall_s": None if m.wall_s is None or fixed_epoch() is not None else round(m.wall_s, 3),
             "folder": m.folder.relative_to(job.out_dir.resolve()).as_posix()
             if m.folder.is_relative_to(job.out_dir.resolve()) else str(m.folder)}
            for m in order]
    write_rows(job.out_dir / MEMBERS_TABLE, columns, rows)


def _write_rasters(job: SummaryJob, finished: list[MemberResult],
                   on_note: Callable[[str], None]) -> dict[Path, float | None]:
    """The statistics rasters of every raster output that all finished members wrote; each
    output summarised, with its age (ka; None for a raster without one)."""
    summarised: dict[Path, float | None] = {}
    for relative in job.rasters:
        missing = [m.folder.name for m in finished if not (m.folder / relative).is_file()]
        if missing:
            on_note(f"note: member(s) {', '.join(missing)} wrote no {relative}; no summary of it.")
            continue
        first = read_terrain(finished[0].folder / relative)
        layers = [first] + [read_terrain(m.folder / relative) for m in finished[1:]]
        if any(layer.shape != first.shape for layer in layers):
            on_note(f"note: the members' {relative} differ in size; no summary of it.")
            continue
        stack = np.stack([layer.elevation for layer in layers])
        for name, raster in cell_statistics(stack).items():
            _write_statistic(job, first, relative, name, raster, len(layers))
        age = first.tags.get(AGE_TAG)
        summarised[relative] = None if age is None else float(age)
    return summarised


def _write_snapshot_series(job: SummaryJob, summarised: dict[Path, float | None]) -> int:
    """summary/snapshots.nc from the statistics rasters of the outputs ``summarised`` with an
    age (one per age, the first output listed at that age); the number of ages (0: none, no
    file)."""
    by_age: dict[float, Path] = {}
    for relative, age in summarised.items():
        if age is not None:
            by_age.setdefault(age, relative)
    if not by_age:
        return 0
    variables = [(Quantity(f"elevation_{name}", "surface_altitude", STATISTIC_TEXTS[name][0], "m",
                           STATISTIC_TEXTS[name][1]),
                  [summary_raster_path(job.folder, relative, name) for relative in by_age.values()])
                 for name in STATISTICS]
    write_variables(job.folder / SNAPSHOTS_NC, variables,
                    f"ensemble of {len(job.members)} member(s): statistics of the snapshots")
    return len(by_age)


def summary_raster_path(folder: Path, relative: Path, statistic: str) -> Path:
    """``summary/past_12ka_p95.tif`` for the members' ``past_12ka.tif``."""
    return folder / f"{relative.stem}_{statistic}.tif"


def _write_statistic(job: SummaryJob, first: Terrain, relative: Path, statistic: str,
                     raster: np.ndarray, count: int) -> None:
    path = summary_raster_path(job.folder, relative, statistic)
    terrain = first.with_elevation(raster)
    terrain.tags = {k: v for k, v in first.tags.items() if k == AGE_TAG or not k.startswith("UNERODE_")}
    outputs = Outputs(path, WriteOptions(cog=True), overwrite=True)  # cloud-optimised GeoTIFF
    outputs.check()
    save(terrain, outputs, COMMAND, {"statistic": statistic, "of": relative.as_posix(), "members": count},
         {"statistic": statistic, "members": count, "statistics_of": STATISTICS})


def _write_scatters(job: SummaryJob, finished: list[MemberResult], scores: dict[int, dict[str, Any]],
                    best: MemberResult) -> None:
    """summary/scatter_KEY.png for each swept parameter (the scored members)."""
    scored = [m for m in finished if scores[m.index].get("rank") is not None]
    columns = {SCORES[k]: [scores[m.index].get(k) for m in scored] for k in SCORES
               if any(scores[m.index].get(k) is not None for m in scored)}
    for key in job.keys:
        path = job.folder / f"scatter_{_file_part(key)}.png"
        check_output(path, overwrite=True)
        with atomic_path(path) as tmp:
            save_scatter(tmp, key, [m.parameters[key] for m in scored], columns, key in job.log_keys,
                         scored.index(best))


def _file_part(key: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", key)


def _short(value: Any) -> str:
    return f"{value:.4g}" if isinstance(value, float) else Path(str(value)).name


def _score_text(scores: dict[str, Any]) -> str:
    return ", ".join(f"{SCORES[k]} {v:.3g}" for k, v in scores.items() if k in SCORES and v is not None)
