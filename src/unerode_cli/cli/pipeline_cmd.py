"""`unerode-cli pipeline run SPEC.yaml`: run a YAML chain of subcommands, resumably.

The spec format is described in :mod:`unerode_cli.pipeline.spec`, the state file and resume
rules in :mod:`unerode_cli.pipeline.pipeline_run`. This module only parses the command line
and tells the pipeline layer what each subcommand accepts (read from the click commands of
:mod:`unerode_cli.cli.commands`), since nothing below ``cli`` may import typer or click.
"""

from __future__ import annotations

import sys
import typing
from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import Quiet, Verbose
from unerode_cli.cli.values import Command, OptionParser

EXAMPLES = """\
Examples:

  unerode-cli pipeline run pipelines/demo.yaml

  unerode-cli pipeline run pipelines/demo.yaml --dry-run --resume

  unerode-cli pipeline run pipelines/demo.yaml --resume --var dt=500

A minimal spec (relative paths are relative to the spec's folder):

  version: 1
  vars: {dt: 1000}
  steps:
    - name: terrain
      run: synth
      args: ["terrain.tif"]
      options: {size: 64, seed: 3}
    - name: eroded
      run: erode
      args: ["${steps.terrain.output}", eroded.tif]
      options: {dt: "${dt}", steps: 10, preview: eroded.png}
"""

pipeline_app = typer.Typer(
    name="pipeline",
    help="Run pipeline specs: YAML chains of subcommands with named outputs and resume.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)

# Path parameters whose value is written, by name; others are told by their help text.
OUTPUT_PARAMETERS = {"output", "png", "preview", "change_map"}
INPUT_PARAMETERS = {"source", "dem", "params", "dirichlet"}


@pipeline_app.command("run", epilog=EXAMPLES, cls=Command)
def run(
    spec: Annotated[Path, typer.Argument(help="Pipeline spec (YAML): version, vars, workdir, steps.")],
    resume: Annotated[bool, typer.Option("--resume", help="Skip the steps finished by an earlier run whose command line, inputs and outputs are unchanged.")] = False,
    dry_run: Annotated[bool, typer.Option("--dry-run", help="Validate and print the command line of each step (run or skip) without running anything.")] = False,
    var: Annotated[list[str] | None, typer.Option("--var", help="Set a variable declared under vars: NAME=VALUE (repeatable).")] = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Run the steps of a pipeline spec in order, each as its own unerode-cli process.

    Everything is validated before the first step runs (subcommands, options, types, variables, step references, input files). A failing step stops the run and keeps what the earlier steps wrote; `--resume` then continues from the failed step. Progress goes to stderr; the state of finished steps is kept in `.SPEC-STEM.state.json` in the workdir.
    """
    verbosity = verbose - quiet
    with reported_errors(verbosity):
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.pipeline.pipeline_run import StepFailed, run_pipeline
        from unerode_cli.pipeline.pipeline_run import dry_run as plan_lines
        from unerode_cli.pipeline.spec import load_spec, parse_var_overrides, resolve

        pipeline = resolve(load_spec(spec), spec, command_schemas(), parse_var_overrides(var or []))
        if dry_run:
            lines = plan_lines(pipeline, resume, verbosity)
            say(f"dry run of {len(pipeline.steps)} step(s) in {pipeline.workdir}; nothing is run.", verbosity)
            for line in lines:
                typer.echo(line)
            return
        try:
            report = run_pipeline(pipeline, resume, verbosity, note=lambda text: say(text, verbosity))
        except StepFailed as exc:
            print(f"error: {exc}", file=sys.stderr)
            raise typer.Exit(exc.exit_code) from None
        say(f"pipeline finished: {len(report.ran)} step(s) ran, {len(report.skipped)} skipped.", verbosity,
            SUMMARY)


def command_schemas() -> dict[str, Any]:
    """What each unerode-cli subcommand accepts, as :class:`CommandSchema` objects."""
    from unerode_cli.cli.commands import register
    from unerode_cli.pipeline.spec import CommandSchema

    group = typer.main.get_command(register(typer.Typer()))
    schemas: dict[str, Any] = {}
    for name, command in getattr(group, "commands", {}).items():
        arguments, options = [], {}
        for param in command.params:
            if param.param_type_name == "argument":
                arguments.append(_schema(param, ()))
            elif param.param_type_name == "option" and not getattr(param, "hidden", False):
                longs = tuple(o for o in param.opts if o.startswith("--"))
                if not longs:
                    continue
                schema = _schema(param, longs)
                for flag in longs:
                    options[flag[2:]] = schema
                    options.setdefault(flag[2:].replace("_", "-"), schema)
        schemas[name] = CommandSchema(name, tuple(arguments), options)
    return schemas


def _schema(param: Any, flags: tuple[str, ...]) -> Any:
    """One click parameter as a :class:`ParamSchema`."""
    from unerode_cli.pipeline.spec import ParamSchema

    annotation = getattr(getattr(param, "type_descriptor", None), "annotation", str)
    if typing.get_origin(annotation) in (list, tuple):
        annotation = (typing.get_args(annotation) or (str,))[0]
    kind = "value"
    if getattr(param, "count", False):
        kind = "count"
    elif getattr(param, "is_flag", False):
        kind = "flag"
    elif param.multiple or param.nargs == -1:
        kind = "multiple"
    choices: tuple[str, ...] = ()
    if isinstance(annotation, type) and issubclass(annotation, Enum):
        type_name, choices = "choice", tuple(str(e.value) for e in annotation)
    elif annotation is Path:
        type_name = "path"
    elif annotation in (int, float):
        type_name = annotation.__name__
    else:
        type_name = "str"
    role = "other"
    if type_name == "path":
        role = "output" if _is_output(param) else "input"
    parser = _option_parser(param)
    return ParamSchema(
        name=param.name, flags=flags, kind=kind, type=type_name, role=role, choices=choices,
        minimum=getattr(param, "min", None), maximum=getattr(param, "max", None),
        required=bool(param.required),
        off_flags=tuple(o for o in getattr(param, "secondary_opts", ()) if o.startswith("--")),
        parse=parser.parse if parser is not None else None,
    )


def _option_parser(param: Any) -> OptionParser | None:
    """The parser of a typer parameter's values (:mod:`unerode_cli.cli.values`), if it has one."""
    info = getattr(getattr(param, "type_descriptor", None), "parameter_info", None)
    parser = getattr(info, "parser", None)
    return parser if isinstance(parser, OptionParser) else None


def _is_output(param: Any) -> bool:
    """Whether a path parameter names a file the command writes."""
    if param.name in OUTPUT_PARAMETERS:
        return True
    if param.name in INPUT_PARAMETERS:
        return False
    text = (getattr(param, "help", None) or "").lower()
    return text.startswith(("output", "write", "also write"))
