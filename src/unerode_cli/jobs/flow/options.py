"""Options of `flow` (declared once: CLI, pipeline, Python API, provenance)."""

from __future__ import annotations

from unerode_cli.run.common_options import (
    COG,
    CREATION_OPTIONS,
    DIRICHLET,
    OUTLETS,
    OUTPUT,
    OVERWRITE,
    PREVIEW,
    READING,
    SEA_LEVEL,
    SOURCE,
    renamed,
)
from unerode_cli.run.declare import Opt

#: What `flow` writes: discharge (m³/y), drainage area (m²) or D8 receivers (ESRI codes).
WHAT = ("discharge", "area", "receivers")

OPTIONS = (
    renamed(SOURCE, "dem"),
    OUTPUT,
    Opt("what", str, "discharge", "discharge (m³/y), drainage area (m²), or receivers (ESRI D8 codes: "
        "E 1, SE 2, S 4, SW 8, W 16, NW 32, N 64, NE 128; 0 outlet).", choices=WHAT),
    Opt("method", str, "mfd", "mfd: multiple flow directions ∝ slope; d8: steepest descent.",
        choices=("mfd", "d8")),
    Opt("precipitation", str, "1.0", "Precipitation rate (m/y): a number or a raster on the DEM's grid.",
        flags=("--precipitation", "-p")),
    OUTLETS,
    SEA_LEVEL,
    DIRICHLET,
    *READING,
    COG,
    CREATION_OPTIONS,
    OVERWRITE,
    PREVIEW,
)
