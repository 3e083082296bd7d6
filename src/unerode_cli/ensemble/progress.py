"""How far an ensemble has gone: members done, running and failed, the time left (ETA), and
whether the cluster ran them faster than one after the other would have.

The ETA is the pace so far: (wall time since the first member was handed to the cluster) ÷
(members ended) × (members left), in seconds. The speed-up is Σ members' wall times ÷ the wall
time of the whole run: how many members ran side by side on average.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

#: Idle cores (cores − the 1-minute load average) below which the machine counts as busy: a
#: local cluster's workers then share their cores with other work, and the members run no
#: faster side by side than one after the other.
BUSY_IDLE_CORES = 0.5


@dataclass
class Tally:
    """Members of an ensemble as they end: ``total`` to run, ``done``, ``failed``, and the sum of
    their wall times ``busy_s`` (s); the clock starts when the tally is made."""

    total: int
    done: int = 0
    failed: int = 0
    busy_s: float = 0.0
    started_s: float = field(default_factory=time.perf_counter)

    @property
    def ended(self) -> int:
        return self.done + self.failed

    def heard(self, finished: bool, wall_s: float | None) -> None:
        """Count one member that ended (``finished``, else failed) after ``wall_s`` seconds."""
        if finished:
            self.done += 1
        else:
            self.failed += 1
        self.busy_s += wall_s or 0.0

    def eta_s(self, now: float | None = None) -> float | None:
        """Seconds left at the pace so far (None before the first member ended)."""
        if not self.ended:
            return None
        elapsed = (time.perf_counter() if now is None else now) - self.started_s
        return elapsed / self.ended * (self.total - self.ended)

    def line(self, running: int, now: float | None = None) -> str:
        """"3 done, 2 running, 1 failed of 8; about 1 min 20 s left"."""
        running = max(0, min(running, self.total - self.ended))
        text = f"{self.done} done, {running} running, {self.failed} failed of {self.total}"
        eta = self.eta_s(now)
        if eta is not None and self.ended < self.total:
            text += f"; about {duration(eta)} left"
        return text

    def speedup(self, now: float | None = None) -> float | None:
        """Σ members' wall times ÷ the run's wall time (None before any member ended)."""
        elapsed = (time.perf_counter() if now is None else now) - self.started_s
        return self.busy_s / elapsed if self.ended and elapsed > 0 else None


def duration(seconds: float) -> str:
    """"45 s", "3 min 20 s", "2 h 05 min"."""
    seconds = max(0, round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60:02d} s"
    return f"{seconds // 3600} h {seconds % 3600 // 60:02d} min"


def slow_cluster_warning(local: bool, cores: int, workers: int, load: float) -> str | None:
    """Why a local cluster of several workers is not expected to run the members faster than one
    after the other, or None: the machine's ``cores`` are already busy (the 1-minute ``load``
    average leaves fewer than :data:`BUSY_IDLE_CORES` idle). On idle cores several workers are
    faster even on two cores: members of a few hundred thousand cells gain little from a
    second numba thread, and each worker's start is paid once (the Tautavel ensemble on 2
    idle cores: 2.0× faster with 2 workers than with ``--workers 1``)."""
    if local and workers > 1 and cores - load < BUSY_IDLE_CORES:
        return (f"the machine is busy (load {load:.1f} on {cores} core(s)): the {workers} workers will "
                "share those cores with other work and are not expected to be faster than running "
                "the members one after the other (--workers 1)")
    return None


def short_members_warning(tally: Tally, start_s: float, workers: int) -> str | None:
    """When the members took on average less time (s) than the cluster took to start
    (``start_s``, s), the start outweighed what running them side by side saved; None otherwise."""
    if workers <= 1 or not tally.ended or start_s <= 0:
        return None
    mean = tally.busy_s / tally.ended
    if mean >= start_s:
        return None
    return (f"the members took {mean:.1f} s each on average, less than the {start_s:.1f} s the cluster "
            f"of {workers} workers took to start: running them one after the other in one process "
            "(--workers 1) is likely faster for members this short")
