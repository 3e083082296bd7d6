"""`unerode-cli info DEM`: size, CRS, cell size in metres, extent, elevation statistics."""

from __future__ import annotations

import json
from typing import Annotated, Any

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import Band, Channel, InputDem, Quiet, Verbose


def info(
    dem: InputDem,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of text.")] = False,
    band: Band = None,
    channel: Channel = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Describe a heightfield: size, CRS, cell size (m), extent, elevations (m), nodata."""
    with reported_errors(verbose - quiet):
        from unerode_cli.cli.common import load

        summary = describe(load(dem, band, channel))
        summary["file"] = str(dem)
        if as_json:
            typer.echo(json.dumps(summary, indent=2))
        else:
            typer.echo(_as_text(summary))


def describe(terrain: Any) -> dict[str, Any]:
    """A JSON-able summary of a Terrain."""
    from pyproj import CRS

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
        "history_steps": len(json.loads(terrain.tags.get("UNERODE_HISTORY", "[]"))),
    }


def _as_text(s: dict[str, Any]) -> str:
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
