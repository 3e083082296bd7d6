"""What the tests of refused and failed commands share: run the command line in process in a
folder, fingerprint a folder's files, and the pattern of what no message may show."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from typer.testing import CliRunner

from unerode_cli.cli.app import app

#: A Python class name, a traceback or a GDAL error class: never part of a message.
CLASS_NAME = r"\b[A-Z][A-Za-z0-9]*(?:Error|Exception|Warning|Interrupt)\b|Traceback|CPLE_"


def cli(folder: Path, *args: object) -> tuple[int, str]:
    """Run ``unerode-cli ARGS`` in process in ``folder``: (exit code, stderr)."""
    try:
        runner = CliRunner(mix_stderr=False)      # click < 8.2
    except TypeError:
        runner = CliRunner()
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        result = runner.invoke(app, [str(a) for a in args], env={"COLUMNS": "100"})
    finally:
        os.chdir(cwd)
    return result.exit_code, result.stderr


def snapshot(folder: Path) -> dict[str, str]:
    """Relative path → sha256 ('dir' for a folder) of everything under ``folder``."""
    return {str(p.relative_to(folder)): "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*"))}
