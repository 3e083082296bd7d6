"""Processing history: the ``UNERODE_HISTORY`` tag and the JSON sidecar of each output."""

from __future__ import annotations

import json
import shlex
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from unerode_cli import __version__
from unerode_cli.io.json_files import jsonable, to_json, write_json
from unerode_cli.io.paths import active_plan
from unerode_cli.io.terrain import Terrain

HISTORY_TAG = "UNERODE_HISTORY"


def history_entry(command: str, parameters: dict[str, Any], seed: int | None = None) -> dict[str, Any]:
    """One processing step: command, version, parameters, seed, the job's equivalent command
    line (from its declared options, see the active output plan) and UTC time."""
    return {
        "command": command,
        "version": __version__,
        "parameters": jsonable(parameters),
        "seed": seed,
        "command_line": shlex.join(["unerode-cli", *active_plan().command_line]),
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
    terrain.tags[HISTORY_TAG] = to_json(history(terrain) + [entry])


def sidecar_path(output: Path) -> Path:
    """``OUT.tif`` → ``OUT.tif.json``: where an output's sidecar is written."""
    return output.with_name(output.name + ".json")


def write_sidecar(output: Path, entry: dict[str, Any], statistics: dict[str, Any]) -> Path:
    """Write ``OUTPUT.json`` beside an output: the history entry plus run statistics."""
    sidecar = sidecar_path(output)
    payload = dict(entry, statistics=statistics)
    write_json(sidecar, payload)
    return sidecar
