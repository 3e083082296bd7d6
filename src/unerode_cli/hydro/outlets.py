"""Outlets: the valid cells through which water and sediment leave the domain.

An outlet is a sink: it has no receivers and, in the processes, keeps its elevation (it is the
base level). Outlets come from chosen domain edges, the borders of nodata areas, Dirichlet
nodes and cells at or below sea level.
"""

from __future__ import annotations

import numpy as np

from unerode_cli.grid import Grid

EDGE_NAMES = ("N", "E", "S", "W")


def parse_edges(spec: str) -> frozenset[str]:
    """Parse an edge specification: ``"all"``, ``"none"`` or a comma list of N, E, S, W.

    Returns the set of edge letters, e.g. ``parse_edges("s, w") == {"S", "W"}``.
    """
    text = spec.strip().upper()
    if text == "ALL":
        return frozenset(EDGE_NAMES)
    if text == "NONE":
        return frozenset()
    letters = [part.strip() for part in text.split(",")]
    unknown = [part for part in letters if part not in EDGE_NAMES]
    if unknown:
        raise ValueError(f"edge specification {spec!r} must be 'all', 'none' or a comma list of N, E, S, W")
    return frozenset(letters)


def _touches_nodata(valid: np.ndarray) -> np.ndarray:
    """Valid cells with at least one nodata cell among their 8 neighbours (outside the grid
    is not nodata)."""
    ny, nx = valid.shape
    invalid = np.pad(~valid, 1, constant_values=False)
    near = np.zeros_like(valid)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr or dc:
                near |= invalid[1 + dr : 1 + dr + ny, 1 + dc : 1 + dc + nx]
    return near & valid


def outlet_mask(
    grid: Grid,
    edges: str = "all",
    *,
    nodata_borders: bool = True,
    dirichlet: np.ndarray | None = None,
    elevation: np.ndarray | None = None,
    sea_level: float | None = None,
) -> np.ndarray:
    """Build the bool[ny, nx] outlet mask (always a subset of ``grid.valid``).

    Args:
        grid: the grid (its ``valid`` mask excludes nodata).
        edges: domain edges that drain out: ``"all"``, ``"none"`` or e.g. ``"S,W"``
            (N = row 0, S = last row, W = column 0, E = last column).
        nodata_borders: valid cells 8-adjacent to nodata cells are outlets.
        dirichlet: optional bool[ny, nx] mask of fixed-elevation nodes.
        elevation: float64[ny, nx] elevation (m); needed with ``sea_level``.
        sea_level: cells at or below this elevation (m) are outlets.
    """
    valid = grid.valid
    mask = np.zeros(grid.shape, dtype=bool)
    chosen = parse_edges(edges)
    if "N" in chosen:
        mask[0, :] = True
    if "S" in chosen:
        mask[-1, :] = True
    if "W" in chosen:
        mask[:, 0] = True
    if "E" in chosen:
        mask[:, -1] = True
    if nodata_borders:
        mask |= _touches_nodata(valid)
    if dirichlet is not None:
        if dirichlet.shape != grid.shape:
            raise ValueError(f"Dirichlet mask has shape {dirichlet.shape}, the grid has {grid.shape}")
        mask |= dirichlet.astype(bool)
    if sea_level is not None:
        if elevation is None:
            raise ValueError("a sea level needs the elevation to find the cells below it")
        with np.errstate(invalid="ignore"):
            mask |= elevation <= sea_level
    return mask & valid


def require_outlets(outlets: np.ndarray) -> None:
    """Raise ValueError when the mask holds no outlet at all."""
    if not outlets.any():
        raise ValueError(
            "the domain has no outlet: choose draining edges, nodata borders, Dirichlet nodes or a sea level"
        )
