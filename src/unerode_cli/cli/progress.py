"""Progress of a run on stderr: a bar (rich) on a terminal, one line per step with ``-v`` (and
its wall time with ``-vv``), nothing with ``-q`` or when stderr is not a terminal."""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable, Iterator

from unerode_cli.cli.common import DEBUG, DETAIL, NOTE, say


@contextlib.contextmanager
def progress_bar(total: int, description: str, verbosity: int) -> Iterator[Callable[[str], None]]:
    """Yield ``advance(info)``, to be called once per completed unit of work."""
    if verbosity >= DETAIL:
        yield _step_lines(total, description, verbosity)
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
               TextColumn("{task.fields[info]}"), TimeElapsedColumn(), TimeRemainingColumn())
    with Progress(*columns, console=Console(stderr=True), transient=False) as bar:
        task = bar.add_task(description, total=total, info="")
        yield lambda info="": bar.update(task, advance=1, info=info)


def _step_lines(total: int, description: str, verbosity: int) -> Callable[[str], None]:
    """``advance(info)`` that says ``DESCRIPTION k/N: INFO`` (with ``-vv``: and the step's wall
    time in seconds)."""
    done, last = 0, time.perf_counter()

    def advance(info: str = "") -> None:
        nonlocal done, last
        done, now = done + 1, time.perf_counter()
        timing = f" ({now - last:.3f} s)" if verbosity >= DEBUG else ""
        say(f"{description} {done}/{total}{': ' + info if info else ''}{timing}", verbosity, DETAIL)
        last = now

    return advance
