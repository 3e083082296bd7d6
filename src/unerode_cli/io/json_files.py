"""JSON files: sidecars, reports, pipeline state. Strict JSON (no NaN), written atomically, read
whole."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.io.paths import atomic_path


def write_json(path: Path, payload: Any) -> None:
    """Write ``payload`` as indented UTF-8 strict JSON (see to_json), atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(to_json(payload, indent=2) + "\n", encoding="utf-8")


def to_json(payload: Any, indent: int | None = None) -> str:
    """``payload`` as strict JSON text: NaN and ±inf become ``null`` (see jsonable)."""
    return json.dumps(jsonable(payload), indent=indent, allow_nan=False)


def jsonable(value: Any) -> Any:
    """``value`` with plain JSON types all the way down: NumPy scalars and arrays as numbers and
    lists, paths as strings, tuples as lists, and non-finite floats (NaN, ±inf) as None."""
    if isinstance(value, np.ndarray | np.generic):
        value = value.tolist()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, dict):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    return value


def read_json(path: Path) -> Any:
    """The JSON document at ``path``.

    Raises:
        OSError, UnicodeDecodeError, ValueError: unreadable or malformed file (the caller says
            what it means for its file).
    """
    return json.loads(Path(path).read_text(encoding="utf-8"))
