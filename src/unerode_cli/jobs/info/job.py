"""The `info` job: describe a heightfield (size, CRS, cell size, extent, elevations, nodata)
as text or JSON on the standard output."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from pyproj import CRS

from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.provenance import history
from unerode_cli.io.rasters import read_header, read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.info.options import OPTIONS
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.memory import check_read


@declared("info", OPTIONS)
class InfoJob(Job):
    """Describe the heightfield ``dem``; writes no file, prints the description (``progress.data``)."""

    def plan(self, outputs: OutputPlan) -> Terrain:
        """Read the DEM, once its header says that its cells fit in memory (refused if not)."""
        outputs.read(self.dem)
        check_read(read_header(self.dem, band=self.band, georef=input_georef(self)))
        return read_terrain(self.dem, band=self.band, channel=self.channel, georef=input_georef(self))

    def run(self, planned: Terrain, progress: Progress) -> None:
        summary = describe(planned, self.dem)
        progress.data(json.dumps(summary, indent=2) if self.as_json else as_text(summary))


def describe(terrain: Terrain, path: Path) -> dict[str, Any]:
    """A JSON-able summary of ``terrain`` (read from ``path``): size, CRS, cell size (m), extent,
    elevations (m), nodata and the number of unerode-cli steps in its history."""
    ny, nx = terrain.shape
    valid = ~terrain.nodata_mask
    crs = CRS.from_wkt(terrain.crs_wkt) if terrain.crs_wkt else None
    left, top = terrain.transform @ (0, 0)
    right, bottom = terrain.transform @ (nx, ny)
    z = terrain.elevation[valid]
    return {
        "width": nx,
        "height": ny,
        "crs": crs.name if crs else None,
        "epsg": crs.to_epsg() if crs else None,
        "cell_size_m": [terrain.dx, terrain.dy],
        "pixel_size": [terrain.transform.a, -terrain.transform.e],
        "extent": {"left": left, "bottom": bottom, "right": right, "top": top},
        "elevation_m": {
            "min": float(z.min()) if z.size else None,
            "mean": float(z.mean()) if z.size else None,
            "max": float(z.max()) if z.size else None,
        },
        "nodata_value": terrain.nodata,
        "nodata_cells": int(terrain.nodata_mask.sum()),
        "history_steps": len(history(terrain)),
        "file": str(path),
    }


def as_text(s: dict[str, Any]) -> str:
    """The summary of :func:`describe` as aligned lines of text."""
    e, z = s["extent"], s["elevation_m"]
    crs = f"{s['crs']} (EPSG:{s['epsg']})" if s["epsg"] else (s["crs"] or "none (metres assumed)")
    fmt = lambda v: "n/a" if v is None else f"{v:.2f}"  # noqa: E731
    cells = s["width"] * s["height"]
    return "\n".join([
        f"file        {s['file']}",
        f"size        {s['width']} × {s['height']} cells",
        f"crs         {crs}",
        f"cell size   {s['cell_size_m'][0]:.3f} m × {s['cell_size_m'][1]:.3f} m (E-W × N-S)",
        f"extent      x {e['left']:.10g} … {e['right']:.10g}, y {e['bottom']:.10g} … {e['top']:.10g}",
        f"elevation   min {fmt(z['min'])} m, mean {fmt(z['mean'])} m, max {fmt(z['max'])} m",
        f"nodata      {s['nodata_cells']} cells ({100.0 * s['nodata_cells'] / cells:.1f} %), "
        f"value {s['nodata_value']}",
        f"history     {s['history_steps']} unerode-cli step(s)",
    ])
