"""Progress of a run on stderr: a bar (rich) on a terminal, one line per step with ``-v`` (and
its wall time with ``-vv``), nothing with ``-q`` or when stderr is not a terminal."""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable, Iterator

from unerode_cli.cli.common import DEBUG, DETAIL, NOTE, say


@contextlib.contextmanager
def progress_bar(total: int, description: str, verbosity: int, cells: int = 0,
                 done: int = 0) -> Iterator[Callable[[str], None]]:
    """Yield ``advance(info)``, to be called once per completed unit of work, the first being
    unit ``done + 1`` (``done``: units of a resumed run done before); with ``cells`` (cells
    updated per unit) the bar and the ``-v`` lines show the rate in cells per second."""
    if verbosity >= DETAIL:
        yield _step_lines(total, description, verbosity, cells, done)
        return
    if verbosity < NOTE or not sys.stderr.isatty():
        yield lambda info="": None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TextColumn("{task.fields[info]}"), TextColumn("{task.fields[rate]}"), TimeElapsedColumn(),
               TimeRemainingColumn())
    pace = _CellRate(cells)
    with Progress(*columns, console=Console(stderr=True), transient=False) as bar:
        task = bar.add_task(description, total=total, completed=done, info="", rate="")
        yield lambda info="": bar.update(task, advance=1, info=info, rate=pace.advance())


def _step_lines(total: int, description: str, verbosity: int, cells: int = 0,
                done: int = 0) -> Callable[[str], None]:
    """``advance(info)`` that says ``DESCRIPTION k/N: INFO``, k counting on from ``done`` (with
    ``cells``: the rate in cells per second; with ``-vv``: and the step's wall time in seconds)."""
    last = time.perf_counter()
    pace = _CellRate(cells)

    def advance(info: str = "") -> None:
        nonlocal done, last
        done, now = done + 1, time.perf_counter()
        timing = f" ({now - last:.3f} s)" if verbosity >= DEBUG else ""
        rate = pace.advance()
        rate = f" [{rate}]" if rate else ""
        say(f"{description} {done}/{total}{': ' + info if info else ''}{rate}{timing}", verbosity, DETAIL)
        last = now

    return advance


class _CellRate:
    """Cells updated per second since the start, as text ("12.3 Mcells/s"; "" without cells)."""

    def __init__(self, cells: int) -> None:
        self.cells, self.units, self.start = cells, 0, time.perf_counter()

    def advance(self) -> str:
        self.units += 1
        elapsed = time.perf_counter() - self.start
        if not self.cells or elapsed <= 0.0:
            return ""
        rate = self.cells * self.units / elapsed
        return f"{rate / 1e6:.3g} Mcells/s" if rate >= 1e5 else f"{rate:,.0f} cells/s"


@contextlib.contextmanager
def simulated_time_bar(total_years: float, description: str,
                       verbosity: int) -> Iterator[Callable[[float, str], None]]:
    """Yield ``advance(years, info)``, to be called after each step with the simulated years
    done so far: a bar in simulated years with their rate (y/s) and the time left at that rate
    on a terminal; with ``-v`` one line per step (years done, rate, time left and ``info``, e.g.
    the solver's iterations and residual); nothing with ``-q`` or when stderr is not a terminal.
    The rate is measured from the first step reported on, so that a run resumed from a checkpoint
    (whose first report is already far into the run) gets a true time left."""
    pace = _Pace()
    if verbosity >= DETAIL:

        def line(years: float, info: str = "") -> None:
            rate = pace.rate(years)
            left = (total_years - years) / rate if rate > 0 else float("nan")
            say(f"{description} {years:,.0f}/{total_years:,.0f} y ({rate:,.3g} y/s, {left:,.0f} s left)"
                f"{': ' + info if info else ''}", verbosity, DETAIL)

        yield line
        return
    if verbosity < NOTE or not sys.stderr.isatty():
        yield lambda years, info="": None
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    columns = (TextColumn("{task.description}"), BarColumn(),
               TextColumn("{task.completed:,.0f}/{task.total:,.0f} y"),
               TextColumn("{task.fields[rate]}"), TextColumn("{task.fields[info]}"),
               TimeElapsedColumn(), TimeRemainingColumn())
    with Progress(*columns, console=Console(stderr=True), transient=False) as bar:
        task = bar.add_task(description, total=total_years, info="", rate="")

        def advance(years: float, info: str = "") -> None:
            rate = pace.rate(years)
            bar.update(task, completed=years, info=info, rate=f"{rate:,.3g} y/s" if rate > 0 else "")

        yield advance


class _Pace:
    """Simulated years per wall-clock second since the first report; 0 (not known yet) at the
    first report, whose step also loads the compiled kernels."""

    def __init__(self) -> None:
        self.first: tuple[float, float] | None = None  # (years, wall clock) of the first report

    def rate(self, years: float) -> float:
        now = time.perf_counter()
        if self.first is None:
            self.first = (years, now)
            return 0.0
        done, wall = years - self.first[0], now - self.first[1]
        return done / wall if wall > 0 and done > 0 else 0.0
