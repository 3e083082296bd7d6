"""Typer commands built from job declarations (:mod:`unerode_cli.run.declare`).

:func:`command` turns a job class into a typer command: one argument or option per declared
option (flags, help text, default, bounds, choices and help panel from the declaration), plus
``-v``/``-q``. The command builds the job from the parsed values, runs it with
:func:`~unerode_cli.run.job.execute` under :func:`~unerode_cli.cli.errors.reported_errors`, and
shows progress on stderr (:class:`TerminalProgress`). Job modules are imported only when the
command runs, so ``--help`` answers at once.
"""

from __future__ import annotations

import enum
import functools
import importlib
import inspect
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer

from unerode_cli.cli.common import DETAIL, NOTE, SUMMARY, say
from unerode_cli.cli.errors import EXIT_BAD_INPUT, reported_errors
from unerode_cli.cli.options import Quiet, Verbose
from unerode_cli.cli.values import for_typer
from unerode_cli.run.declare import Opt

#: The message of a positional input file that does not exist (``path`` filled in).
MISSING_INPUT = "input {path} does not exist."


def _escaped(text: str) -> str:
    """Help text for rich: ``[`` would open a markup tag."""
    return text.replace("[", "\\[")


@functools.cache
def _choice_enum(choices: tuple[str, ...]) -> type[enum.Enum]:
    return enum.Enum("Choice", {value: value for value in choices}, type=str)  # type: ignore[return-value]


def parameter(opt: Opt) -> inspect.Parameter:
    """The typer parameter of one declaration."""
    if opt.kind == "flag":
        base: Any = bool
    elif opt.kind == "count":
        base = int
    elif opt.choices:
        base = _choice_enum(opt.choices)
    else:
        base = opt.type
    if opt.kind == "multiple":
        base = list[base]  # type: ignore[valid-type]
    annotation: Any = base if opt.required or opt.kind in ("flag", "count") else base | None
    info: dict[str, Any] = {"help": _escaped(opt.help)}
    if opt.parser is not None:
        info["parser"] = for_typer(opt.parser)
    if opt.minimum is not None and opt.type is int and opt.parser is None:
        info["min"] = opt.minimum
    if opt.maximum is not None and opt.type is int and opt.parser is None:
        info["max"] = opt.maximum
    if opt.metavar:
        info["metavar"] = opt.metavar
    default = ... if opt.required else opt.default
    if opt.choices and default not in (None, ...):
        default = _choice_enum(opt.choices)(default)
    if opt.argument:
        marker = typer.Argument(**info, show_default=default not in (None, ...))
    else:
        flags = list(opt.all_flags)
        if opt.off_flag:
            flags = [f"{flags[0]}/{opt.off_flag}", *flags[1:]]
        if opt.kind == "count":
            info["count"] = True
            info.setdefault("metavar", "")               # a counter (-v, -vv): no value to show
        if opt.panel:
            info["rich_help_panel"] = opt.panel
        marker = typer.Option(*flags, **info,
                              show_default=opt.default is not None and opt.kind != "count")
    return inspect.Parameter(opt.name, inspect.Parameter.KEYWORD_ONLY, default=default,
                             annotation=Annotated[annotation, marker])


def plain(value: Any) -> Any:
    """A typer value as the job takes it (an enum member becomes its text)."""
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


def command(job_path: str, help: str, epilog: str | None = None,
            options: tuple[Opt, ...] | None = None, missing: str = MISSING_INPUT) -> Callable[..., None]:
    """A typer command for the job class ``module:Class`` (imported when the command runs;
    ``options`` are its declarations, imported now). A positional input path that does not
    exist ends the command before the job's module is imported, with ``missing`` (formatted with
    ``path``). The summary goes to stderr; a summary that carries an exit code ends the command
    with it."""
    module_name, class_name = job_path.split(":")
    declarations = options if options is not None else _job_class(module_name, class_name).OPTIONS
    inputs = [opt.name for opt in declarations if opt.argument and opt.role == "input" and opt.is_path]
    params = [parameter(opt) for opt in declarations]
    verbose_quiet = [
        inspect.Parameter("verbose", inspect.Parameter.KEYWORD_ONLY, default=0, annotation=Verbose),
        inspect.Parameter("quiet", inspect.Parameter.KEYWORD_ONLY, default=0, annotation=Quiet),
    ]

    def run_command(**kwargs: Any) -> None:
        verbosity = kwargs.pop("verbose") - kwargs.pop("quiet")
        refuse_missing_inputs([kwargs[name] for name in inputs], missing)
        with reported_errors(verbosity) as outputs:
            from unerode_cli.pipeline.commands import run_job

            job_class = _job_class(module_name, class_name)
            job = job_class(**{name: plain(value) for name, value in kwargs.items()})
            summary = run_job(job, TerminalProgress(verbosity), outputs)
            if summary:
                say(summary, verbosity, SUMMARY)
            if getattr(summary, "exit_code", 0):
                raise typer.Exit(summary.exit_code)

    run_command.__signature__ = inspect.Signature(params + verbose_quiet)  # type: ignore[attr-defined]
    run_command.__annotations__ = {p.name: p.annotation for p in params + verbose_quiet}
    run_command.__doc__ = help
    run_command.epilog = epilog  # type: ignore[attr-defined]
    return run_command


def refuse_missing_inputs(values: list[Any], missing: str = MISSING_INPUT) -> None:
    """End the command (exit 2) with ``error: MISSING.`` for the first path of ``values`` (paths
    or lists of paths) that does not exist: the existence check of the input files, done before
    any numerical or GIS library is imported; the job's own checks of its inputs come later."""
    for value in values:
        for path in value if isinstance(value, list) else [value]:
            if isinstance(path, Path) and not path.exists():
                print(f"error: {missing.format(path=path)}", file=sys.stderr)
                raise typer.Exit(EXIT_BAD_INPUT)


def _job_class(module_name: str, class_name: str) -> Any:
    return getattr(importlib.import_module(module_name), class_name)


class TerminalProgress:
    """Progress on stderr: a bar (rich) on a terminal, one line per step with ``-v`` (its wall
    time with ``-vv``), nothing with ``-q`` or when stderr is not a terminal; notes unless
    ``-q``; data on stdout."""

    def __init__(self, verbosity: int) -> None:
        self.verbosity = verbosity
        self._bar: Any = None
        self._advance: Callable[..., None] | None = None
        self._unit = "steps"

    def start(self, total: float, label: str, unit: str = "steps", cells: int = 0, done: float = 0) -> None:
        from unerode_cli.cli.progress import progress_bar, simulated_time_bar

        self.finish()
        self._unit = unit
        if unit == "years":
            self._bar = simulated_time_bar(float(total), label, self.verbosity)
        else:
            self._bar = progress_bar(int(total), label, self.verbosity, cells, done=int(done))
        self._advance = self._bar.__enter__()

    def advance(self, info: str = "", done: float | None = None) -> None:
        if self._advance is None:
            return
        if self._unit == "years":
            self._advance(float(done or 0.0), info)
        else:
            self._advance(info)

    def finish(self) -> None:
        if self._bar is not None:
            bar, self._bar, self._advance = self._bar, None, None
            bar.__exit__(*sys.exc_info())

    def note(self, text: str) -> None:
        say(text, self.verbosity, NOTE)

    def detail(self, text: str) -> None:
        say(text, self.verbosity, DETAIL)

    def data(self, text: str) -> None:
        typer.echo(text)

    def cancelled(self) -> bool:
        return False


__all__ = ["command", "parameter", "plain", "refuse_missing_inputs", "TerminalProgress", "Path"]
