"""The one shape of every job, the progress it reports, and the executor that runs it.

A job is a frozen dataclass built once from its declared options (:mod:`unerode_cli.run.declare`)
by any front door — the command line, a pipeline step, an ensemble member, the Python API —
and run in three phases by :func:`execute`:

1. ``plan(outputs)``: read and check every input, clear every output on the
   :class:`~unerode_cli.io.paths.OutputPlan` (exists without ``--overwrite``, is an input,
   folder, format), estimate memory; no computation. Bad input raises
   :class:`~unerode_cli.errors.InputError` here, before any work. Before it, every file the
   job's options name for reading (:func:`~unerode_cli.run.declare.read_files`: declared
   inputs, parameter rasters and tables given as text, rasters a parameter file names) is
   recorded as an input of the plan, so that no output of any job is one of them, and the
   outputs its options name are checked (not an input, not two on one file, their folders
   writable); after it, the outputs are checked against the free space of their file systems.
2. ``run(planned, progress)``: the computation, on arrays. Long loops report through
   ``progress`` and stop early when ``progress.cancelled()`` says so.
3. ``write(result, outputs)``: the outputs, written atomically through the plan; returns the
   one-line summary.

A run that fails (:class:`~unerode_cli.errors.RunFailure`) keeps none of the files it wrote,
except when an output could not be written (:class:`~unerode_cli.errors.WriteFailure`): the
complete files written before it are kept.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any, ClassVar

from unerode_cli.errors import RunFailure, WriteFailure
from unerode_cli.io.paths import OutputPlan, os_error_reason
from unerode_cli.run import memory as _memory  # noqa: F401 - registers the memory check of every raster read
from unerode_cli.run.declare import Opt, command_line, outputs_of, provenance, read_files, resume_flag
from unerode_cli.run.unexpected import interrupt_cause


class Summary(str):
    """A job's one-line summary with the exit code its front door should end with (0 unless
    the job says otherwise, e.g. an ensemble some of whose members failed)."""

    exit_code: int

    def __new__(cls, text: str, exit_code: int = 0) -> Summary:
        summary = super().__new__(cls, text)
        summary.exit_code = exit_code
        return summary


class Progress:
    """What a job says while it runs, and how it learns that it should stop.

    The base class is silent and never cancels: the Python API's and quiet runs' choice.
    ``verbosity`` follows the command line's ``-v``/``-q`` count (0 by default)."""

    verbosity: int = 0

    def __init__(self, cancel: Callable[[], bool] | None = None, verbosity: int = 0) -> None:
        self._cancel = cancel
        self.verbosity = verbosity

    def start(self, total: float, label: str, unit: str = "steps", cells: int = 0, done: float = 0) -> None:
        """A loop of ``total`` units begins (``unit``: ``steps``, or ``years`` of simulated time);
        each step updates ``cells`` cells (0: not said); ``done`` of the units were done before
        (by the run a resumed run continues), so the first step counts as unit ``done + 1``."""

    def advance(self, info: str = "", done: float | None = None) -> None:
        """One more unit is done (or, with ``done``, that many units in all); ``info`` says
        what it was (e.g. the time reached, the solver's iterations)."""

    def finish(self) -> None:
        """The loop has ended (a bar is closed)."""

    def note(self, text: str) -> None:
        """A note for the user (shown unless ``-q``)."""

    def detail(self, text: str) -> None:
        """Per-step detail (shown with ``-v``)."""

    def data(self, text: str) -> None:
        """Data the job prints (``info``'s report): the command line writes it to stdout."""

    def cancelled(self) -> bool:
        """Whether the job should stop at the end of the current step."""
        return bool(self._cancel and self._cancel())


class StreamProgress(Progress):
    """Progress as lines on stderr, for jobs run inside a pipeline or an ensemble member: notes
    unless ``verbosity`` < 0, one line per step and details with ``verbosity`` ≥ 1; data on
    stdout."""

    def __init__(self, verbosity: int = 0, cancel: Callable[[], bool] | None = None) -> None:
        super().__init__(cancel, verbosity)
        self._label, self._total, self._done = "", 0.0, 0

    def start(self, total: float, label: str, unit: str = "steps", cells: int = 0, done: float = 0) -> None:
        self._label, self._total, self._done = label, total, int(done)

    def advance(self, info: str = "", done: float | None = None) -> None:
        self._done += 1
        if self.verbosity >= 1:
            where = (f"{done:,.0f}/{self._total:,.0f} y" if done is not None
                     else f"{self._done}/{self._total:g}")
            print(f"{self._label} {where}{': ' + info if info else ''}", file=sys.stderr)

    def note(self, text: str) -> None:
        if self.verbosity >= 0:
            print(text, file=sys.stderr)

    def detail(self, text: str) -> None:
        if self.verbosity >= 1:
            print(text, file=sys.stderr)

    def data(self, text: str) -> None:
        print(text)


class Job:
    """Base of every job (see the module docstring). Subclasses are made dataclasses by
    :func:`~unerode_cli.run.declare.declared`, which sets ``COMMAND`` and ``OPTIONS``."""

    COMMAND: ClassVar[str]
    OPTIONS: ClassVar[tuple[Opt, ...]]
    PARAMETERS: ClassVar[tuple[str, ...]] = ()

    def plan(self, outputs: OutputPlan) -> Any:
        raise NotImplementedError

    def run(self, planned: Any, progress: Progress) -> Any:
        return planned

    def write(self, result: Any, outputs: OutputPlan) -> str:
        return ""

    # What every job derives from its declarations.

    def provenance(self) -> dict[str, Any]:
        """The recorded options (see :func:`~unerode_cli.run.declare.provenance`)."""
        return provenance(self)

    def command_line(self) -> list[str]:
        """The equivalent command line, after ``unerode-cli``."""
        return command_line(self)

    def parameter_values(self) -> dict[str, str | None]:
        """The process parameters' texts as given (None where not given)."""
        return {name: getattr(self, name) for name in self.PARAMETERS}


def execute(job: Job, progress: Progress | None = None, outputs: OutputPlan | None = None) -> str:
    """Plan, run and write ``job`` with ``outputs`` (a new plan by default) active; returns the
    job's summary.

    Before the job plans, the files its options name for reading are inputs of the plan, and
    the outputs its options name are checked (InputError): none is an input (through links
    too), no two are one file, a file output is no folder, and each folder above them exists
    and is writable. After it plans, the outputs it cleared must fit in the free space
    (InputError). A :class:`RunFailure` removes the files written so far (recorded in
    ``outputs.removed``) before it propagates, except a :class:`WriteFailure` (an output that
    could not be written; an OSError of ``write`` becomes one), which keeps them; any
    exception leaves no temporary file. An exception that a Ctrl-C caused (numba's dispatcher
    reports one as a SystemError) is raised as the ``KeyboardInterrupt`` it is."""
    progress = progress or Progress()
    outputs = outputs or OutputPlan()
    with outputs.active():
        outputs.command_line = job.command_line()
        outputs.resume_flag = resume_flag(job)
        for path in read_files(job):
            outputs.read(path)
        try:
            outputs.check_destinations((path, opt.is_folder) for opt, path in outputs_of(job))
            planned = job.plan(outputs)
            outputs.check_space()
            result = job.run(planned, progress)
            progress.finish()
            try:
                return job.write(result, outputs)
            except OSError as exc:
                raise WriteFailure(f"writing the outputs failed: {os_error_reason(exc)}") from None
        except WriteFailure:
            raise
        except RunFailure:
            outputs.discard_written()
            raise
        except Exception as exc:
            if interrupt_cause(exc):    # Ctrl-C inside a compiled kernel's call, said as another error
                raise KeyboardInterrupt from None
            raise
        finally:
            progress.finish()
            outputs.remove_own_temporaries()
