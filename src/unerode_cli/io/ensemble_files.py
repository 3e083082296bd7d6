"""The files of an ensemble folder (``unerode-cli ensemble SPEC OUT_DIR``)::

    OUT_DIR/ensemble.json            the spec, seed, engine and every member's parameters
    OUT_DIR/members/NNNN/            one member's pipeline workdir, with
        member.json                  its index and parameters (written before it runs)
        member.log                   what its steps said (stdout and stderr)
        done.json                    the done marker: written last, when every step succeeded
    OUT_DIR/failures.csv             the members that failed, with their error
    OUT_DIR/members.csv              every member's parameters and scores, best first
    OUT_DIR/summary/                 statistics rasters, best.json and scatter plots

Records are rewritten atomically by whichever process runs the member, so each write clears
its own path first (a command run in the same process starts a new list of cleared outputs).
"""

from __future__ import annotations

import shutil
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from unerode_cli.errors import InputError
from unerode_cli.io.csv_tables import write_table
from unerode_cli.io.json_files import read_json, write_json
from unerode_cli.io.paths import atomic_path, check_output

ENSEMBLE_FILE = "ensemble.json"
MEMBERS_FOLDER = "members"
MEMBER_FILE = "member.json"
DONE_FILE = "done.json"
LOG_FILE = "member.log"
FAILURES_FILE = "failures.csv"
MEMBERS_TABLE = "members.csv"
SUMMARY_FOLDER = "summary"


def member_folder(out_dir: Path, index: int) -> Path:
    """``OUT_DIR/members/0007`` for member 7 (at least four digits)."""
    return out_dir / MEMBERS_FOLDER / f"{index:04d}"


def write_record(path: Path, payload: Mapping[str, Any]) -> None:
    """Write a JSON record of the ensemble (replacing the one there), atomically."""
    check_output(path, overwrite=True, again=True)
    write_json(path, dict(payload))


def read_record(path: Path) -> dict[str, Any] | None:
    """A JSON record of the ensemble; None when there is none. InputError when damaged."""
    if not path.exists():
        return None
    try:
        record = read_json(path)
    except (OSError, ValueError, UnicodeDecodeError):
        raise InputError(f"{path} is damaged; delete it (or the whole folder) to start again.") from None
    if not isinstance(record, dict):
        raise InputError(f"{path} is damaged; delete it (or the whole folder) to start again.")
    return record


def write_text(path: Path, text: str) -> None:
    """Write UTF-8 text (a member's log), atomically, replacing the file there."""
    check_output(path, overwrite=True, again=True)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_rows(path: Path, columns: list[str], rows: Iterable[Mapping[str, Any]]) -> None:
    """Write a CSV table of the ensemble (members.csv, failures.csv), replacing the one there."""
    check_output(path, overwrite=True, again=True)
    write_table(path, columns, rows)


def fresh_folder(folder: Path) -> None:
    """Make ``folder`` exist and be empty (a member that did not finish starts again from
    nothing: no output, checkpoint or state of its interrupted run is trusted)."""
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)

