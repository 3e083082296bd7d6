"""Small helpers of the command modules: reading the input and logging to stderr."""

from __future__ import annotations

import sys
from pathlib import Path

from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain


def load(path: Path, band: int | None = None, channel: str | None = None) -> Terrain:
    """Read the input heightfield (never opened for writing)."""
    return read_terrain(path, band=band, channel=channel)


def say(message: str, verbosity: int, level: int = 0) -> None:
    """Log to stderr when ``verbosity`` ≥ ``level`` (−q lowers, −v raises)."""
    if verbosity >= level:
        print(message, file=sys.stderr)
