"""The chronology of a climate-run as per-step forcing (000 §5): the steps from ``--from`` to
``--to``, the sea level by age and the climate phase of each step, and the names of the run's
side outputs.

A step of ``dt`` years goes from age a to a ± dt/1000 ka; its phase and sea level are those of
its middle age, and the sea level at its end age is the one its boundary nodes follow.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from unerode_cli.climate.chronology import YEARS_PER_KA, Series
from unerode_cli.climate.phases import PhaseThresholds, classify
from unerode_cli.climate.sealevel import DEFAULT_MAPPING, SeaLevelMapping, extend_with_d18o, sea_level
from unerode_cli.errors import InputError
from unerode_cli.io.chronology_files import read_series
from unerode_cli.run.stepping import check_step_count

if TYPE_CHECKING:
    from unerode_cli.jobs.climate_run.job import ClimateJob


def timeline_path(output: Path) -> Path:
    """``past.tif`` → ``past_timeline.csv``: one row per step."""
    return output.with_name(f"{output.stem}_timeline.csv")


def chronology_png_path(output: Path) -> Path:
    """``past.tif`` → ``past_chronology.png``: the chronology and the run's sea level by phase."""
    return output.with_name(f"{output.stem}_chronology.png")


def report_path(output: Path) -> Path:
    """``past.tif`` → ``past_report.html``: the report of ``--report``."""
    return output.with_name(f"{output.stem}_report.html")


def snapshot_path(output: Path, age_ka: float) -> Path:
    """``past.tif`` at 12 ka → ``past_12ka.tif``."""
    return output.with_name(f"{output.stem}_{age_ka:g}ka{output.suffix}")


@dataclass(frozen=True)
class SeaLevelSource:
    """Sea level (m relative to present) by age as climate-run takes it (000 §5.1–5.2): from the
    chronology when it is a sea-level curve, else from ``--sea-level``, else from the δ18O
    chronology through ``mapping`` (``climate.sealevel``)."""

    sea: Series | None
    d18o: Series | None
    mapping: SeaLevelMapping

    @classmethod
    def of(cls, job: ClimateJob, chronology: Series, sea: Series | None,
           mapping: SeaLevelMapping) -> SeaLevelSource:
        if job.chronology_kind == "sea-level":
            return cls(chronology, None, mapping)
        return cls(sea, chronology if job.chronology_kind == "d18o" else None, mapping)

    @property
    def series(self) -> Series:
        """The table the sea level is read from (sea level, else δ18O)."""
        series = self.sea if self.sea is not None else self.d18o
        assert series is not None
        return series

    def at(self, ages_ka: np.ndarray) -> np.ndarray:
        """Sea level (m) at ``ages_ka`` (ka); ValueError (one sentence) outside the table."""
        return np.asarray(sea_level(ages_ka, self.sea, self.d18o, self.mapping), dtype=float)

    def since(self, from_ka: float) -> Callable[[float], float]:
        """The sea level (m) at t years after the age ``from_ka`` (ka) of a forward run."""
        return lambda time_y: float(self.at(np.asarray(from_ka - time_y / YEARS_PER_KA)))


def read_sea_level(job: ClimateJob, on_note: Callable[[str], None] | None) -> tuple[Series, SeaLevelSource]:
    """The chronology, and the sea level by age from it, ``--sea-level`` (continued beyond its
    oldest age with δ18O by ``--sea-level-extend d18o``: ``climate.sealevel.extend_with_d18o``)
    and ``--d18o-to-sea`` (``on_note`` hears what was changed in the tables as read: rows left
    out or sorted)."""
    if job.sea_level_extend != "none" and (job.sea_level_file is None or job.chronology_kind != "d18o"):
        raise InputError(f"--sea-level-extend {job.sea_level_extend} continues a --sea-level table with "
                         "the δ18O of --chronology; give both (with --chronology-kind d18o).")
    chronology = read_series(job.chronology, job.chronology_kind, on_note=on_note)
    sea = read_series(job.sea_level_file, "sea-level", on_note=on_note) if job.sea_level_file else None
    if sea is not None and job.sea_level_extend == "d18o":
        try:
            sea = extend_with_d18o(sea, chronology)
        except ValueError as exc:
            raise InputError(f"{exc}.") from None
    mapping = SeaLevelMapping(*job.d18o_mapping) if job.d18o_mapping else DEFAULT_MAPPING
    return chronology, SeaLevelSource.of(job, chronology, sea, mapping)


def step_count(job: ClimateJob) -> int:
    """The number of ``--dt`` steps from ``--from`` to ``--to``, checked: a whole number, in the
    direction ``--direction`` says."""
    if not (np.isfinite(job.dt) and job.dt > 0):
        raise InputError(f"--dt must be a positive number of years, got {job.dt:g}.")
    if job.from_ka == job.to_ka:
        raise InputError("--from and --to are the same age: nothing to run.")
    wanted = "backward" if job.backward else "forward"
    if job.direction is not None and job.direction != wanted:
        raise InputError(f"--direction {job.direction} does not match --from {job.from_ka:g} "
                         f"--to {job.to_ka:g} ka, which runs {wanted} in time.")
    count = abs(job.to_ka - job.from_ka) * 1000.0 / job.dt
    if count < 0.5:
        raise InputError(f"--dt {job.dt:g} years is longer than the span {job.from_ka:g}–{job.to_ka:g} ka "
                         "of the run.")
    check_step_count(count, f"the span {job.from_ka:g}–{job.to_ka:g} ka in steps of --dt {job.dt:g} y",
                     "give a larger --dt or a shorter span")
    if abs(count - round(count)) > 1e-9 * max(1.0, count):
        raise InputError(f"the span {job.from_ka:g}–{job.to_ka:g} ka is not a whole number of "
                         f"--dt {job.dt:g} year steps.")
    return round(count)


@dataclass
class Forcing:
    """Per-step forcing: end ages (ka), middle-age phases and sea levels (m), end sea levels, and
    the sea level (m) at ``--from``."""

    end_ka: np.ndarray
    mid_ka: np.ndarray
    phase: np.ndarray
    sea_mid: np.ndarray
    sea_end: np.ndarray
    sea_start: float


def forcing(job: ClimateJob, steps: int, sea: SeaLevelSource) -> Forcing:
    """The forcing of each of the ``steps`` steps; InputError when the sea level's table does
    not cover the run."""
    sign = 1.0 if job.backward else -1.0
    k = np.arange(1, steps + 1, dtype=np.float64)
    end = job.from_ka + sign * k * job.dt / 1000.0
    mid = end - sign * 0.5 * job.dt / 1000.0
    lo, hi = min(job.from_ka, job.to_ka), max(job.from_ka, job.to_ka)
    try:
        sea_mid, sea_end = sea.at(mid), sea.at(end)
        sea_start = float(sea.at(np.array([job.from_ka]))[0])
        # phases need the trend around each age: classify on a 1 ka grid, read at the middles
        source = sea.series
        grid = np.arange(max(source.start_ka, lo - 30.0), min(source.end_ka, hi + 30.0) + 1e-9, 1.0)
        phases_on_grid = classify(grid, sea.at(grid), PhaseThresholds())
    except ValueError as exc:
        hint = ""
        if sea.sea is not None and sea.d18o is not None and hi > sea.sea.end_ka:
            hint = (f" (the --sea-level table ends at {sea.sea.end_ka:g} ka; --sea-level-extend d18o "
                    "continues it with sea level from the δ18O chronology)")
        raise InputError(f"{str(exc).rstrip('.')}{hint}.") from None
    # nearest grid age (1 ka apart), the younger one on ties
    pick = np.clip(np.ceil(mid - grid[0] - 0.5).astype(np.int64), 0, grid.size - 1)
    return Forcing(end, mid, np.asarray(phases_on_grid)[pick], sea_mid, sea_end, sea_start)
