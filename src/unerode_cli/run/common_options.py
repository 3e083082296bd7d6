"""Declarations of the options that several jobs share (DESIGN §5), with units in their help.

A job takes one of these as it is, or renamed with :func:`renamed` / with another default via
:func:`with_default`, so that each option's text, unit and bounds are written once.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from unerode_cli.errors import InputError
from unerode_cli.io.georef import parse_crs
from unerode_cli.io.input_georef import InputGeoref
from unerode_cli.run.declare import Opt
from unerode_cli.run.values import Number, OptionParser

#: Parsers of kinds of numbers that several options share: a time span (years, > 0) and an
#: elevation (m).
POSITIVE_YEARS = Number("years", 0.0, above=True)
METRES = Number("m")

#: Help panels of the shared options.
INPUT_PANEL = "Inputs"
BOUNDARY_PANEL = "Boundaries"
OUTPUT_PANEL = "Outputs"
CHECKPOINT_PANEL = "Checkpoints"


def renamed(opt: Opt, name: str, **changes: Any) -> Opt:
    """``opt`` under another field name (the flag follows the name unless given)."""
    flags = changes.pop("flags", () if not opt.flags or opt.argument else opt.flags)
    return dataclasses.replace(opt, name=name, flags=flags, **changes)


def with_default(opt: Opt, default: Any) -> Opt:
    """``opt`` with another default value."""
    return dataclasses.replace(opt, default=default)


SOURCE = Opt("source", Path, help="Input heightfield (GeoTIFF, any GDAL raster, or .exr), metres.",
             argument=True, required=True, role="input", record="input")
OUTPUT = Opt("output", Path, help="Output heightfield; the format follows the extension (.tif, .exr, ...).",
             argument=True, required=True, role="output", record=False)
BAND = Opt("band", int, help="Band to read from a multi-band raster (1-based).", minimum=1, record=False)
CHANNEL = Opt("channel", str, help="EXR channel to read (default: Y, else R, else the only float channel).",
              record=False)


class CrsText(OptionParser):
    """A CRS that pyproj parses (``EPSG:32632``, WKT, PROJ JSON or string), kept as given."""

    def parse(self, value: Any) -> str:
        text = str(value).strip()
        try:
            parse_crs(text)
        except InputError:
            raise ValueError(f"expected a CRS that pyproj knows (e.g. EPSG:32632 or a WKT string), "
                             f"got '{value}'") from None
        return text


INPUT_CRS = Opt("input_crs", str, None, "Assign this CRS (EPSG:n, WKT or PROJ string) to inputs that have "
                "none; an input with another CRS is refused (nothing is reprojected).", flags=("--crs",),
                parser=CrsText(), panel=INPUT_PANEL, metavar="CRS")
INPUT_CELL_SIZE = Opt("input_cell_size", float, None, "Cell size of inputs without a geotransform (e.g. an "
                      "EXR from Houdini), in the CRS's units (m without --crs); their lower-left corner is "
                      "put at (0, 0). An input with other cells is refused.",
                      flags=("--cell-size", "--input-cell-size"), parser=Number(minimum=0.0, above=True),
                      panel=INPUT_PANEL)
INPUT_NODATA = Opt("input_nodata", float, None, "Nodata value of the inputs: their cells equal to it are "
                   "nodata, and it is the nodata value of the outputs.", flags=("--nodata",),
                   parser=Number(), panel=INPUT_PANEL)
#: Georeferencing assigned to the heightfields a job reads (see :func:`input_georef`).
GEOREF = (INPUT_CRS, INPUT_CELL_SIZE, INPUT_NODATA)
#: The same for ``convert``, whose ``--cell-size`` resamples: the cell size is ``--input-cell-size``.
GEOREF_CONVERT = (INPUT_CRS, dataclasses.replace(INPUT_CELL_SIZE, flags=("--input-cell-size",)), INPUT_NODATA)


def input_georef(job: Any) -> InputGeoref:
    """What a job's ``--crs``, ``--cell-size`` and ``--nodata`` assign to its inputs (nothing
    for a job without them)."""
    return InputGeoref(getattr(job, "input_crs", None), getattr(job, "input_cell_size", None),
                       getattr(job, "input_nodata", None))


OVERWRITE = Opt("overwrite", bool, False, "Replace an existing output.", kind="flag", panel=OUTPUT_PANEL,
                record=False)
DTYPE = Opt("dtype", str, "float32", "Output sample type of GDAL outputs.", choices=("float32", "float64"),
            panel=OUTPUT_PANEL, record=False)
COG = Opt("cog", bool, False, "Write a Cloud-Optimized GeoTIFF.", kind="flag", panel=OUTPUT_PANEL,
          record=False)
CREATION_OPTIONS = Opt("co", str, None, "GDAL creation option KEY=VALUE (repeatable).", kind="multiple",
                       panel=OUTPUT_PANEL, record=False)
PREVIEW = Opt("preview", Path, None, "Also write a hillshade preview PNG of the output.", role="output",
              panel=OUTPUT_PANEL, record=False)
SEED = Opt("seed", int, 0, "Random seed (recorded in the output's history).")

FORCE = Opt("force", bool, False, "Run a DEM whose elevations cannot be metres of a real terrain "
            "(beyond -11 km … +9 km) as it is.", kind="flag", record=False)

#: The raster-output options of most jobs: format, creation options, overwrite and preview.
RASTER_OUTPUT = (DTYPE, COG, CREATION_OPTIONS, OVERWRITE, PREVIEW)
#: Reading a band of a multi-band raster or a channel of an EXR, and the georeferencing assigned.
READING = (BAND, CHANNEL, *GEOREF)

SNAPSHOTS_NC = Opt("snapshots_nc", Path, None, "Also write the snapshots as one CF-1.8 NetCDF time series "
                   "(.nc: time, y, x; CRS as grid mapping; units on every variable), for xarray and QGIS.",
                   role="output", panel=OUTPUT_PANEL, record=False, metavar="FILE.nc")

OUTLETS = Opt("outlets", str, "all", "Domain edges that drain out: all, none, or a comma list of N,E,S,W.",
              panel=BOUNDARY_PANEL)
SEA_LEVEL = Opt("sea_level", float, None, "Cells at or below this elevation (m) are outlets.",
                parser=METRES, panel=BOUNDARY_PANEL)
DIRICHLET = Opt("dirichlet", Path, None,
                "Raster on the DEM's grid; non-zero cells are fixed-elevation outlet nodes.",
                role="input", panel=BOUNDARY_PANEL)
COAST = Opt("coast", str, "none", "Sea edges, whose cells follow sea level: none, all, or a comma list of "
            "N,E,S,W and nodata (nodata borders).", panel=BOUNDARY_PANEL)
EDGE_BASE = Opt("edge_base", str, None, "Base level of the other boundary nodes: fixed (keep their "
                "elevation; the default), uplift (rise with U), coarse (follow the surface of the coarse "
                "run of --inflow-from; the default with it), or FILE, a CSV table of age_ka, elevation_m "
                "(move as it does since --from).", panel=BOUNDARY_PANEL)

CHECKPOINT_EVERY = Opt("checkpoint_every", int, 10, "Write a checkpoint (.OUT.checkpoint.npz beside OUT) "
                       "every this many steps.", minimum=1, panel=CHECKPOINT_PANEL, record=False)
RESUME = Opt("resume", bool, False, "Continue an interrupted run from its checkpoint (same inputs and "
             "options).", kind="flag", panel=CHECKPOINT_PANEL, record=False)
MAX_STEPS = Opt("max_steps", int, None, "Stop after this many steps of this invocation (checkpointed; "
                "continue with --resume).", minimum=1, panel=CHECKPOINT_PANEL, record=False)
#: Checkpoint and resume options of the time-stepping jobs.
CHECKPOINTS = (CHECKPOINT_EVERY, RESUME, MAX_STEPS)
