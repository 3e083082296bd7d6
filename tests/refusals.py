"""What the tests of refused and failed commands share: run the command line in process in a
folder, fingerprint a folder's files, and the pattern of what no message may show."""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
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


def assert_refused(folder: Path, *args: object, phrase: str, seconds: float | None = None) -> str:
    """``unerode-cli ARGS`` in ``folder`` exits 2 (within ``seconds`` when given) with one
    sentence containing ``phrase`` and no class name, and changes or adds no file; the sentence."""
    before = snapshot(folder)
    start = time.perf_counter()
    code, stderr = cli(folder, *args)
    assert code == 2, stderr
    if seconds is not None:
        assert time.perf_counter() - start < seconds, stderr
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1, stderr
    assert lines[0].startswith("error: ") and lines[0].rstrip().endswith("."), stderr
    assert not re.search(CLASS_NAME, stderr), stderr
    assert phrase.lower() in stderr.lower(), stderr
    assert snapshot(folder) == before
    return lines[0]


@contextlib.contextmanager
def read_only_folder(path: Path) -> Iterator[Path]:
    """``path`` made as a folder this process cannot write: mode 0555, and immutable
    (``chattr +i``) for root, whom modes do not stop; the test is skipped where neither works."""
    path.mkdir()
    path.chmod(0o555)
    immutable = False
    if os.access(path, os.W_OK) and shutil.which("chattr"):
        immutable = subprocess.run(["chattr", "+i", str(path)], capture_output=True).returncode == 0
    try:
        if os.access(path, os.W_OK):
            pytest.skip("no read-only folder can be made here (root, and chattr +i refused)")
        yield path
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(path)], capture_output=True)
        path.chmod(0o755)
