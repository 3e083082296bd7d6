"""Processing history: the ``UNERODE_HISTORY`` tag and the JSON sidecar of each output.

Two identical runs write byte-identical outputs: the history tag of a raster holds what made
it (command, version, parameters, seed, equivalent command line) but no time; the time of the
run is in the sidecar only. With ``SOURCE_DATE_EPOCH`` set (seconds since 1970, the
reproducible-builds convention) the sidecar's time is that one, and its wall-clock durations
(:data:`WALL_CLOCK_KEYS`) are left out, so that the sidecars of two runs are identical too.
Inside :func:`recorded_relative_to` (a pipeline step), the paths in a history that lie in the
step's workdir are written relative to it, as the spec names them.
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import os
import shlex
from collections.abc import Iterator
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from unerode_cli import __version__
from unerode_cli.io.json_files import jsonable, to_json, write_json
from unerode_cli.io.paths import active_plan
from unerode_cli.io.terrain import Terrain

HISTORY_TAG = "UNERODE_HISTORY"
#: The environment variable that fixes the recorded time (seconds since 1970-01-01 UTC).
EPOCH_VARIABLE = "SOURCE_DATE_EPOCH"
#: Statistics that measure the wall clock (s), left out of sidecars when ``SOURCE_DATE_EPOCH``
#: is set.
WALL_CLOCK_KEYS = frozenset({"wall_time_s", "sampling_s", "seconds", "wall_s"})

_RELATIVE_TO: contextvars.ContextVar[Path | None] = contextvars.ContextVar("recorded_relative_to",
                                                                          default=None)


def fixed_epoch() -> int | None:
    """The time ``SOURCE_DATE_EPOCH`` fixes (s since 1970), None when it is unset or not a
    whole number."""
    text = os.environ.get(EPOCH_VARIABLE, "").strip()
    return int(text) if text.isdigit() else None


def record_time() -> str:
    """The time to record (UTC, ISO 8601 to the second): ``SOURCE_DATE_EPOCH`` when set, else now."""
    epoch = fixed_epoch()
    moment = datetime.now(timezone.utc) if epoch is None else datetime.fromtimestamp(epoch, timezone.utc)
    return moment.isoformat(timespec="seconds")


@contextlib.contextmanager
def recorded_relative_to(folder: Path) -> Iterator[None]:
    """Within this block, histories name the paths inside ``folder`` relative to it."""
    token = _RELATIVE_TO.set(Path(folder).resolve())
    try:
        yield
    finally:
        _RELATIVE_TO.reset(token)


def _relative(value: Any) -> Any:
    """``value`` with every text that is an absolute path inside the active folder of
    :func:`recorded_relative_to` made relative to it (lists and mappings walked)."""
    folder = _RELATIVE_TO.get()
    if folder is None:
        return value
    if isinstance(value, dict):
        return {key: _relative(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_relative(item) for item in value]
    if isinstance(value, str) and value.startswith(os.sep):
        path = Path(value)
        if path.is_relative_to(folder):
            return path.relative_to(folder).as_posix() or "."
    return value


def history_entry(command: str, parameters: dict[str, Any], seed: int | None = None) -> dict[str, Any]:
    """One processing step: command, version, parameters, seed, the job's equivalent command
    line (from its declared options, see the active output plan) and the time of the run
    (:func:`record_time`; :func:`append_history` leaves it out of the tag)."""
    return {
        "command": command,
        "version": __version__,
        "parameters": _relative(jsonable(parameters)),
        "seed": seed,
        "command_line": shlex.join(["unerode-cli", *_relative(list(active_plan().command_line))]),
        "time": record_time(),
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
    """Append ``entry``, without its time, to the terrain's history tag (in place on the
    output terrain): the raster holds no time, so two identical runs give identical bytes."""
    timeless = {key: value for key, value in entry.items() if key != "time"}
    terrain.tags[HISTORY_TAG] = to_json(history(terrain) + [timeless])


def sidecar_path(output: Path) -> Path:
    """``OUT.tif`` → ``OUT.tif.json``: where an output's sidecar is written."""
    return output.with_name(output.name + ".json")


def write_sidecar(output: Path, entry: dict[str, Any], statistics: dict[str, Any]) -> Path:
    """Write ``OUTPUT.json`` beside an output: the history entry (with its time) plus run
    statistics, the wall-clock ones left out when ``SOURCE_DATE_EPOCH`` is set."""
    sidecar = sidecar_path(output)
    if fixed_epoch() is not None:
        statistics = _without_wall_clock(statistics)
    payload = dict(entry, statistics=statistics)
    write_json(sidecar, payload)
    return sidecar


def _without_wall_clock(value: Any) -> Any:
    if isinstance(value, dict):
        return {key: _without_wall_clock(item) for key, item in value.items() if key not in WALL_CLOCK_KEYS}
    return value
