"""Climate forcing from a chronology (000 §5, DESIGN §7): tables of (age, value), sea level,
climate phases and the parameter schedule. Pure functions: no file is opened here (the pipeline
reads chronology files with ``unerode_cli.io.chronology_files.read_series``).

Ages are in ka (thousands of years before present) in these table functions, by nature;
the rest of the project counts time in years (``YEARS_PER_KA``).
"""

from unerode_cli.climate.chronology import KINDS, YEARS_PER_KA, Series, parse_table
from unerode_cli.climate.phases import (
    END_OF_GLACIAL,
    GLACIAL,
    INTERGLACIAL,
    PHASES,
    PhaseThresholds,
    classify,
    classify_d18o,
)
from unerode_cli.climate.schedule import DOWNSTREAM_K_D, DownstreamKd, Schedule, downstream_mask
from unerode_cli.climate.sealevel import DEFAULT_MAPPING, SeaLevelMapping, fit_mapping, sea_level

__all__ = [
    "DEFAULT_MAPPING",
    "DOWNSTREAM_K_D",
    "END_OF_GLACIAL",
    "GLACIAL",
    "INTERGLACIAL",
    "KINDS",
    "PHASES",
    "YEARS_PER_KA",
    "DownstreamKd",
    "PhaseThresholds",
    "Schedule",
    "SeaLevelMapping",
    "Series",
    "classify",
    "classify_d18o",
    "downstream_mask",
    "fit_mapping",
    "parse_table",
    "sea_level",
]
