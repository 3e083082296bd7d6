"""Option declarations: each option of a job is written once, as an :class:`Opt`.

One declaration feeds every front door and every record of a run:

- the job's dataclass field (:func:`declared` turns a job class into a frozen, keyword-only
  dataclass with one field per option, in declaration order);
- the command-line option or argument (``cli/declared.py`` builds the typer command from the
  declarations: flags, help text with its unit, default, bounds and help panel);
- the pipeline spec's checks and the input/output role of each path (``pipeline/``);
- the Python API's keyword arguments (``api.py``);
- the provenance written into each output's history (:meth:`Opt.recorded_as`);
- the equivalent command line printed by pipelines and stored in histories
  (:func:`command_line`).

Process parameters declared as :class:`~unerode_cli.processes.parameters.ParamSpec` become
options too (:func:`parameter_options`): text fields holding a number or a raster path.
"""

from __future__ import annotations

import dataclasses
import enum
import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from unerode_cli.io.parameter_file import named_rasters
from unerode_cli.processes.parameters import ParamSpec
from unerode_cli.run.values import OptionParser, ParameterValue, unit_suffix

Kind = Literal["value", "flag", "count", "multiple"]
Role = Literal["input", "output", "other"]

#: Names of the output options that are folders when their declaration does not say
#: (:attr:`Opt.folder`).
FOLDER_OUTPUTS = frozenset({"out", "out_dir"})

#: Name of the option that gives a parameter file (YAML: parameter → number or raster path).
PARAMETER_FILE = "params"


@dataclass(frozen=True)
class Opt:
    """One option (or positional argument) of a job.

    Attributes:
        name: the job's field (a Python identifier).
        type: type of one value: ``str``, ``int``, ``float`` or ``Path`` (``bool`` for flags).
        default: value when not given (``None``: absent; ignored when ``required``).
        help: help text, with the unit of the value.
        flags: command-line names, the long one first (default ``--name-with-dashes``).
        off_flag: for a flag that is on by default, the name that turns it off.
        kind: ``value`` (one value), ``flag`` (true/false), ``count`` (repeatable flag) or
            ``multiple`` (repeatable option; the field holds a list or None).
        argument: a positional argument (in declaration order).
        required: must be given.
        role: for paths, whether the job reads (``input``) or writes (``output``) them.
        panel: help panel the option is shown in.
        parser: check and conversion of one value's text (:mod:`unerode_cli.run.values`).
        choices: the values a choice option accepts.
        minimum / maximum: bounds of an integer option.
        record: whether the value goes into the output's provenance (True: under ``name``),
            or the key it is recorded under.
        metavar: placeholder of the value in the help.
        folder: for an output, whether it names a folder the job fills rather than a file
            (None: inferred, the outputs named ``out`` and ``out_dir`` are folders).
    """

    name: str
    type: type = str
    default: Any = None
    help: str = ""
    flags: tuple[str, ...] = ()
    off_flag: str = ""
    kind: Kind = "value"
    argument: bool = False
    required: bool = False
    role: Role = "other"
    panel: str | None = None
    parser: OptionParser | None = None
    choices: tuple[str, ...] = ()
    minimum: float | None = None
    maximum: float | None = None
    record: bool | str = True
    metavar: str | None = None
    folder: bool | None = None

    @property
    def long_flag(self) -> str:
        """The option's main command-line name (``--sea-level``); the argument's name in capitals."""
        if self.argument:
            return self.name.upper()
        return self.flags[0] if self.flags else "--" + self.name.replace("_", "-")

    @property
    def all_flags(self) -> tuple[str, ...]:
        return self.flags or (self.long_flag,)

    @property
    def recorded_as(self) -> str | None:
        """Key of the value in the provenance, None when it is not recorded."""
        if self.record is False:
            return None
        return self.name if self.record is True else str(self.record)

    @property
    def is_path(self) -> bool:
        return self.type is Path

    @property
    def is_folder(self) -> bool:
        """Whether this path option names a folder (a report or output folder), not a file."""
        if self.folder is not None:
            return self.folder
        return self.is_path and self.name in FOLDER_OUTPUTS

    def convert(self, value: Any) -> Any:
        """The field value of one given value (text from a spec, or a Python value): parsed,
        checked and typed as the command line does; ValueError (end of a sentence) when bad."""
        if self.kind == "flag":
            if isinstance(value, bool):
                return value
            text = str(value).lower()
            if text in ("true", "false"):
                return text == "true"
            raise ValueError(f"this flag takes true or false, got {value!r}")
        if self.kind == "count":
            if isinstance(value, bool):
                return int(value)
            count = int(value)
            if count < 0:
                raise ValueError(f"expected a count (0, 1, 2, ...), got {value!r}")
            return count
        if self.kind == "multiple":
            if value is None:
                return None
            items = value if isinstance(value, list | tuple) else [value]
            return [self._one(item) for item in items]
        return None if value is None else self._one(value)

    def _one(self, value: Any) -> Any:
        if isinstance(value, enum.Enum):
            value = value.value
        if self.parser is not None:
            return self.parser.parse(value)
        if self.choices:
            text = str(value)
            if text not in self.choices:
                raise ValueError(f"expected one of {', '.join(self.choices)}, got '{text}'")
            return text
        if self.type is Path:
            if isinstance(value, Path):
                return value
            if not str(value):
                raise ValueError("expected a path, got an empty value")
            return Path(str(value))
        if self.type is int:
            if isinstance(value, bool):
                raise ValueError(f"expected an integer, got {value}")
            try:
                number = int(str(value))
            except ValueError:
                raise ValueError(f"expected an integer, got '{value}'") from None
            if self.minimum is not None and number < self.minimum:
                raise ValueError(f"must be ≥ {self.minimum:g}, got {number}")
            if self.maximum is not None and number > self.maximum:
                raise ValueError(f"must be ≤ {self.maximum:g}, got {number}")
            return number
        if self.type is float:
            try:
                return float(value)
            except (TypeError, ValueError):
                raise ValueError(f"expected a number, got '{value}'") from None
        return str(value)

    def as_text(self, value: Any) -> list[str]:
        """The command-line words that give ``value`` to this option (none when it is the default)."""
        if self.argument:
            return [] if value is None else [str(item) for item in _items(value)]
        if self.kind == "flag":
            if value == self.default:
                return []
            if value:
                return [self.long_flag]
            return [self.off_flag] if self.off_flag else []
        if self.kind == "count":
            return [self.long_flag] * int(value or 0)
        if value is None or (value == self.default and not self.required):
            return []
        if self.kind != "multiple":
            return [self.long_flag, _word(value)]
        words: list[str] = []
        for item in _items(value):
            words += [self.long_flag, _word(item)]
        return words


def _items(value: Any) -> list[Any]:
    return list(value) if isinstance(value, list | tuple) and not isinstance(value, str) else [value]


def _word(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}" if float(f"{value:g}") == value else repr(value)
    if isinstance(value, tuple | list):
        return ",".join(_word(v) for v in value)
    return str(value)


def parameter_help(spec: ParamSpec) -> str:
    """Help text of a process parameter with unit, default, range and whether a raster is
    accepted, e.g. ``Erodibility [m^(1-2m)/y; default 2e-05; ≥ 0; a number or a raster]``."""
    bounds = []
    if spec.minimum is not None:
        bounds.append(f"≥ {spec.minimum:g}")
    if spec.maximum is not None:
        bounds.append(f"≤ {spec.maximum:g}")
    extra = f"; {', '.join(bounds)}" if bounds else ""
    raster = "; a number or a raster on the DEM's grid" if spec.raster else ""
    unit = unit_suffix(spec.unit).strip() or "dimensionless"
    return f"{spec.help} [{unit}; default {spec.default:g}{extra}{raster}]"


def parameter_options(groups: Mapping[str, Sequence[ParamSpec]]) -> tuple[Opt, ...]:
    """One text option per process parameter (``--NAME``, and ``--SYMBOL`` where the paper's
    symbol differs), in the help panel of its first group; None when not given (the job then
    takes the declaration's default or a ``--params`` file's value)."""
    options: dict[str, Opt] = {}
    for panel, specs in groups.items():
        for spec in specs:
            if spec.name in options:
                continue
            flags = [f"--{spec.name.replace('_', '-')}"]
            if spec.symbol and spec.symbol != spec.name:
                flags.append(f"--{spec.symbol.replace('_', '-')}")
            options[spec.name] = Opt(spec.name, str, None, parameter_help(spec), tuple(flags),
                                     panel=panel, parser=ParameterValue(spec), record=False)
    return tuple(options.values())


def declared(command: str, options: Sequence[Opt]):
    """Class decorator: make a job class a frozen keyword-only dataclass with one field per
    option of ``options``, and record them as ``OPTIONS`` (the process parameters' names as
    ``PARAMETERS``) with the subcommand name ``COMMAND``. Two options of one name, or two
    options sharing a flag, are refused."""
    every = tuple(options)
    names, flags = set(), set()
    for opt in every:
        if opt.name in names:
            raise ValueError(f"{command}: option {opt.name} is declared twice")
        names.add(opt.name)
        for flag in (*opt.all_flags, opt.off_flag) if not opt.argument else ():
            if flag and flag in flags:
                raise ValueError(f"{command}: flag {flag} is declared twice")
            flags.add(flag)

    def decorate(cls: type) -> type:
        annotations: dict[str, Any] = {}
        for opt in every:
            annotations[opt.name] = Any
            if opt.required:
                if hasattr(cls, opt.name):
                    delattr(cls, opt.name)
                continue
            if isinstance(opt.default, list | dict):
                setattr(cls, opt.name, dataclasses.field(default_factory=lambda d=opt.default: type(d)(d)))
            else:
                setattr(cls, opt.name, opt.default)
        cls.__annotations__ = annotations
        cls.COMMAND = command
        cls.OPTIONS = every
        cls.PARAMETERS = tuple(o.name for o in every if isinstance(o.parser, ParameterValue))
        return dataclass(frozen=True, kw_only=True)(cls)

    return decorate


def options_of(job: Any) -> dict[str, Opt]:
    """Name → declaration of each option of a job (class or instance)."""
    return {opt.name: opt for opt in job.OPTIONS}


def build(job_class: type, values: Mapping[str, Any]) -> Any:
    """A job from ``values`` (field name → text or Python value), each converted and checked
    by its declaration; unknown names and missing required options are refused (ValueError)."""
    declarations = options_of(job_class)
    fields: dict[str, Any] = {}
    for name, value in values.items():
        opt = declarations.get(name)
        if opt is None:
            raise ValueError(f"{job_class.COMMAND} has no option {name}")
        try:
            fields[name] = opt.convert(value)
        except ValueError as exc:
            raise ValueError(f"{opt.long_flag}: {str(exc).rstrip('.')}") from None
    missing = [o.long_flag for o in job_class.OPTIONS if o.required and fields.get(o.name) is None]
    if missing:
        raise ValueError(f"{job_class.COMMAND} needs {', '.join(missing)}")
    return job_class(**fields)


def provenance(job: Any) -> dict[str, Any]:
    """The recorded options of ``job`` (key → value), and the process parameters that were
    given, in declaration order: what an output's history says of the job's options."""
    record: dict[str, Any] = {}
    for opt in job.OPTIONS:
        key = opt.recorded_as
        if key is not None:
            record[key] = getattr(job, opt.name)
    return record


def command_line(job: Any) -> list[str]:
    """``[SUBCOMMAND, ...]``: the words after ``unerode-cli`` that run ``job`` (its arguments,
    then every option whose value is not the default)."""
    words = [job.COMMAND]
    arguments = [o for o in job.OPTIONS if o.argument]
    for opt in arguments:
        words += opt.as_text(getattr(job, opt.name))
    for opt in job.OPTIONS:
        if not opt.argument:
            words += opt.as_text(getattr(job, opt.name))
    return words


def shown(words: Sequence[str]) -> str:
    """A command line as logs show it: ``unerode-cli erode in.tif out.tif --dt 500``."""
    return shlex.join(["unerode-cli", *words])


def paths(job: Any, role: Role) -> list[Path]:
    """Every path the job's options name in ``role`` (input or output), in declaration order."""
    found: list[Path] = []
    for opt in job.OPTIONS:
        if opt.is_path and opt.role == role:
            found += [Path(p) for p in _items(getattr(job, opt.name)) if p is not None]
    return found


def outputs_of(job: Any) -> list[tuple[Opt, Path]]:
    """(declaration, path) of every output the job's options name, in declaration order."""
    found: list[tuple[Opt, Path]] = []
    for opt in job.OPTIONS:
        if opt.is_path and opt.role == "output":
            found += [(opt, Path(p)) for p in _items(getattr(job, opt.name)) if p is not None and str(p)]
    return found


def read_files(job: Any) -> list[Path]:
    """Every path the job reads as its options say, never to be one of its outputs: each path
    declared as an input, each value of another option that is not an output and names an
    existing file — a process parameter's raster or table (``--K k.tif``, ``--uplift T.csv``),
    an ELA table (``--ela e.csv``) — and each existing raster a parameter file (``--params``)
    names."""
    found: list[Path] = []
    for opt in job.OPTIONS:
        if opt.role == "output" or opt.kind in ("flag", "count"):
            continue
        for value in _items(getattr(job, opt.name)):
            if not isinstance(value, str | Path) or not str(value):
                continue
            path = Path(value)
            if (opt.is_path and opt.role == "input") or _is_file(path):
                found.append(path)
                if opt.name == PARAMETER_FILE and _is_file(path):
                    found += [raster for _, raster in named_rasters(path) if _is_file(raster)]
    return found


def resume_flag(job: Any) -> str:
    """The flag that continues an interrupted run of ``job`` (``--resume``), '' when it has none."""
    return next((opt.long_flag for opt in job.OPTIONS if opt.name == "resume" and opt.kind == "flag"), "")


def _is_file(path: Path) -> bool:
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False
