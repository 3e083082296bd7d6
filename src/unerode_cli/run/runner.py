"""The time-stepping runner: applies process changes step after step (DESIGN §3).

Processes never edit the elevation: each returns a change, and the runner applies it, splits a
step between several processes in the given order (operator splitting), sub-steps a process
whose stable time step (CFL) is shorter than the step, and reports progress and snapshots.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from unerode_cli.errors import InputError, RunFailure
from unerode_cli.run.divergence import DivergenceGuard

#: More sub-steps than this in one step is refused: --dt is far above the stable step.
MAX_SUBSTEPS = 100_000


@dataclass
class Budget:
    """Volumes (m³) moved by a process over a run: eroded, deposited, left through outlets,
    and brought in from upstream of the map (inflow)."""

    eroded: float = 0.0
    deposited: float = 0.0
    outflux: float = 0.0
    inflow: float = 0.0

    def add(self, eroded: float, deposited: float, outflux: float, inflow: float = 0.0) -> None:
        self.eroded += eroded
        self.deposited += deposited
        self.outflux += outflux
        self.inflow += inflow

    @property
    def residual(self) -> float:
        """eroded + inflow − deposited − outflux (m³); zero for a mass-conserving process."""
        return self.eroded + self.inflow - self.deposited - self.outflux


@dataclass(frozen=True)
class Change:
    """What one (sub-)step of a process does: Δh (m) and the volumes it moved (m³)."""

    dh: np.ndarray
    eroded: float
    deposited: float
    outflux: float
    inflow: float = 0.0


class Process(Protocol):
    """A surface process bound to its grid, boundaries and parameters."""

    name: str

    def stable_dt(self, elevation: np.ndarray, dt: float) -> float:
        """Largest stable |dt| (y) on this elevation for a step of the sign of ``dt`` (inf
        when unconstrained)."""

    def advance(self, elevation: np.ndarray, dt: float) -> Change:
        """The change of one step of ``dt`` years (negative: backward in time)."""


@dataclass
class RunReport:
    """Totals of a run."""

    steps: int = 0
    substeps: dict[str, int] = field(default_factory=dict)
    budgets: dict[str, Budget] = field(default_factory=dict)
    elapsed_years: float = 0.0


class NoStableStep(ValueError):
    """A process whose stable |dt| is 0 or not a number: no sub-step is small enough."""


def substeps_needed(dt: float, stable: float) -> int:
    """Number of equal sub-steps so that each is within the stable |dt| (y; inf: any step).

    Raises :class:`NoStableStep` when ``stable`` is 0, negative or NaN (a process whose speed
    overflowed, e.g. a rate parameter of 1e308): no number of sub-steps is stable."""
    if math.isnan(stable) or stable <= 0.0:
        raise NoStableStep(stable)
    if math.isinf(stable):
        return 1
    return max(1, math.ceil(abs(dt) / stable * (1.0 - 1e-12)))


class StepApplier:
    """Applies the processes' changes one step at a time, keeping across steps what a run
    keeps: the report (steps, sub-steps, budgets) and which sub-stepping notes were given.

    Within a step the processes are applied one after the other (operator splitting); each is
    sub-stepped when its stable time step is shorter than ``dt`` (a note is given once per
    process), or, with ``allow_substeps`` False or more than ``MAX_SUBSTEPS`` sub-steps, the
    run is refused (InputError). ``guard`` checks the elevation after each step and stops a
    diverging run (RunFailure)."""

    def __init__(self, processes: Sequence[Process], dt: float, allow_substeps: bool = True,
                 on_note: Callable[[str], None] | None = None, guard: DivergenceGuard | None = None,
                 steps: int = 1) -> None:
        if dt == 0.0 or not math.isfinite(dt):
            raise InputError("the time step must be a non-zero number of years.")
        self.processes, self.dt, self.allow_substeps = processes, dt, allow_substeps
        self.on_note, self.guard, self.steps = on_note, guard, steps
        self.report = RunReport(substeps={p.name: 0 for p in processes},
                                budgets={p.name: Budget() for p in processes})
        self.noted: set[str] = set()
        self.started = False

    def step(self, h: np.ndarray, i: int) -> None:
        """Advance ``h`` (m, changed in place) by step ``i`` (1-based)."""
        dt = self.dt
        for process in self.processes:
            try:
                n_sub = substeps_needed(dt, process.stable_dt(h, dt))
            except NoStableStep:
                self._no_stable_step(process.name, i)
            if n_sub > MAX_SUBSTEPS:
                raise InputError(
                    f"a time step of {abs(dt):g} years would need {float(n_sub):.3g} {process.name} "
                    f"sub-steps (stable: ≤ {abs(dt) / n_sub:.4g} years); lower --dt.")
            if n_sub > 1 and not self.allow_substeps:
                raise InputError(
                    f"the {process.name} time step of {abs(dt):g} years is unstable here "
                    f"(stable: ≤ {abs(dt) / n_sub:.4g} years); lower --dt or allow sub-steps."
                )
            if n_sub > 1 and process.name not in self.noted and self.on_note is not None:
                at = f" at step {i}" if self.steps > 1 else ""
                self.on_note(f"note: {process.name} is sub-stepped ({n_sub} sub-steps of "
                             f"{abs(dt) / n_sub:.4g} years{at}) to stay stable (CFL).")
                self.noted.add(process.name)
            for _ in range(n_sub):
                self.started = True
                change = process.advance(h, dt / n_sub)
                h += change.dh
                self.report.budgets[process.name].add(change.eroded, change.deposited, change.outflux,
                                                      change.inflow)
            self.report.substeps[process.name] += n_sub
        self.report.steps = i
        elapsed = self.report.elapsed_years = i * dt
        if self.guard is not None:
            self.guard.check(h, elapsed, f"in step {i} (t = {elapsed:g} y)")

    def _no_stable_step(self, name: str, i: int) -> None:
        """Refuse a process with no stable time step: bad parameters (InputError) when nothing
        was computed yet, else a run that became unstable (RunFailure)."""
        if not self.started:
            raise InputError(
                f"the {name} process has no stable time step on this terrain (no sub-step is short "
                "enough): its rate parameters are too large (e.g. --K or --k-th); lower them.")
        raise RunFailure(
            f"the run became unstable in step {i}: the {name} process has no stable time step any "
            "more (no sub-step is short enough); lower its rate parameters.")


def run(
    elevation: np.ndarray,
    processes: Sequence[Process],
    dt: float,
    steps: int,
    allow_substeps: bool = True,
    on_step: Callable[[int, np.ndarray], None] | None = None,
    on_note: Callable[[str], None] | None = None,
    guard: DivergenceGuard | None = None,
) -> tuple[np.ndarray, RunReport]:
    """Advance ``elevation`` (m) by ``steps`` steps of ``dt`` years through ``processes``
    (:class:`StepApplier`); ``on_step(i, h)`` is called after step i (1-based). The input
    array is not modified."""
    h = np.array(elevation, dtype=np.float64, copy=True)
    applier = StepApplier(processes, dt, allow_substeps, on_note, guard, steps)
    for i in range(1, steps + 1):
        applier.step(h, i)
        if on_step is not None:
            on_step(i, h)
    return h, applier.report
