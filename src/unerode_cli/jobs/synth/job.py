"""A `synth` job: a reproducible synthetic DEM with a CRS, written with its sidecar."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.cellsize import cell_size_metres
from unerode_cli.io.georef import centred_transform, parse_crs
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.outputs import Outputs, save
from unerode_cli.synthetic import synthesize


@dataclass(frozen=True)
class SynthJob:
    """``size`` cells square of ``dx`` metres, ``relief`` metres of land, in ``crs`` around
    ``centre`` ("X,Y" in CRS units; None: the CRS's area of use)."""

    outputs: Outputs
    kind: str = "mountain"
    size: int = 512
    dx: float = 30.0
    relief: float = 2000.0
    seed: int = 1
    crs: str = "EPSG:32632"
    centre: str | None = None
    sea_nodata: bool = False


def run_synth(job: SynthJob) -> None:
    """Check the options and output, synthesise and write the DEM."""
    job.outputs.check()
    if not job.dx > 0:
        raise InputError(f"--dx must be a positive cell size in metres, got {job.dx}.")
    crs = parse_crs(job.crs)
    shape = (job.size, job.size)
    transform = centred_transform(crs, shape, job.dx, parse_centre(job.centre))
    elevation = synthesize(job.kind, shape, job.relief, job.seed)
    if job.sea_nodata:
        elevation = np.where(elevation < 0.0, np.nan, elevation)
    wkt = crs.to_wkt()
    cell = cell_size_metres(wkt, transform, shape, str(job.outputs.path))
    terrain = Terrain(elevation, cell.dx, cell.dy, wkt, transform,
                      -9999.0 if job.sea_nodata else None, {"AREA_OR_POINT": "Area", "UNIT": "metre"})
    save(terrain, job.outputs, "synth",
         {"kind": job.kind, "size": job.size, "dx": job.dx, "relief": job.relief, "crs": job.crs,
          "centre": job.centre, "sea_nodata": job.sea_nodata}, seed=job.seed)


def parse_centre(text: str | None) -> tuple[float, float] | None:
    """``"X,Y"`` → (x, y); None stays None."""
    if text is None:
        return None
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--centre expects X,Y (two numbers), got '{text}'.") from None
    return (x, y)
