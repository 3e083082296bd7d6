"""Whether a sweep axis of sea-level curves can change a climate-run, judged before any member
of the ensemble runs.

An axis of sea-level curves (a list swept over ``--sea-level``) acts on a run only through the
sea reaching its domain, the downstream K_d and the climate phases
(:mod:`unerode_cli.climate.sea_influence`). Runs that differ only in the curve (one group per
combination of the other swept values) are compared through those three with the run's own
forcing (:func:`~unerode_cli.jobs.climate_run.forcing.forcing`: the sea levels and phases the
run will use). When none differs in any group, the axis is **inert**: the ensemble would run
the same members several times. An axis that acts only through the climate phases is told too
(e.g. curves that agree over the ages the terraces test).

Never judged inert, whatever the curves: a glacial run, a coast (``--coast``), a nested run
(``--inflow-from``), an uplift given as a raster or table, or a run whose forcing does not
resolve (it fails on its own).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from unerode_cli.climate.schedule import Schedule, downstream_mask
from unerode_cli.climate.sea_influence import CurveForcing, SeaInfluence, sea_influence
from unerode_cli.errors import InputError
from unerode_cli.io.grid_rasters import load_on_grid
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.io.yaml_files import read_yaml_mapping
from unerode_cli.jobs.climate_run.forcing import forcing as run_forcing
from unerode_cli.jobs.climate_run.forcing import read_sea_level, step_count
from unerode_cli.run.common_options import input_georef

if TYPE_CHECKING:
    from unerode_cli.jobs.climate_run.job import ClimateJob

#: The climate-run option of a sea-level curve (as a sweep key names it).
SEA_OPTION = "sea-level"


@dataclass(frozen=True)
class AxisCheck:
    """What an axis of sea-level curves does: ``influence`` in the first group of members that
    differ only in it (the one whose curves act most), ``inert`` when no group's curves act."""

    key: str
    step: str
    inert: bool
    influence: SeaInfluence | None
    unread: bool = False

    def sentence(self) -> str:
        """One sentence: why the axis changes nothing, or how little it changes."""
        where = f"sweep '{self.key}'"
        if self.unread:
            return (f"{where} cannot change any member's result: step '{self.step}' reads its sea level from "
                    "--chronology (--chronology-kind sea-level), not from --sea-level")
        assert self.influence is not None
        if self.inert:
            return f"{where} cannot change any member's result: {self.influence.reasons()}"
        return f"{where} changes the members only through the climate phases: {self.influence.reasons()}"

    def record(self) -> dict[str, Any]:
        """The axis as ensemble.json records it."""
        out: dict[str, Any] = {"key": self.key, "step": self.step, "reason": self.sentence()}
        if self.influence is not None:
            i = self.influence
            out.update(highest_sea_level_m=round(i.highest_sea_m, 3),
                       lowest_ground_m=round(i.lowest_ground_m, 3), uplift_m=round(i.uplift_m, 3),
                       downstream_cells=i.downstream_cells, phase_steps_differing=i.phase_steps_differing)
        return out


def judge_sea_axis(key: str, step: str, groups: Sequence[Sequence[ClimateJob]]) -> AxisCheck | None:
    """What the axis ``key`` over ``--sea-level`` of step ``step`` does, from ``groups`` of
    climate-run jobs, each group the same run but for the curve; None when it acts through the
    sea or the downstream K_d in some group, or cannot be judged."""
    cache = _Cache()
    worst: SeaInfluence | None = None
    unread = 0
    for jobs in groups:
        if len({str(job.sea_level_file) for job in jobs}) < 2:
            continue
        if all(job.chronology_kind == "sea-level" for job in jobs):
            unread += 1                                # --sea-level is not read
            continue
        influence = cache.influence(jobs)
        if influence is None or influence.reaches or influence.kd_differs:
            return None
        if worst is None or influence.phase_steps_differing > worst.phase_steps_differing:
            worst = influence
    if worst is None:
        return AxisCheck(key, step, True, None, unread=True) if unread else None
    return AxisCheck(key, step, worst.inert, worst)


class _Cache:
    """DEMs, downstream regions and curve forcings read once for all the members judged."""

    def __init__(self) -> None:
        self.terrains: dict[tuple[Any, ...], Terrain] = {}
        self.curves: dict[tuple[Any, ...], tuple[CurveForcing, np.ndarray]] = {}

    def influence(self, jobs: Sequence[ClimateJob]) -> SeaInfluence | None:
        """How the curves of ``jobs`` (one member each, the same run but for the curve) act;
        None when the run cannot be judged."""
        job = jobs[0]
        if "glacial" in job.process or job.coast not in (None, "none") or job.inflow_from is not None:
            return None
        try:
            terrain = self.terrain(job)
            uplift = max(_uplift_rate(j) for j in jobs) * abs(job.to_ka - job.from_ka) * 1000.0
            curves = [self.curve(j) for j in jobs]
            region = 0
            if job.downstream_mask is not None or job.downstream_below is not None:
                mask = (load_on_grid(job.downstream_mask, terrain, "downstream mask") != 0
                        if job.downstream_mask else None)
                region = int(np.count_nonzero(downstream_mask(terrain.elevation, job.downstream_below, mask)
                                              & terrain.grid.valid))
        except (InputError, ValueError):
            return None
        lowest = float(np.nanmin(np.where(terrain.grid.valid, terrain.elevation, np.nan)))
        return sea_influence([c for c, _ in curves], curves[0][1], lowest, uplift, region, job.sea_outlets)

    def terrain(self, job: ClimateJob) -> Terrain:
        key = (str(job.source), input_georef(job))
        if key not in self.terrains:
            self.terrains[key] = read_terrain(job.source, georef=input_georef(job))
        return self.terrains[key]

    def curve(self, job: ClimateJob) -> tuple[CurveForcing, np.ndarray]:
        """The curve of ``job``: its sea levels at the start and at each step's middle and end,
        and its phases; with the steps' middle ages."""
        key = tuple(str(getattr(job, name)) for name in (
            "sea_level_file", "sea_level_extend", "chronology", "chronology_kind", "d18o_mapping",
            "from_ka", "to_ka", "dt"))
        if key not in self.curves:
            _, sea = read_sea_level(job, None)
            steps = run_forcing(job, step_count(job), sea)
            levels = np.concatenate(([steps.sea_start], steps.sea_mid, steps.sea_end))
            self.curves[key] = (CurveForcing(Path(str(job.sea_level_file)).name, levels, steps.phase),
                                steps.mid_ka)
        return self.curves[key]


def _uplift_rate(job: ClimateJob) -> float:
    """The largest |U| (m/y) of the run: its --uplift number and the schedule's per-phase values;
    inf when --uplift names a raster or a table."""
    text = job.parameter_values().get("uplift")
    try:
        rate = abs(float(text)) if text is not None else 0.0
    except ValueError:
        return math.inf
    if job.schedule_file is not None:
        schedule = Schedule.from_mapping(read_yaml_mapping(job.schedule_file, "the schedule file",
                                                           "a mapping of phases to parameters"))
        rate = max([rate, *(abs(v.get("uplift", 0.0)) for v in schedule.phases.values())])
    return rate
