"""Reading the YAML files of a run (parameter files, climate schedules, pipeline specs)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from unerode_cli.errors import InputError


def read_yaml_mapping(path: Path, what: str, mapping_of: str, allow_empty: bool = True) -> dict[str, Any]:
    """The top-level mapping of the YAML file ``path``; an empty file is ``{}`` when
    ``allow_empty``.

    Raises:
        InputError: one sentence naming ``what`` (e.g. "the parameter file") and ``path`` for an
            unreadable file, text that is not UTF-8 or not valid YAML (with the line), or a
            document that is not ``mapping_of`` (e.g. "a mapping of phases to parameters").
    """
    import yaml

    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{what} {path} is not a UTF-8 text file.") from None
    except OSError as exc:
        raise InputError(f"cannot read {what} {path}: {exc.strerror}.") from None
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise InputError(f"{what} {path} is not valid YAML{where}.") from None
    if document is None and allow_empty:
        return {}
    if not isinstance(document, dict):
        raise InputError(f"{what} {path} must be {mapping_of}.")
    return document
