"""Outputs of a run: checked before any work, written atomically with history, sidecar and
previews (DESIGN §5)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.gdal_io import WriteOptions
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.io.provenance import append_history, history_entry, sidecar_path, write_sidecar
from unerode_cli.io.rasters import check_writable, write_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.viz.preview import save_field_preview, save_preview

# Tags of written rasters: simulated time (years, negative backward), and for climate-run
# snapshots their age (ka), sea level (m) and climate phase.
TIME_TAG = "UNERODE_TIME_Y"
AGE_TAG = "UNERODE_AGE_KA"
SEA_TAG = "UNERODE_SEA_LEVEL_M"
PHASE_TAG = "UNERODE_PHASE"


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
        """Refuse bad outputs before any work is done: the raster (format and options
        included), its sidecar and the preview."""
        check_raster(self.path, self.options, self.overwrite, inputs)
        if self.preview is not None:
            check_png(self.preview, self.overwrite, inputs)

    def check_source(self, terrain: Terrain, source: Path | str) -> None:
        """Refuse, before any work, a preview that ``terrain`` (read from ``source``) cannot give."""
        if self.preview is not None:
            check_previewable(terrain, source)


def check_raster(path: Path, options: WriteOptions, overwrite: bool, inputs: tuple[Path, ...] = ()) -> None:
    """Clear a raster output and its JSON sidecar before any work: a format and options that
    can be written, and neither file existing (without ``overwrite``) nor being an input."""
    check_writable(path, options)
    check_output(path, overwrite, inputs)
    check_output(sidecar_path(path), overwrite, inputs)


def check_png(path: Path, overwrite: bool, inputs: tuple[Path, ...] = ()) -> None:
    """Clear a PNG output (preview, plot) before any work."""
    if path.suffix.lower() != ".png":
        raise InputError(f"previews and plots are PNG files: {path.name} does not end in .png.")
    check_output(path, overwrite, inputs)


def check_previewable(terrain: Terrain, source: Path | str) -> None:
    """Refuse, before any work, a preview of a heightfield that cannot be hill-shaded: fewer
    than 2 × 2 cells (no slope) or no valid cell. ``source`` names it in the message."""
    ny, nx = terrain.shape
    if ny < 2 or nx < 2:
        raise InputError(f"{source} has {ny} × {nx} cells; a preview needs at least 2 × 2.")
    terrain.check_valid(source)
    finite = np.isfinite(terrain.elevation)
    low = float(np.min(terrain.elevation, where=finite, initial=np.inf))
    high = float(np.max(terrain.elevation, where=finite, initial=-np.inf))
    relief = high - low
    # The hillshade squares slopes (relief ÷ cell size): beyond ~1e150 they overflow.
    if not np.isfinite(relief) or relief / min(abs(terrain.dx), abs(terrain.dy)) > 1e150:
        raise InputError(f"{source} spans elevations from {low:.3g} to "
                         f"{high:.3g} m, too wide a range to shade; check its values "
                         "(a scale factor or nodata value mistaken for elevations?).")


def save(
    terrain: Terrain,
    outputs: Outputs,
    command: str,
    parameters: dict[str, Any],
    statistics: dict[str, Any] | None = None,
    seed: int | None = None,
    elevation_preview: bool = True,
) -> None:
    """Write the raster (with its history entry), its JSON sidecar and, unless
    ``elevation_preview`` is False, the hillshade preview asked for in ``outputs``."""
    entry = history_entry(command, parameters, seed)
    append_history(terrain, entry)
    write_terrain(terrain, outputs.path, outputs.options)
    write_sidecar(outputs.path, entry, statistics or {})
    if outputs.preview is not None and elevation_preview:
        preview(terrain, outputs.preview, title=outputs.path.name)


def preview(terrain: Terrain, path: Path, title: str = "", **style: Any) -> None:
    """The one preview function: hillshade + colour ramp PNG, written atomically."""
    with atomic_path(path) as tmp:
        save_preview(terrain.elevation, terrain.dx, terrain.dy, tmp, title=title, **style)


def field_preview(
    values: Any, terrain: Terrain, path: Path, label: str, title: str = "", **style: Any
) -> None:
    """PNG of a side field (discharge, Δh, ...) over the terrain's hillshade, written atomically
    (``style``: ``log`` or ``diverging``, see viz.preview.save_field_preview)."""
    with atomic_path(path) as tmp:
        save_field_preview(values, terrain.elevation, terrain.dx, terrain.dy, tmp, label,
                           title=title, **style)


def parse_creation_options(entries: list[str] | None) -> dict[str, str]:
    """``["KEY=VALUE", ...]`` → dict; a malformed entry is bad input."""
    options: dict[str, str] = {}
    for entry in entries or []:
        key, sep, value = entry.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--co expects KEY=VALUE, got '{entry}'.")
        options[key.strip().upper()] = value.strip()
    return options


def snapshot_path(output: Path, index: int) -> Path:
    """``OUT.tif`` → ``OUT_001.tif`` (numbered snapshots)."""
    return output.with_name(f"{output.stem}_{index:03d}{output.suffix}")
