"""The one time-stepping loop of every job that steps in time (erode/unerode, climate-run,
glaciate, particle-erode, sandstone): progress, stop, checkpoints and resume.

A job hands :func:`step_through` a :class:`Stepper` — its own state and how to advance it by one
step — and the loop does the rest, the same way for every job:

- **Resume.** With ``resume`` and a checkpoint of the same run (equal fingerprint: same inputs,
  options and version), the stepper's state is restored and the loop goes on after the
  checkpoint's step, so that the result is bit for bit that of a run never stopped. A checkpoint
  of another run is refused (InputError); none at all starts from the beginning with a note.
- **Progress.** ``progress.start`` once (a resumed run's with the steps done before, so that it
  counts on: step 41 of 80), ``progress.advance`` after each step with what the step reports
  (its info text, and for runs counted in years the simulated years done).
- **Stop.** After ``max_steps`` steps of this invocation, or when ``progress.cancelled()`` says so,
  the loop writes a checkpoint and returns normally with ``finished`` False.
- **Checkpoints.** Every ``every`` steps, and at a stop, the stepper's state is saved atomically
  (:func:`~unerode_cli.io.checkpoints.write_state_checkpoint`); a finished run removes it.
- **Limit.** A run of more than :data:`MAX_STEPS` steps (10 million) is refused (InputError,
  exit 2) before any step: jobs check their step count in ``plan()`` with
  :func:`check_step_count`, and the loop checks it again before the first step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from unerode_cli.errors import InputError
from unerode_cli.io.checkpoints import read_state_checkpoint, write_state_checkpoint
from unerode_cli.run.job import Progress


@dataclass(frozen=True)
class StepInfo:
    """What one step reports: ``info`` for the progress line, ``done`` the simulated years done
    so far (for runs whose progress counts years), and ``last`` when the run has reached its end
    (for runs whose number of steps is not known in advance, e.g. adaptive time steps)."""

    info: str = ""
    done: float | None = None
    last: bool = False


class Stepper(Protocol):
    """A job's time-stepping state, as :func:`step_through` drives it."""

    def step(self, k: int) -> StepInfo:
        """Advance from the end of step ``k`` (0-based: ``k`` steps done) by one step."""

    def state(self) -> dict[str, Any]:
        """Everything needed to go on bit for bit after the steps done: NumPy arrays, numbers,
        text, and lists or mappings of them."""

    def restore(self, state: dict[str, Any]) -> None:
        """Take back a state that :meth:`state` gave."""


@dataclass(frozen=True)
class Checkpoints:
    """Where and how often a run is checkpointed: ``path`` (None: never), every ``every``
    steps, continued when ``resume``; ``fingerprint`` names the run; ``compressed``: the
    checkpoint is zip-deflated (large particle states)."""

    path: Path | None
    every: int = 10
    resume: bool = False
    fingerprint: str = ""
    compressed: bool = False


@dataclass(frozen=True)
class Stepped:
    """How the loop ended: ``done`` steps done in all (``first`` of them before this
    invocation), ``finished`` when every step is done."""

    done: int
    first: int
    finished: bool


NO_CHECKPOINTS = Checkpoints(None)

#: The most time steps one run may take (a documented limit: at a millisecond a step, about
#: three hours; longer runs are split with --max-steps and --resume, or take a larger --dt).
MAX_STEPS = 10_000_000


def check_step_count(count: float, how: str,
                     change: str = "give a larger --dt or a shorter --duration") -> int:
    """The step count ``count`` of a run as a whole number, refused (InputError) when it is not
    finite or exceeds :data:`MAX_STEPS`. ``how`` says where the count comes from ("--duration
    1e+308 y in steps of --dt 1000 y", "--steps"), ``change`` what to change."""
    if not (math.isfinite(count) and count <= MAX_STEPS):
        shown = f"{count:,.0f}" if math.isfinite(count) and count < 1e18 else f"{count:.3g}"
        raise InputError(f"{how} gives {shown} time steps, more than the limit of {MAX_STEPS:,} steps per "
                         f"run; {change}.")
    return max(int(round(count)), 0)


def step_through(stepper: Stepper, steps: int | None, progress: Progress, label: str,
                 checkpoints: Checkpoints = NO_CHECKPOINTS, max_steps: int | None = None,
                 years: float | None = None, cells: int = 0) -> Stepped:
    """Run ``steps`` steps of ``stepper`` (see the module docstring), or with ``steps`` None
    until a step reports ``last``. ``years``: the simulated years of the whole run when progress
    counts years (steps report ``done``), else None. ``cells``: the cells a step updates, for
    the progress's rate in cells per second (0: none shown)."""
    if steps is not None:
        check_step_count(steps, f"this {label} run", "give a larger --dt or fewer steps")
    first = _resumed(stepper, steps, progress, checkpoints)
    end = steps if steps is not None else float("inf")
    last = end if max_steps is None else min(end, first + max_steps)
    if years is None:
        if steps is None:
            raise ValueError("a run whose number of steps is not known counts its progress in years")
        progress.start(steps, label, cells=cells, done=first)
    else:
        progress.start(years, label, unit="years")
    k = first
    while k < last:
        report = stepper.step(k)
        k += 1
        progress.advance(report.info, report.done)
        ended = report.last or k >= end
        stop = not ended and (k == last or progress.cancelled())
        if checkpoints.path is not None and (k % checkpoints.every == 0 or stop):
            write_state_checkpoint(checkpoints.path, checkpoints.fingerprint, k, stepper.state(),
                                   checkpoints.compressed)
        if ended or stop:
            return Stepped(k, first, ended)
    return Stepped(k, first, k >= end)


def finish_checkpoints(checkpoints: Checkpoints, stepped: Stepped) -> None:
    """Remove the checkpoint of a run that has finished (a stopped run keeps it)."""
    if checkpoints.path is not None and stepped.finished:
        checkpoints.path.unlink(missing_ok=True)


def _resumed(stepper: Stepper, steps: int | None, progress: Progress, checkpoints: Checkpoints) -> int:
    """Steps already done: 0, or with ``resume`` those of this run's checkpoint (restored)."""
    path = checkpoints.path
    if path is None or not checkpoints.resume:
        return 0
    if not path.exists():
        progress.note(f"note: no checkpoint {path.name} to resume from; starting from the beginning.")
        return 0
    fingerprint, done, state = read_state_checkpoint(path)
    if fingerprint != checkpoints.fingerprint:
        raise InputError(f"the checkpoint {path} belongs to a run with other inputs or options; run "
                         "without --resume (or with the same options).")
    stepper.restore(state)
    progress.note(f"note: resuming after step {done}" + (f" of {steps}." if steps is not None else "."))
    return done
