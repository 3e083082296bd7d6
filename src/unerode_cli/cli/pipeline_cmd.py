"""`unerode-cli pipeline run SPEC.yaml`: run a YAML chain of subcommands, resumably.

The spec format is described in :mod:`unerode_cli.pipeline.spec`, the state file and resume
rules in :mod:`unerode_cli.pipeline.pipeline_run`. This module only parses the command line;
what each subcommand accepts comes from the jobs' declarations (:mod:`unerode_cli.pipeline.commands`).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.examples import epilog
from unerode_cli.cli.options import Quiet, Verbose
from unerode_cli.cli.values import Command

SPEC_EXAMPLE = """\
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

@pipeline_app.command("run", epilog=epilog("pipeline run", SPEC_EXAMPLE), cls=Command)
def run(
    spec: Annotated[Path, typer.Argument(help="Pipeline spec (YAML): version, vars, workdir, steps.")],
    resume: Annotated[bool, typer.Option("--resume", help="Skip the steps finished by an earlier run whose command line, inputs and outputs are unchanged.")] = False,
    dry_run: Annotated[bool, typer.Option("--dry-run", help="Validate and print the command line of each step (run or skip) without running anything.")] = False,
    var: Annotated[list[str] | None, typer.Option("--var", help="Set a variable declared under vars: NAME=VALUE (repeatable).")] = None,
    data: Annotated[list[Path] | None, typer.Option("--data", help="A folder whose files the steps may read, besides the workdir and the spec's folder (repeatable).")] = None,
    allow_outside: Annotated[list[Path] | None, typer.Option("--allow-outside", help="A file or folder outside the spec's folder that you trust this spec to read and write (repeatable).")] = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Run the steps of a pipeline spec in order, each as its subcommand's job in this process.

    Everything is validated before the first step runs (subcommands, options, types, variables, step references, input files). A spec stays in its folder: its workdir lies in the spec's folder, its outputs in the workdir, and its inputs in the workdir, the spec's folder, a --data folder or the shipped folders of the unerode-cli checkout (sample_dems/, pipelines/ and ../shared/data); any other path, symbolic links resolved, is refused unless given with --allow-outside. A step replaces only files that this spec wrote, listed with their sha256 in the state file. A failing step stops the run and keeps what the earlier steps wrote; `--resume` then continues from the failed step. Progress goes to stderr; the state of finished steps is kept in `.SPEC-STEM.state.json` in the workdir.
    """
    verbosity = verbose - quiet
    from unerode_cli.cli.declared import refuse_missing_inputs

    refuse_missing_inputs([spec], "pipeline spec {path} does not exist.")
    with reported_errors(verbosity):
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.pipeline.commands import schemas
        from unerode_cli.pipeline.pipeline_run import StepFailed, run_pipeline
        from unerode_cli.pipeline.pipeline_run import dry_run as plan_lines
        from unerode_cli.pipeline.spec import Confinement, load_spec, parse_var_overrides, resolve

        confinement = Confinement.from_options(data, allow_outside)
        pipeline = resolve(load_spec(spec), spec, schemas(), parse_var_overrides(var or []), confinement)
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
