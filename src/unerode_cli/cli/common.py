"""What every subcommand does around its work: check outputs first, read, write with history,
sidecar and optional preview. Heavy libraries are imported here, never at CLI start-up."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from unerode_cli.cli.options import parse_creation_options
from unerode_cli.raster.gdal_io import WriteOptions
from unerode_cli.raster.io import read_terrain, write_terrain
from unerode_cli.raster.paths import atomic_path, check_output
from unerode_cli.raster.provenance import append_history, history_entry, write_sidecar
from unerode_cli.raster.terrain import Terrain
from unerode_cli.viz.preview import save_preview


@dataclass(frozen=True)
class Outputs:
    """An output heightfield, its write options and its optional preview PNG."""

    path: Path
    options: WriteOptions
    overwrite: bool = False
    preview: Path | None = None

    @classmethod
    def from_cli(
        cls, path: Path, dtype: str, cog: bool, co: list[str] | None, overwrite: bool,
        preview: Path | None,
    ) -> Outputs:
        """Outputs from the common options (--dtype, --cog, --co, --overwrite, --preview)."""
        return cls(path, WriteOptions(dtype, cog, parse_creation_options(co)), overwrite, preview)

    def check(self, *inputs: Path) -> None:
        """Refuse bad outputs before any work is done."""
        check_output(self.path, self.overwrite, inputs)
        if self.preview is not None:
            check_output(self.preview, self.overwrite, inputs)


def load(path: Path, band: int | None = None, channel: str | None = None) -> Terrain:
    return read_terrain(path, band=band, channel=channel)


def save(
    terrain: Terrain,
    outputs: Outputs,
    command: str,
    parameters: dict[str, Any],
    statistics: dict[str, Any] | None = None,
    seed: int | None = None,
) -> None:
    """Write the heightfield (with its history entry), its JSON sidecar and its preview."""
    entry = history_entry(command, parameters, seed)
    append_history(terrain, entry)
    write_terrain(terrain, outputs.path, outputs.options)
    write_sidecar(outputs.path, entry, statistics or {})
    if outputs.preview is not None:
        preview(terrain, outputs.preview, title=outputs.path.name)


def preview(terrain: Terrain, path: Path, title: str = "", **style: Any) -> None:
    """The one preview function: hillshade + colour ramp PNG, written atomically."""
    with atomic_path(path) as tmp:
        save_preview(terrain.elevation, terrain.dx, terrain.dy, tmp, title=title, **style)


def say(message: str, verbosity: int, level: int = 0) -> None:
    """Log to stderr when ``verbosity`` ≥ ``level`` (−q lowers, −v raises)."""
    if verbosity >= level:
        print(message, file=sys.stderr)
