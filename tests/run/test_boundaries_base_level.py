"""Base levels of a climate run's boundary nodes: only sea follows sea level; the other nodes
keep their elevation, rise with the uplift or follow a table."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from unerode_cli.errors import InputError
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.boundaries import base_levels_from_options

SPAN = (0.0, 20.0)


def ramp(sea_corner: bool = False, hole: bool = False) -> Terrain:
    """8 × 6 cells of 30 m rising north from 5 m; optionally two south-edge cells below 0 m and
    a nodata hole."""
    rows, _ = np.indices((8, 6))
    z = 5.0 + 2.0 * (7 - rows)
    if sea_corner:
        z[-1, :2] = [-3.0, 0.0]
    if hole:
        z[3:5, 2:4] = np.nan
    return Terrain(z.astype(np.float64), 30.0, 30.0)


def levels_after(terrain: Terrain, sea_change: float, age_ka: float = 20.0, uplift=0.0,
                 dt: float = -20000.0, **options):
    """The base levels from ``options`` and the elevation after setting them once."""
    arguments = {"outlets": "all", "dirichlet": None, "coast": "none", "edge_base": "fixed",
                 "sea_start": 0.0, "span_ka": SPAN, **options}
    levels = base_levels_from_options(terrain, **arguments)
    h = terrain.elevation.copy()
    levels.set_levels(h, terrain.elevation, sea_change, age_ka, uplift, dt)
    return levels, h


def test_an_inland_dem_keeps_every_edge_whatever_the_sea_does() -> None:
    terrain = ramp()
    levels, h = levels_after(terrain, -120.0)
    assert np.array_equal(h, terrain.elevation)
    assert levels.counts() == {"sea_cells": 0, "coast_edge_cells": 0, "fixed_edge_cells": 24,
                               "uplift_edge_cells": 0, "table_edge_cells": 0,
                               "coarse_edge_cells": 0}
    assert levels.summary() == \
        "0 coast-edge and 0 sea cells follow sea level, 24 edge cells keep their elevation"


def test_a_coast_edge_follows_sea_level_and_the_other_edges_stay() -> None:
    terrain = ramp()
    levels, h = levels_after(terrain, -120.0, coast="S")
    np.testing.assert_array_equal(h[-1], terrain.elevation[-1] - 120.0)
    np.testing.assert_array_equal(h[:-1], terrain.elevation[:-1])
    assert levels.counts()["coast_edge_cells"] == 6 and levels.counts()["fixed_edge_cells"] == 18


def test_the_coast_drains_even_when_no_edge_is_chosen_as_outlet() -> None:
    levels, _ = levels_after(ramp(), 0.0, outlets="none", coast="S")
    assert np.array_equal(levels.nodes, levels.coast) and levels.coast[-1].all()
    outlets = levels.boundaries(None).outlets(ramp().elevation, ramp())
    assert np.array_equal(outlets, levels.coast)


def test_edge_cells_at_or_below_the_start_sea_level_are_sea_by_default() -> None:
    terrain = ramp(sea_corner=True)
    levels, h = levels_after(terrain, -100.0)
    assert levels.sea[-1, :2].all() and levels.sea.sum() == 2
    np.testing.assert_array_equal(h[-1, :2], [-103.0, -100.0])
    np.testing.assert_array_equal(h[-1, 2:], terrain.elevation[-1, 2:])
    # without sea outlets only the coast is sea
    levels, h = levels_after(terrain, -100.0, sea_start=None)
    assert not levels.sea.any() and np.array_equal(h, terrain.elevation)


def test_uplift_raises_the_edges_by_u_dt_each_step_and_a_map_cell_by_cell() -> None:
    terrain = ramp()
    u = np.full(terrain.shape, 1e-3)
    u[0, :] = 2e-3
    levels, h = levels_after(terrain, -120.0, uplift=u, dt=1000.0, edge_base="uplift")
    levels.set_levels(h, terrain.elevation, -120.0, 18.0, u, 1000.0)
    np.testing.assert_allclose(h[0], terrain.elevation[0] + 4.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(h[-1], terrain.elevation[-1] + 2.0, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(h[1:-1, 1:-1], terrain.elevation[1:-1, 1:-1])
    assert levels.counts()["uplift_edge_cells"] == 24


def test_a_table_moves_the_edges_by_its_change_since_the_start(tmp_path: Path) -> None:
    table = tmp_path / "outlet.csv"
    table.write_text("# river level at the outlet of a coarser run\nage_ka,elevation_m\n"
                     "30,80\n0,100\n10,90\n")
    terrain = ramp(hole=True)
    levels, h = levels_after(terrain, -120.0, age_ka=20.0, edge_base=str(table))
    # T(20) = 85, T(0) = 100: every edge and nodata-border cell 15 m lower, each its own shape
    nodes = levels.edge
    assert nodes[2, 2] and levels.counts()["table_edge_cells"] == int(nodes.sum()) == 24 + 12
    np.testing.assert_allclose(h[nodes], terrain.elevation[nodes] - 15.0, rtol=0, atol=1e-12)
    assert levels.summary().endswith("edge cells follow the --edge-base table")


def test_the_nodata_borders_can_be_the_coast() -> None:
    terrain = ramp(hole=True)
    levels, h = levels_after(terrain, -50.0, coast="nodata")
    assert levels.coast[2, 2] and not levels.coast[0].any()
    np.testing.assert_array_equal(h[2, 1:5], terrain.elevation[2, 1:5] - 50.0)
    np.testing.assert_array_equal(h[0], terrain.elevation[0])


@pytest.mark.parametrize(("options", "message"), [
    ({"coast": "south"}, "--coast must be none, all or a comma list"),
    ({"edge_base": "missing.csv"}, "cannot read the edge-base file missing.csv"),
    ({"span_ka": (0.0, 40.0)}, "covers 0–30 ka, not the whole run from 0 to 40 ka"),
])
def test_bad_boundaries_are_refused_in_one_sentence(tmp_path: Path, options: dict, message: str) -> None:
    table = tmp_path / "outlet.csv"
    table.write_text("age_ka,elevation_m\n0,100\n30,80\n")
    options = {"edge_base": str(table), **options}
    with pytest.raises(InputError, match=message):
        levels_after(ramp(), 0.0, **options)


def test_a_table_with_an_age_twice_is_refused_naming_the_line(tmp_path: Path) -> None:
    table = tmp_path / "outlet.csv"
    table.write_text("age_ka,elevation_m\n0,100\n10,90\n0,95\n")
    with pytest.raises(InputError, match="line 4: age 0 ka is given twice"):
        levels_after(ramp(), 0.0, edge_base=str(table))
