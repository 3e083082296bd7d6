"""Processing history: the ``UNERODE_HISTORY`` tag and the JSON sidecar of each output."""

from __future__ import annotations

import json
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from unerode_cli import __version__
from unerode_cli.io.json_files import write_json
from unerode_cli.io.terrain import Terrain

HISTORY_TAG = "UNERODE_HISTORY"


def history_entry(command: str, parameters: dict[str, Any], seed: int | None = None) -> dict[str, Any]:
    """One processing step: command, version, parameters, seed, command line and UTC time."""
    return {
        "command": command,
        "version": __version__,
        "parameters": {k: _jsonable(v) for k, v in parameters.items()},
        "seed": seed,
        "argv": sys.argv,
        "time": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }


def history(terrain: Terrain) -> list[dict[str, Any]]:
    """The processing history a terrain carries (empty for a raw DEM)."""
    raw = terrain.tags.get(HISTORY_TAG)
    if not raw:
        return []
    try:
        entries = json.loads(raw)
    except json.JSONDecodeError:
        return []
    return entries if isinstance(entries, list) else []


def append_history(terrain: Terrain, entry: dict[str, Any]) -> None:
    """Append ``entry`` to the terrain's history tag (in place on the output terrain)."""
    terrain.tags[HISTORY_TAG] = json.dumps(history(terrain) + [entry])


def write_sidecar(output: Path, entry: dict[str, Any], statistics: dict[str, Any]) -> Path:
    """Write ``OUTPUT.json`` beside an output: the history entry plus run statistics."""
    sidecar = output.with_name(output.name + ".json")
    payload = dict(entry, statistics={k: _jsonable(v) for k, v in statistics.items()})
    write_json(sidecar, payload)
    return sidecar


def _jsonable(value: Any) -> Any:
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "item") and getattr(value, "ndim", 1) == 0:
        return value.item()
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value
