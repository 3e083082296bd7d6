"""Materials of layered terrains (003 §4.2).

- Materials table: CSV with a header row; columns ``name``, ``erodibility`` (K_ε of 003
  Eq. 2, Pa^-a, ≥ 0) and optionally ``critical_stress`` (τ_c of 003 Eq. 2, Pa, ≥ 0; empty or
  absent = 0) and ``description``, in any order; lines starting with ``#`` are comments. It is
  read like the observation tables (same rules, errors naming the line).
- Layers raster (read by ``grid_rasters.read_bands_on_grid``): one band per layer, thicknesses
  in metres, bottom layer first (band 1). Band descriptions may name each layer's material.
"""

from __future__ import annotations

from pathlib import Path

from unerode_cli.errors import InputError
from unerode_cli.io.csv_tables import table_number, table_rows
from unerode_cli.particles.terrain import Material

MATERIAL_COLUMNS = ("name", "erodibility", "critical_stress", "description")
MATERIAL_REQUIRED = ("name", "erodibility")


def read_materials(path: Path) -> list[Material]:
    """The materials of a CSV table (module docstring), in file order.

    Raises:
        InputError: unreadable file, unknown or missing column, or a bad row (the message
            names its line).
    """
    materials: list[Material] = []
    for line, row in table_rows(path, "materials", MATERIAL_COLUMNS, MATERIAL_REQUIRED):
        if any(m.name == row["name"] for m in materials):
            raise InputError(f"{path}, line {line}: material '{row['name']}' is named twice.")
        materials.append(Material(row["name"], table_number(row, "erodibility", path, line, minimum=0.0),
                                  table_number(row, "critical_stress", path, line, minimum=0.0) or 0.0))
    if not materials:
        raise InputError(f"the materials table {path} lists no material.")
    return materials
