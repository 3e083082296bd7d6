"""Every subcommand's ``--help`` ends with examples (``unerode-cli NAME …``), and the examples of
the fast commands run as written from a checkout's folder."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
from tests.conftest import SAMPLE_DEMS, SHARED_DATA, run_cli
from typer.testing import CliRunner

from unerode_cli.cli.app import app
from unerode_cli.cli.commands import COMMANDS
from unerode_cli.cli.examples import EXAMPLES, command_line

FAST = ("info", "flow", "preview", "convert", "synth")
#: Rich lays the help out 80 columns wide, the examples 3 columns in: a longer line would wrap.
WIDEST = 74


def help_text(name: str) -> str:
    result = CliRunner().invoke(app, [*name.split(), "--help"], env={"COLUMNS": "80"})
    assert result.exit_code == 0, result.output
    return result.output


def test_every_subcommand_has_examples() -> None:
    assert set(EXAMPLES) == {*COMMANDS, "pipeline run"}
    for name, examples in EXAMPLES.items():
        assert any(example[0].startswith(f"unerode-cli {name} ") for example in examples), name
        for example in examples:
            assert all(line.endswith(" \\") for line in example[:-1]), example
            assert not example[-1].endswith("\\"), example
            assert all(len(line) <= WIDEST for line in example), example


@pytest.mark.parametrize("name", [*COMMANDS, "pipeline run"])
def test_help_shows_the_examples(name: str) -> None:
    lines = [line.strip() for line in help_text(name).splitlines()]
    assert any(line.startswith(f"unerode-cli {name} ") for line in lines)
    for example in EXAMPLES[name]:
        for line in example:
            assert line.strip() in lines, line


def checkout(tmp_path: Path) -> Path:
    """A folder laid out as the checkout's (sample_dems/ and pipelines/ in it, the shared data
    at ../shared/data), where the examples run as written."""
    root = tmp_path / "main"
    root.mkdir()
    (root / "sample_dems").symlink_to(SAMPLE_DEMS)
    (root / "pipelines").symlink_to(SAMPLE_DEMS.parent / "pipelines")
    (tmp_path / "shared").symlink_to(SHARED_DATA.parent)
    return root


@pytest.mark.parametrize(("name", "index"), [(name, i) for name in FAST for i in range(len(EXAMPLES[name]))])
def test_the_examples_of_the_fast_commands_run(tmp_path: Path, name: str, index: int) -> None:
    root = checkout(tmp_path)
    args = shlex.split(command_line(EXAMPLES[name][index]))
    assert args[:2] == ["unerode-cli", name]
    result = run_cli(*args[1:], cwd=root)
    assert result.returncode == 0, result.stderr
    written = [p for p in root.iterdir() if p.name not in ("sample_dems", "pipelines")]
    assert written or name == "info"                         # its outputs landed in the folder
