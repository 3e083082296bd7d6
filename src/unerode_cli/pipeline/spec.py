"""Pipeline specs (YAML): the model, variable substitution and validation before any step runs.

A spec chains subcommands of ``unerode-cli``; each step is built as the subcommand's job from
its values and run in the pipeline's process (see ``pipeline_run``)::

    version: 1
    vars:                      # name -> string, number or boolean; `--var NAME=VALUE` overrides
      size: 32                 # (null: the value must be given with --var)
      dt: 1000
    workdir: runs/demo         # optional; default: the spec's folder (relative to it);
                               # created by `pipeline run` when missing
    steps:
      - name: terrain          # unique; letters, digits, _ . -
        run: synth             # a subcommand of unerode-cli
        args: [terrain.tif]    # positional arguments, in order
        options: {size: "${size}", seed: 3, kind: mountain}
      - name: eroded
        run: erode
        args: ["${steps.terrain.output}", eroded.tif]
        options:
          steps: 2             # a value option: one value
          dt: "${dt}"
          no-substep: true     # a flag: true gives --no-substep, false leaves it out
          co: [ZLEVEL=9]       # a repeatable option: a list (or one value)
          preview: eroded.png  # an output option: also an output of the step
      - name: picture
        run: preview
        args: ["${steps.eroded.output}", eroded_hillshade.png]
        outputs: []            # extra files the command writes (e.g. snapshots)

Option keys are the long option names without ``--`` (``sea-level``, ``K-d``); ``_`` may stand
for ``-``. ``${name}`` is replaced by the variable's value anywhere in ``args``, ``options``,
``outputs`` and ``workdir``; a value that is exactly ``${name}`` keeps the variable's type.
``$${`` gives a literal ``${``; variable values are not themselves substituted. A ``--var``
value is text, checked like any other value where it is used. Relative paths are relative to
the workdir, where every step runs.

**Outputs.** A step's outputs are, in this order: its positional path arguments that are
outputs (the ``OUT`` of ``SUBCOMMAND IN OUT``, the only argument of ``synth OUT``), the output
path options it is given (``--preview``, ``--change-map``), then its explicit ``outputs:``
list. ``${steps.NAME.output}`` is the first of them, written as the spec gave it; ``NAME``
must be an earlier step. The runner decides when to pass ``--overwrite`` (see ``pipeline_run``):
a step replaces only files that this spec wrote, whatever its ``overwrite: true`` says.
Which parameters are output paths is told by the jobs' declarations
(:class:`CommandSchema`, built by :mod:`unerode_cli.pipeline.commands`).

**Confinement.** A spec may be written by someone else, so every path it names is checked
after symbolic links are resolved (:class:`Confinement`): the workdir must lie in the spec's
folder, every output in the workdir, and every input (raster paths inside a ``--params`` file
included) in the workdir, the spec's folder, a ``--data`` folder or the shipped folders of the
unerode-cli checkout that runs it (:func:`checkout_folders`: its ``sample_dems/`` and
``pipelines/``, and the ``shared/data`` folder beside it, read by the shipped specs). Values given
with ``--var`` are checked where they are used. ``--allow-outside PATH`` (the user's own
decision) admits PATH and what lies below it for all three. A path leading elsewhere
(``../../x.tif``, an absolute path, a symbolic link out of the folder) is refused before any
step runs.

**Validation** raises :class:`~unerode_cli.errors.InputError` (exit code 2) naming the step and
the field (``step 'past' (options.dt): ...``) for: an unknown subcommand or option, a value of
the wrong type (a list for a flag, text for a number, a choice not offered), an undefined
variable, a reference to an unknown or later step, an input file that neither exists nor is
written by an earlier step, two steps writing the same file, duplicate step names, and a path
outside its confinement (:class:`OutsideError`, an InputError).
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, TypeVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from unerode_cli.errors import InputError
from unerode_cli.io.parameter_file import named_rasters
from unerode_cli.io.yaml_files import read_yaml_mapping

Scalar = str | int | float | bool
NAME_PATTERN = r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$"
_REFERENCE = re.compile(r"\$(\$?)\{([^}]*)\}")
_GLOB = re.compile(r"[*?\[]")
#: The option whose file names parameter rasters (erode's and unerode's ``--params``).
PARAMETER_FILE = "params"


# ---------------------------------------------------------------------------------------------
# What the jobs' declarations tell us about each subcommand (see pipeline.commands).

@dataclass(frozen=True)
class ParamSchema:
    """One parameter of a subcommand, as far as a spec needs to know it.

    ``kind``: ``value`` (one value), ``multiple`` (repeatable), ``flag`` (true/false),
    ``count`` (repeated flag, e.g. ``-v``). ``type``: ``path``, ``int``, ``float``, ``str`` or
    ``choice``. ``role``: ``input`` or ``output`` for path parameters, ``other`` else.
    ``parse``: the subcommand's own check of one value's text (finite, in range, well formed),
    raising ValueError with the end of a sentence; None when it has none.
    """

    name: str
    flags: tuple[str, ...] = ()
    kind: Literal["value", "multiple", "flag", "count"] = "value"
    type: Literal["path", "int", "float", "str", "choice"] = "str"
    role: Literal["input", "output", "other"] = "other"
    choices: tuple[str, ...] = ()
    minimum: float | None = None
    maximum: float | None = None
    required: bool = False
    off_flags: tuple[str, ...] = ()
    parse: Callable[[str], object] | None = None


@dataclass(frozen=True)
class CommandSchema:
    """A subcommand: its positional arguments (in order) and options by spec key."""

    name: str
    arguments: tuple[ParamSchema, ...]
    options: Mapping[str, ParamSchema]

    def option(self, key: str) -> ParamSchema | None:
        """The option a spec key names (``sea-level``, ``sea_level`` or ``--sea-level``)."""
        bare = key.lstrip("-")
        return self.options.get(bare) or self.options.get(bare.replace("_", "-"))


# ---------------------------------------------------------------------------------------------
# Where a spec's paths may lead.

class OutsideError(InputError):
    """A path of a spec leads outside its confinement (exit code 2, like any bad input; an
    ensemble refuses itself whole for it rather than failing one member)."""


#: The folders of a checkout whose files every spec may read (relative to the repository).
SHIPPED_FOLDERS = ("sample_dems", "pipelines")


def checkout_folders() -> tuple[Path, ...]:
    """The folders of the unerode-cli source checkout this code runs from that specs may
    read: the shipped sample DEMs and pipeline tables (:data:`SHIPPED_FOLDERS` of the
    repository, ``pyproject.toml`` above ``src/unerode_cli``) and the ``shared/data`` folder
    beside the repository, where the shipped specs find their chronologies; none for an
    installed package. The rest of the checkout (sources, virtual environment) is not among
    them."""
    package = Path(__file__).resolve().parents[1]
    root = package.parents[1]
    if package.parent.name != "src" or not (root / "pyproject.toml").is_file():
        return ()
    folders = [root / name for name in SHIPPED_FOLDERS] + [root.parent / "shared" / "data"]
    return tuple(folder.resolve() for folder in folders if folder.is_dir())


@dataclass(frozen=True)
class Confinement:
    """Where the paths of a spec may lead (see the module docstring): ``data``, folders of
    ``--data`` (inputs); ``allowed``, paths of ``--allow-outside`` (inputs, outputs and the
    workdir); ``shipped``, the checkout's folders (inputs); ``writes_in`` names the place of
    outputs in messages. Paths are compared after symbolic links are resolved."""

    data: tuple[Path, ...] = ()
    allowed: tuple[Path, ...] = ()
    shipped: tuple[Path, ...] = field(default_factory=checkout_folders)
    writes_in: str = "the workdir"

    @classmethod
    def from_options(cls, data: list[Path] | None, allowed: list[Path] | None,
                     writes_in: str = "the workdir") -> Confinement:
        """From ``--data`` (existing folders) and ``--allow-outside``; InputError when a
        ``--data`` folder is not one."""
        for folder in data or []:
            if not Path(folder).expanduser().is_dir():
                raise InputError(f"--data {folder}: no such folder; give a folder whose files the spec "
                                 "may read.")
        return cls(tuple(Path(f).expanduser().resolve() for f in data or []),
                   tuple(Path(p).expanduser().resolve() for p in allowed or []), writes_in=writes_in)

    def admits(self, path: Path, *roots: Path) -> bool:
        """Whether the resolved ``path`` lies in one of ``roots`` or of ``--allow-outside``."""
        return any(path == root or path.is_relative_to(root) for root in (*roots, *self.allowed))

    def read_roots(self, workdir: Path, spec_folder: Path) -> tuple[Path, ...]:
        """Every folder (or file) whose content a step may read, ``--allow-outside`` paths
        included."""
        return (workdir, spec_folder, *self.data, *self.shipped, *self.allowed)

    def check_workdir(self, text: str, workdir: Path, spec_folder: Path) -> None:
        """Refuse a workdir outside the spec's folder."""
        if not self.admits(workdir, spec_folder):
            raise OutsideError(f"spec field 'workdir': {text} leads to {workdir}, outside the spec's "
                               f"folder {spec_folder}; a spec works inside its own folder (pass "
                               f"--allow-outside {workdir} if you trust it).")

    def check_output(self, context: str, text: str, path: Path, workdir: Path) -> None:
        """Refuse an output outside the workdir."""
        if not self.admits(path, workdir):
            raise OutsideError(f"{context}: output {text} leads to {path}, outside {self.writes_in} "
                               f"{workdir}; a spec writes only there (pass --allow-outside {path} if "
                               "you trust it).")

    def check_input(self, context: str, text: str, path: Path, workdir: Path, spec_folder: Path,
                    subject: str = "") -> None:
        """Refuse an input outside the workdir, the spec's folder, the ``--data`` folders and
        the checkout; in an input folder, a symbolic link leading out as well. ``subject``
        says what names the path in the message (default: ``input TEXT``)."""
        roots = (workdir, spec_folder, *self.data, *self.shipped)
        if self.admits(path, *roots):
            links = [p for p in _entries(path) if p.is_symlink() and not self.admits(p.resolve(), *roots)]
            if not links:
                return
            subject, path = f"input {links[0]}", links[0].resolve()
        raise OutsideError(f"{context}: {subject or f'input {text}'} leads to {path}, outside the workdir, "
                           "the spec's folder and the --data folders; pass --data with its folder (or "
                           f"--allow-outside {path}) if you trust this spec.")


def _entries(path: Path) -> list[Path]:
    """The entries of a folder (none for a file or a missing path)."""
    try:
        return sorted(path.iterdir()) if path.is_dir() else []
    except OSError:
        return []


# ---------------------------------------------------------------------------------------------
# The YAML model.

class StepSpec(BaseModel):
    """One step: a subcommand with its positional arguments and options."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(pattern=NAME_PATTERN)
    run: str
    args: list[Scalar] = []
    options: dict[str, Scalar | list[Scalar]] = {}
    outputs: list[str] = []


class PipelineSpec(BaseModel):
    """A whole spec: format version, variables, working folder and steps."""

    model_config = ConfigDict(extra="forbid")

    version: Literal[1]
    vars: dict[str, Scalar | None] = {}
    workdir: str | None = None
    steps: list[StepSpec] = Field(min_length=1)


def load_spec(path: Path) -> PipelineSpec:
    """Read and check the structure of a YAML spec (one-sentence InputError when wrong)."""
    return load_model(path, PipelineSpec, "pipeline spec", "a YAML mapping with version and steps")


SpecModel = TypeVar("SpecModel", bound=BaseModel)


def load_model(path: Path, model: type[SpecModel], what: str, expected: str) -> SpecModel:
    """Read the YAML file ``path`` as ``model`` (``what`` names it in messages, ``expected``
    says what it should hold); one-sentence InputError when it is missing or wrong."""
    if not path.is_file():
        raise InputError(f"{what} {path} does not exist.")
    raw = read_yaml_mapping(path, what, expected, allow_empty=False)
    try:
        return model.model_validate(raw)
    except ValidationError as exc:
        raise InputError(_describe(exc, raw)) from None


def _describe(exc: ValidationError, raw: dict[str, Any]) -> str:
    """The first validation error of a spec as one sentence naming the step and field."""
    error = exc.errors()[0]
    loc = list(error["loc"])
    message = error["msg"].rstrip(".")
    if error["type"] == "extra_forbidden":
        message = "is not a known field"
    elif error["type"] == "missing":
        message = "is missing"
    elif error.get("input", "") is None:
        message = "has no value (null)"
    elif error["type"] == "literal_error":
        message = f"must be {error['ctx']['expected']}"
    if len(loc) >= 2 and loc[0] == "steps" and isinstance(loc[1], int):
        steps = raw.get("steps")
        name = None
        if isinstance(steps, list) and loc[1] < len(steps) and isinstance(steps[loc[1]], dict):
            name = steps[loc[1]].get("name")
        who = f"step '{name}'" if isinstance(name, str) else f"step {loc[1] + 1}"
        # union members show up as extra loc parts ("str", "list[...]"): keep the spec's path
        fields = [str(p) for p in loc[2:] if not _union_member(p)]
        if len(fields) < len(loc) - 2 and error.get("input", "") is not None:
            message = "expected text, a number, true/false or a list of them"
        return f"{who} ({'.'.join(fields) or 'step'}): {message}."
    return f"spec field '{'.'.join(str(p) for p in loc) or 'spec'}': {message}."


def _union_member(part: object) -> bool:
    """Whether a pydantic error location part names a union member, not a spec field."""
    return isinstance(part, str) and ("[" in part or part in ("str", "int", "float", "bool"))


# ---------------------------------------------------------------------------------------------
# Resolution: substitute, type-check and turn each step into a command line.

@dataclass
class ResolvedStep:
    """A step ready to run: ``values`` (field name → checked text, flag or list, as the spec
    gave them; relative paths are relative to the workdir) build its job; ``argv`` (after
    ``unerode-cli``) is its equivalent command line, for logs and for the step's key;
    ``inputs`` and ``outputs`` are absolute."""

    name: str
    command: str
    argv: list[str]
    inputs: list[Path]
    outputs: list[Path]
    overwrite_given: bool
    has_overwrite: bool
    has_verbosity: bool
    produced_by: set[str] = field(default_factory=set)
    values: dict[str, Any] = field(default_factory=dict)


@dataclass
class ResolvedPipeline:
    """The validated pipeline: where it runs, its steps in order, and where its paths may lead
    (also checked by the runner as each step's job clears its outputs)."""

    spec_path: Path
    workdir: Path
    steps: list[ResolvedStep]
    confinement: Confinement = field(default_factory=Confinement)

    @property
    def state_path(self) -> Path:
        return self.workdir / f".{self.spec_path.stem}.state.json"


def parse_var_overrides(items: list[str]) -> dict[str, str]:
    """``NAME=VALUE`` strings of ``--var`` as a dict."""
    values: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not re.match(NAME_PATTERN, name.strip()):
            raise InputError(f"--var expects NAME=VALUE, got '{item}'.")
        values[name.strip()] = value
    return values


def resolve(spec: PipelineSpec, spec_path: Path, schemas: Mapping[str, CommandSchema],
            overrides: Mapping[str, str] | None = None,
            confinement: Confinement | None = None) -> ResolvedPipeline:
    """Validate ``spec`` against the subcommands, its paths against ``confinement`` (default:
    no ``--data`` or ``--allow-outside``), and return the steps' command lines."""
    confinement = confinement or Confinement()
    variables = _variables(spec, overrides or {})
    base = spec_path.resolve().parent
    workdir = base
    if spec.workdir is not None:
        text = _substitute(spec.workdir, variables, {}, "workdir")
        workdir = (base / Path(str(text)).expanduser()).resolve()
        confinement.check_workdir(str(text), workdir, base)
        if workdir.exists() and not workdir.is_dir():
            raise InputError(f"spec field 'workdir': {workdir} is a file, not a folder.")
    resolver = _Resolver(workdir, variables, schemas, {s.name for s in spec.steps}, base, confinement)
    steps = [resolver.step(step) for step in spec.steps]
    return ResolvedPipeline(spec_path.resolve(), workdir, steps, confinement)


def _variables(spec: PipelineSpec, overrides: Mapping[str, str]) -> dict[str, Scalar | None]:
    values: dict[str, Scalar | None] = dict(spec.vars)
    for name, value in overrides.items():
        if name not in values:
            known = ", ".join(sorted(values)) or "none"
            raise InputError(f"--var {name}: the spec declares no variable '{name}' (declared: {known}).")
        values[name] = value
    return values


def _substitute(value: Scalar, variables: Mapping[str, Scalar | None],
                outputs: Mapping[str, str | None], where: str,
                all_steps: frozenset[str] | set[str] = frozenset()) -> Scalar:
    """Replace ``${var}`` and ``${steps.NAME.output}`` in ``value``; ``where`` names the field."""
    if not isinstance(value, str):
        return value

    def lookup(ref: str) -> Scalar:
        if ref.startswith("steps."):
            parts = ref.split(".")
            if len(parts) < 3 or parts[-1] != "output":
                raise InputError(f"{where}: '${{{ref}}}' is not a reference; use ${{steps.NAME.output}}.")
            step = ".".join(parts[1:-1])
            if step not in outputs and step in all_steps:
                raise InputError(f"{where}: '${{{ref}}}' refers to step '{step}', which does not run "
                                 "before this one; a step can only use outputs of earlier steps.")
            if step not in outputs:
                raise InputError(f"{where}: '${{{ref}}}' refers to step '{step}', "
                                 "which is not a step of this spec.")
            produced = outputs[step]
            if produced is None:
                raise InputError(f"{where}: '${{{ref}}}' refers to step '{step}', which has no output.")
            return produced
        if ref not in variables:
            raise InputError(f"{where}: variable '{ref}' is not defined in vars.")
        found = variables[ref]
        if found is None:
            raise InputError(f"{where}: variable '{ref}' has no value; pass --var {ref}=VALUE.")
        return found

    whole = _REFERENCE.fullmatch(value)
    if whole and not whole.group(1):
        return lookup(whole.group(2).strip())

    def replace(match: re.Match[str]) -> str:
        if match.group(1):
            return "${" + match.group(2) + "}"
        found = lookup(match.group(2).strip())
        return _text(found)

    return _REFERENCE.sub(replace, value)


def _text(value: Scalar) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


class _Resolver:
    """Walks the steps in order, remembering what earlier steps write."""

    def __init__(self, workdir: Path, variables: Mapping[str, Scalar | None],
                 schemas: Mapping[str, CommandSchema], names: set[str], spec_folder: Path,
                 confinement: Confinement) -> None:
        self.names = names
        self.workdir = workdir
        self.spec_folder = spec_folder
        self.confinement = confinement
        self.variables = variables
        self.schemas = schemas
        self.primary: dict[str, str | None] = {}   # step name -> its first output as written
        self.writers: dict[Path, str] = {}          # output path -> step that writes it

    def path(self, text: str) -> Path:
        p = Path(text).expanduser()
        return (p if p.is_absolute() else self.workdir / p).resolve()

    def step(self, step: StepSpec) -> ResolvedStep:
        who = f"step '{step.name}'"
        if step.name in self.primary:
            raise InputError(f"{who} (name): the name is used by an earlier step; step names must be unique.")
        schema = self.schemas.get(step.run)
        if schema is None:
            known = ", ".join(sorted(self.schemas))
            raise InputError(f"{who} (run): unknown subcommand '{step.run}' (known: {known}).")
        sub = lambda v, f: _substitute(v, self.variables, self.primary, f"{who} ({f})",  # noqa: E731
                                       self.names)

        argv: list[str] = [schema.name]
        outputs_written: list[str] = []
        inputs: list[tuple[str, str, bool, str]] = []     # (text, field, required to exist, name)
        values: dict[str, Any] = {}
        argv_args = self._arguments(step, schema, sub, outputs_written, inputs, values)
        argv_opts, overwrite = self._options(step, schema, sub, outputs_written, inputs, values)
        argv += argv_args + argv_opts
        for i, out in enumerate(step.outputs):
            outputs_written.append(str(sub(out, f"outputs[{i}]")))

        produced_by: set[str] = set()
        input_paths: list[Path] = []
        for text, where, required, name in inputs:
            p = self.path(text)
            if required or p in self.writers or p.exists():
                self.confinement.check_input(f"{who} ({where})", text, p, self.workdir, self.spec_folder)
            if p in self.writers:
                produced_by.add(self.writers[p])
                input_paths.append(p)
            elif p.exists():
                input_paths.append(p)
                if name == PARAMETER_FILE:
                    self._check_parameter_file(f"{who} ({where})", p)
            elif required:
                raise InputError(f"{who} ({where}): input file {text} does not exist "
                                 "and no earlier step writes it.")
            elif _GLOB.search(text):
                folder = self.path(_glob_folder(text))
                self.confinement.check_input(f"{who} ({where})", text, folder, self.workdir,
                                             self.spec_folder, f"the pattern {text}, whose folder")
        output_paths: list[Path] = []
        for text in outputs_written:
            p = self.path(text)
            self.confinement.check_output(f"{who} (outputs)", text, p, self.workdir)
            if p in self.writers:
                raise InputError(f"{who} (outputs): {text} is also written by step '{self.writers[p]}'.")
            if any(_same_file(p, source) for source in input_paths):
                raise InputError(f"{who} (outputs): {text} is also an input of this step; inputs are never "
                                 "overwritten, whatever overwrite says, so give the output another name.")
            output_paths.append(p)
        for p in output_paths:
            self.writers[p] = step.name
        self.primary[step.name] = outputs_written[0] if outputs_written else None
        return ResolvedStep(step.name, schema.name, argv, _unique(input_paths), output_paths,
                            overwrite, "overwrite" in schema.options,
                            "verbose" in schema.options and "quiet" in schema.options, produced_by,
                            values)

    def _arguments(self, step, schema, sub, outputs_written, inputs, values) -> list[str]:
        who = f"step '{step.name}'"
        variadic = any(a.kind == "multiple" for a in schema.arguments)
        needed = sum(1 for a in schema.arguments if a.required)
        if not variadic and len(step.args) > len(schema.arguments):
            raise InputError(f"{who} (args): {step.run} takes {len(schema.arguments)} "
                             f"positional argument(s), got {len(step.args)}.")
        if len(step.args) < needed:
            names = " ".join(a.name.upper() for a in schema.arguments)
            raise InputError(f"{who} (args): {step.run} needs {needed} positional "
                             f"argument(s) ({names}), got {len(step.args)}.")
        argv: list[str] = []
        for i, raw in enumerate(step.args):
            where = f"args[{i}]"
            param = schema.arguments[min(i, len(schema.arguments) - 1)]
            text = _check_value(sub(raw, where), param, f"{who} ({where})")
            self._note_path(text, param, where, outputs_written, inputs)
            argv.append(text)
            if param.kind == "multiple":
                values.setdefault(param.name, []).append(text)
            else:
                values[param.name] = text
        return argv

    def _options(self, step, schema, sub, outputs_written, inputs, values) -> tuple[list[str], bool]:
        who = f"step '{step.name}'"
        argv: list[str] = []
        seen: dict[str, str] = {}
        overwrite = False
        for key, raw in step.options.items():
            where = f"options.{key}"
            param = schema.option(key)
            if param is None:
                raise InputError(f"{who} ({where}): {step.run} has no option --{key.lstrip('-')}.")
            if param.name in seen:
                raise InputError(f"{who} ({where}): the same option as options.{seen[param.name]}.")
            seen[param.name] = key
            flag = param.flags[0]
            context = f"{who} ({where})"
            if param.kind == "flag":
                value = sub(raw, where) if not isinstance(raw, list) else raw
                on = _check_bool(value, context)
                if param.name == "overwrite":
                    overwrite = on
                    continue        # the runner passes --overwrite itself (see pipeline_run)
                values[param.name] = on
                if on:
                    argv.append(flag)
                elif param.off_flags:
                    argv.append(param.off_flags[0])
            elif param.kind == "count":
                value = sub(raw, where) if not isinstance(raw, list) else raw
                values[param.name] = _check_count(value, context)
                argv += [flag] * values[param.name]
            elif param.kind == "multiple":
                items = raw if isinstance(raw, list) else [raw]
                for j, item in enumerate(items):
                    field_name = f"{where}[{j}]" if isinstance(raw, list) else where
                    text = _check_value(sub(item, field_name), param, f"{who} ({field_name})")
                    self._note_path(text, param, field_name, outputs_written, inputs)
                    argv += [flag, text]
                    values.setdefault(param.name, []).append(text)
            else:
                if isinstance(raw, list):
                    raise InputError(f"{context}: --{key.lstrip('-')} takes one value, got a list.")
                text = _check_value(sub(raw, where), param, context)
                self._note_path(text, param, where, outputs_written, inputs)
                argv += [flag, text]
                values[param.name] = text
        return argv, overwrite

    def _note_path(self, text: str, param: ParamSchema, where: str,
                   outputs_written: list[str], inputs: list[tuple[str, str, bool, str]]) -> None:
        if param.type == "path" and param.role == "output":
            outputs_written.append(text)
        elif param.type == "path":
            inputs.append((text, where, True, param.name))
        elif param.type == "str" and text:
            inputs.append((text, where, False, param.name))   # e.g. a parameter raster: hashed if a file

    def _check_parameter_file(self, context: str, path: Path) -> None:
        """Refuse a ``--params`` file that names a raster outside the confinement."""
        for text, raster in named_rasters(path):
            self.confinement.check_input(context, text, raster, self.workdir, self.spec_folder,
                                         f"{path.name} names the raster {text}, which")


def _same_file(a: Path, b: Path) -> bool:
    """Whether the resolved paths ``a`` and ``b`` are one file (also as hard links)."""
    if a == b:
        return True
    try:
        return a.is_file() and b.is_file() and os.path.samefile(a, b)
    except OSError:
        return False


def _glob_folder(pattern: str) -> str:
    """The folder a glob pattern searches: its parts before the first with ``*``, ``?`` or ``[``."""
    parts = Path(pattern).parts
    kept = [part for part in parts[:next(i for i, p in enumerate(parts) if _GLOB.search(p))]]
    return str(Path(*kept)) if kept else "."


def _unique(paths: list[Path]) -> list[Path]:
    return list(dict.fromkeys(paths))


def _check_bool(value: Scalar | list[Scalar], context: str) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, str) and value.lower() in ("true", "false"):
        return value.lower() == "true"
    shown = "a list" if isinstance(value, list) else repr(value)
    raise InputError(f"{context}: this flag takes true or false, got {shown}.")


def _check_count(value: Scalar | list[Scalar], context: str) -> int:
    if isinstance(value, bool):
        return int(value)
    try:
        count = int(str(value))
    except ValueError:
        count = -1
    if isinstance(value, list) or count < 0:
        raise InputError(f"{context}: expected a count (0, 1, 2, ...) or true/false, got {value!r}.")
    return count


def _check_value(value: Scalar, param: ParamSchema, context: str) -> str:
    """The command-line text of one value, checked against the parameter's type."""
    if isinstance(value, bool):
        raise InputError(f"{context}: expected {_kind_name(param)}, got {_text(value)}.")
    text = _text(value)
    if param.type in ("int", "float"):
        try:
            number = int(text) if param.type == "int" else float(text)
        except ValueError:
            raise InputError(f"{context}: expected {_kind_name(param)}, got '{text}'.") from None
        if param.minimum is not None and number < param.minimum:
            raise InputError(f"{context}: must be ≥ {param.minimum:g}, got {text}.")
        if param.maximum is not None and number > param.maximum:
            raise InputError(f"{context}: must be ≤ {param.maximum:g}, got {text}.")
    elif param.type == "choice" and text not in param.choices:
        raise InputError(f"{context}: expected one of {', '.join(param.choices)}, got '{text}'.")
    elif param.type == "path" and not text:
        raise InputError(f"{context}: expected a path, got an empty value.")
    if param.parse is not None:
        try:
            param.parse(text)
        except ValueError as exc:
            raise InputError(f"{context}: {str(exc).rstrip('.')}.") from None
    return text


def _kind_name(param: ParamSchema) -> str:
    return {"int": "an integer", "float": "a number", "path": "a path",
            "choice": "one of " + ", ".join(param.choices)}.get(param.type, "a value")
