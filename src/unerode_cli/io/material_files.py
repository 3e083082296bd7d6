"""Materials of layered terrains (003 §4.2).

- Materials table: CSV with a header row; columns ``name``, ``erodibility`` (K_ε of 003
  Eq. 2, Pa^-a, ≥ 0) and optionally ``critical_stress`` (τ_c of 003 Eq. 2, Pa, ≥ 0; empty or
  absent = 0, a note says when the column is absent) and ``description``, in any order; lines
  starting with ``#`` are comments. It is read like the observation tables (same rules, errors
  naming the line).
- Layers raster (read by ``grid_rasters.read_bands_on_grid``): one band per layer, thicknesses
  in metres, bottom layer first (band 1). Band descriptions may name each layer's material.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from unerode_cli.errors import InputError
from unerode_cli.io.csv_tables import table_number, table_rows
from unerode_cli.particles.terrain import Material

MATERIAL_COLUMNS = ("name", "erodibility", "critical_stress", "description")
MATERIAL_REQUIRED = ("name", "erodibility")


def read_materials(path: Path, on_note: Callable[[str], None] | None = None) -> list[Material]:
    """The materials of a CSV table (module docstring), in file order; ``on_note`` hears that
    the table has no ``critical_stress`` column, when it has none.

    Raises:
        InputError: unreadable file, unknown or missing column, or a bad row (the message
            names its line).
    """
    materials: list[Material] = []
    columns: set[str] = set()
    for line, row in table_rows(path, "materials", MATERIAL_COLUMNS, MATERIAL_REQUIRED):
        columns = set(row)
        if any(m.name == row["name"] for m in materials):
            raise InputError(f"{path}, line {line}: material '{row['name']}' is named twice.")
        materials.append(Material(row["name"], table_number(row, "erodibility", path, line, minimum=0.0),
                                  table_number(row, "critical_stress", path, line, minimum=0.0) or 0.0))
    if not materials:
        raise InputError(f"the materials table {path} lists no material.")
    if "critical_stress" not in columns and on_note is not None:
        on_note(f"note: the materials table {path} has no critical_stress column: every material "
                "detaches from τ_c = 0 Pa.")
    return materials
