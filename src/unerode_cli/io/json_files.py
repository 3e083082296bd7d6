"""JSON files: sidecars, reports, pipeline state. Written atomically, read whole."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from unerode_cli.io.paths import atomic_path


def write_json(path: Path, payload: Any) -> None:
    """Write ``payload`` as indented UTF-8 JSON (NaN written as ``NaN``), atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(payload, indent=2, allow_nan=True) + "\n", encoding="utf-8")


def read_json(path: Path) -> Any:
    """The JSON document at ``path``.

    Raises:
        OSError, UnicodeDecodeError, ValueError: unreadable or malformed file (the caller says
            what it means for its file).
    """
    return json.loads(Path(path).read_text(encoding="utf-8"))
