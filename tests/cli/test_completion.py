"""Shell completion (typer's): the root offers --install-completion and --show-completion, and
bash's completion protocol, run in a subshell, completes subcommands and options."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ENTRY = Path(sys.executable).with_name("unerode-cli")
needs_bash = pytest.mark.skipif(shutil.which("bash") is None or not ENTRY.exists(),
                                reason="needs bash and the installed unerode-cli script")


def complete(words: str, cword: int) -> list[str]:
    """What bash completion offers for the command line ``words``, the word ``cword`` completed
    (typer's bash protocol: the completion variable, COMP_WORDS and COMP_CWORD)."""
    script = f"_UNERODE_CLI_COMPLETE=complete_bash COMP_WORDS='{words}' COMP_CWORD={cword} '{ENTRY}'"
    env = {**os.environ, "PATH": f"{ENTRY.parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    result = subprocess.run(["bash", "-c", script], capture_output=True, text=True, timeout=120, env=env)
    assert result.returncode == 0, result.stderr
    return result.stdout.split()


@needs_bash
def test_bash_completes_a_subcommand() -> None:
    assert "erode" in complete("unerode-cli er", 1)
    assert "unerode" not in complete("unerode-cli er", 1)


@needs_bash
def test_bash_completes_an_option_of_a_subcommand() -> None:
    assert "--steps" in complete("unerode-cli erode --st", 2)


def test_the_root_offers_completion() -> None:
    result = subprocess.run([sys.executable, "-m", "unerode_cli", "--help"], capture_output=True,
                            text=True, timeout=120, env={**os.environ, "COLUMNS": "100"})
    assert "--install-completion" in result.stdout and "--show-completion" in result.stdout


@needs_bash
def test_show_completion_prints_the_bash_script() -> None:
    result = subprocess.run([str(ENTRY), "--show-completion", "bash"], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0
    assert "_UNERODE_CLI_COMPLETE=complete_bash" in result.stdout
