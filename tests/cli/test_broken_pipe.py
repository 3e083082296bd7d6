"""A standard output closed by its reader (``unerode-cli erode -h | grep -q Usage``) ends the
command quietly with exit status 141 (128 + SIGPIPE, as the shell reports for a program that
SIGPIPE ended); a broken pipe that is not standard output's stays an error."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
import typer
from tests.conftest import SAMPLE_DEMS

from unerode_cli.cli.app import EXIT_BROKEN_PIPE
from unerode_cli.cli.errors import reported_errors, stdout_closed


def run_with_closed_stdout(*args: str) -> subprocess.CompletedProcess[str]:
    """Run ``unerode-cli ARGS`` whose standard output is a pipe already closed by its reader."""
    read, write = os.pipe()
    os.close(read)
    try:
        return subprocess.run([sys.executable, "-m", "unerode_cli", *args], stdout=write,
                              stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(write)


@pytest.mark.parametrize("args", [("erode", "-h"), ("--help",),
                                  ("info", str(SAMPLE_DEMS / "valley_utm32n_30m.tif"))])
def test_a_closed_stdout_ends_quietly(args: tuple[str, ...]) -> None:
    result = run_with_closed_stdout(*args)
    assert result.returncode == EXIT_BROKEN_PIPE == 141
    assert result.stderr == ""


def test_grep_q_after_help_in_a_shell() -> None:
    result = subprocess.run(["bash", "-c", f"'{sys.executable}' -m unerode_cli erode -h | grep -q Usage; "
                             "echo ${PIPESTATUS[0]} ${PIPESTATUS[1]}"],
                            capture_output=True, text=True, timeout=120)
    assert result.stdout.split()[1] == "0"                         # grep found Usage
    assert result.stdout.split()[0] in ("0", "141")              # 0 when help fitted in the pipe first
    assert "Traceback" not in result.stderr and "Error" not in result.stderr


def test_a_broken_pipe_of_a_closed_stdout_leaves_the_command(monkeypatch: pytest.MonkeyPatch) -> None:
    read, write = os.pipe()
    os.close(read)
    with os.fdopen(write, "w") as closed:
        monkeypatch.setattr(sys, "stdout", closed)
        assert stdout_closed()
        with pytest.raises(BrokenPipeError), reported_errors(0):
            raise BrokenPipeError(32, "Broken pipe")


def test_another_broken_pipe_is_an_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert not stdout_closed()
    with pytest.raises(typer.Exit) as ended, reported_errors(0):
        raise BrokenPipeError(32, "Broken pipe")
    assert ended.value.exit_code == 1
    assert capsys.readouterr().err.startswith("error: ")
