"""Options are declared once: every subcommand's command-line options, job fields, pipeline
schema and provenance come from its job's declarations (run/declare.py), and no command module
spells an option out again."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import pytest
import typer

from unerode_cli.cli.app import app
from unerode_cli.pipeline.commands import JOBS, schemas
from unerode_cli.pipeline.ensemble_options import OPTIONS as ENSEMBLE_OPTIONS
from unerode_cli.pipeline.ensemble_run import EnsembleJob
from unerode_cli.run.declare import Opt, command_line, provenance

CLI = Path(__file__).resolve().parents[2] / "src" / "unerode_cli" / "cli"
#: The command-line-only options every command adds (display, not the job's).
DISPLAY = {"verbose", "quiet"}
COMMANDS = {**{name: (entry.job_class(), entry.declarations()) for name, entry in JOBS.items()},
            "ensemble": (EnsembleJob, ENSEMBLE_OPTIONS)}


def click_commands() -> dict:
    return typer.main.get_command(app).commands  # type: ignore[attr-defined]


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_the_command_line_is_made_from_the_declarations(name: str) -> None:
    job_class, declarations = COMMANDS[name]
    command = click_commands()[name]
    params = {p.name: p for p in command.params if p.name not in DISPLAY}
    assert list(params) == [opt.name for opt in declarations]
    for opt in declarations:
        param = params[opt.name]
        if opt.argument:
            assert param.param_type_name == "argument"
            continue
        flags = set(param.opts) | set(param.secondary_opts)
        assert set(opt.all_flags) | ({opt.off_flag} if opt.off_flag else set()) == flags
        assert param.help.replace("\\[", "[") == opt.help
        assert bool(param.required) == opt.required


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_the_job_fields_are_the_declarations(name: str) -> None:
    job_class, declarations = COMMANDS[name]
    assert job_class.OPTIONS == tuple(declarations)
    assert [f.name for f in dataclasses.fields(job_class)] == [opt.name for opt in declarations]
    for opt in declarations:
        assert opt.help.strip(), f"{name} --{opt.name} has no help"
        assert opt.role in ("input", "output", "other")
        if opt.role != "other":
            assert opt.type is Path, f"{name} {opt.name}: only paths are inputs or outputs"


@pytest.mark.parametrize("name", sorted(JOBS))
def test_the_pipeline_schema_is_the_declarations(name: str) -> None:
    schema = schemas()[name]
    _, declarations = COMMANDS[name]
    assert [a.name for a in schema.arguments] == [o.name for o in declarations if o.argument]
    for opt in declarations:
        if not opt.argument:
            assert schema.option(opt.all_flags[0]).name == opt.name
            expected = opt.role if opt.type is Path else "other"
            assert schema.option(opt.all_flags[0]).role == expected


def test_no_command_module_spells_an_option_out() -> None:
    """typer.Option/typer.Argument appear only where the display options and the generator are."""
    allowed = {"options.py", "declared.py", "pipeline_cmd.py", "app.py"}
    offenders = []
    for path in sorted(CLI.glob("*.py")):
        if path.name in allowed:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and node.attr in ("Option", "Argument"):
                offenders.append(f"{path.name}:{node.lineno}")
    assert offenders == []


def test_provenance_and_command_line_come_from_the_job() -> None:
    job_class, _ = COMMANDS["erode"]
    job = job_class(source=Path("in.tif"), output=Path("out.tif"), dt=500.0, steps=3, k="2e-5",
                    overwrite=True)
    record = provenance(job)
    assert record["input"] == Path("in.tif") and record["dt"] == 500.0 and record["steps"] == 3
    assert "overwrite" not in record and "output" not in record       # not part of the physics
    assert command_line(job) == ["erode", "in.tif", "out.tif", "--dt", "500", "--steps", "3",
                                 "--overwrite", "--k", "2e-5"]


def test_a_declaration_is_refused_twice() -> None:
    from unerode_cli.run.declare import declared
    from unerode_cli.run.job import Job

    with pytest.raises(ValueError, match="declared twice"):
        declared("twice", (Opt("a", int, 1, "a"), Opt("a", int, 2, "b")))(type("J", (Job,), {}))
    with pytest.raises(ValueError, match="flag --x is declared twice"):
        declared("twice", (Opt("a", int, 1, "a", flags=("--x",)), Opt("b", int, 2, "b", flags=("--x",))))(
            type("J", (Job,), {}))
