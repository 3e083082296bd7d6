"""One member of an ensemble, as a dask worker runs it: its pipeline in its own emptied folder,
each step a job run in the worker's process (no shell, no change of folder), ``member.json``
first, what the steps print kept in ``member.log``, and the done marker
``done.json`` last when every step succeeded (the files are those of
:mod:`unerode_cli.io.ensemble_files`). A failing step is reported in the :class:`Outcome`, not
raised: the other members go on. Kept apart from the planning and the summary so that a worker
imports only what running a member needs."""

from __future__ import annotations

import contextlib
import io
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from unerode_cli.ensemble.sweep import Value
from unerode_cli.errors import InputError
from unerode_cli.io.ensemble_files import (
    DONE_FILE,
    LOG_FILE,
    MEMBER_FILE,
    fresh_folder,
    write_record,
    write_text,
)
from unerode_cli.io.provenance import record_time
from unerode_cli.pipeline.pipeline_run import Executor, StepFailed, run_pipeline
from unerode_cli.pipeline.spec import ResolvedPipeline


@dataclass(frozen=True)
class Member:
    """One member: its folder, swept values and pipeline (None, with ``error``, when its spec
    does not resolve)."""

    index: int
    folder: Path
    parameters: dict[str, Value]
    pipeline: ResolvedPipeline | None
    error: str | None = None


@dataclass(frozen=True)
class Outcome:
    """How a member's run ended: ``step`` and ``error`` say where and why it failed."""

    index: int
    finished: bool
    wall_s: float | None
    step: str | None = None
    error: str | None = None


def is_done(member: Member) -> bool:
    """Whether a member finished in an earlier run: its done marker and outputs are there."""
    if member.pipeline is None or not (member.folder / DONE_FILE).exists():
        return False
    return all(p.exists() for step in member.pipeline.steps for p in step.outputs)


def member_record(member: Member) -> dict[str, Any]:
    return {"index": member.index, "parameters": member.parameters}


def run_member(member: Member, verbosity: int = 0, executor: Executor | None = None) -> Outcome:
    """Run one member's pipeline in its emptied folder (in a dask worker): ``member.json``
    first, ``member.log`` after, ``done.json`` last when every step succeeded."""
    assert member.pipeline is not None
    started = time.perf_counter()
    fresh_folder(member.folder)
    write_record(member.folder / MEMBER_FILE, member_record(member))
    log = io.StringIO()
    step, error = None, None
    with contextlib.redirect_stdout(log), contextlib.redirect_stderr(log):
        try:
            run_pipeline(member.pipeline, resume=False, verbosity=verbosity,
                         note=lambda text: print(text, file=sys.stderr), executor=executor)
        except StepFailed as exc:
            step, error = exc.step, _last_error(log.getvalue()) or str(exc)
        except (InputError, RuntimeError) as exc:
            error = str(exc)
    write_text(member.folder / LOG_FILE, log.getvalue())
    wall = time.perf_counter() - started
    if error is None:
        finished = record_time()
        write_record(member.folder / DONE_FILE, {"wall_s": wall, "finished": finished})
    return Outcome(member.index, error is None, wall, step, error)


def _last_error(text: str) -> str | None:
    """The last ``error: ...`` line a step printed, without the prefix."""
    lines = [line[len("error: "):] for line in text.splitlines() if line.startswith("error: ")]
    return lines[-1] if lines else None
