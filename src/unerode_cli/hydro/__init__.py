"""Flow routing on 8-neighbour grids: outlets, depression handling, receivers, accumulation."""

from __future__ import annotations

from unerode_cli.hydro.outlets import outlet_mask, parse_edges, require_outlets
from unerode_cli.hydro.routing import METHODS, Routing, accumulate, drainage_area, route

__all__ = [
    "METHODS",
    "Routing",
    "accumulate",
    "drainage_area",
    "outlet_mask",
    "parse_edges",
    "require_outlets",
    "route",
]
