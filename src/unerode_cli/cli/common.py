"""Small helpers of the command modules: reading the input and logging to stderr.

Every command takes ``-v`` and ``-q`` (repeatable); their count, ``verbose − quiet``, is the
verbosity, and each message is shown when the verbosity reaches its level: errors always,
summaries unless ``-qq``, notes unless ``-q``, per-step detail with ``-v`` and debug detail
(per-step wall times) with ``-vv``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from unerode_cli.io.terrain import Terrain

#: Levels of messages (the verbosity at which they start to show).
SUMMARY = -1
NOTE = 0
DETAIL = 1
DEBUG = 2


def load(path: Path, band: int | None = None, channel: str | None = None) -> Terrain:
    """Read the input heightfield (never opened for writing)."""
    from unerode_cli.io.rasters import read_terrain

    return read_terrain(path, band=band, channel=channel)


def say(message: str, verbosity: int, level: int = NOTE) -> None:
    """Log to stderr when ``verbosity`` (−q lowers it, −v raises it) reaches ``level``."""
    if verbosity >= level:
        print(message, file=sys.stderr)
