"""The coupled glacial-cycle loop (001 §6): the 3 m shield, the process order, uplift."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.glacier import coupled, cycle
from unerode_cli.grid import Grid
from unerode_cli.processes.debris import DebrisParams


def _cliff(n: int = 24) -> tuple[np.ndarray, Grid, np.ndarray]:
    """A 60° cliff between two plateaus along x (cells of 20 m), outlets on the low edge."""
    grid = Grid.full((n, n), 20.0)
    x = np.arange(n) * 20.0
    bed = np.broadcast_to(np.clip((x - 200.0) * np.tan(np.radians(60.0)), 0.0, 200.0), (n, n)).copy()
    outlets = np.zeros((n, n), dtype=bool)
    outlets[:, 0] = True
    return bed, grid, outlets


def test_cells_under_thicker_ice_than_the_shield_see_no_other_process():
    bed, grid, outlets = _cliff()
    ice = np.zeros_like(bed)
    ice[:12] = 50.0                                   # the northern half of the cliff is under ice
    ice[12:14] = 2.0                                  # thin ice does not shield
    erosion = cycle.IceFreeErosion(cycle.SurfaceParams(), grid, outlets)
    new = erosion(coupled.GlacierState(bed, ice), 100.0)
    change = new.bed - bed
    assert np.abs(change[:12]).max() == 0.0
    cliff = (slice(14, None), slice(11, 15))          # the free cliff face, 60° > s_c = 37°
    assert -1.0 < change[cliff].min() < -0.01         # rock walls retreat at 0.1–10 mm/y
    assert -1.0 < change[12:14, 11:15].min() < -0.01
    assert sum(erosion.removed.values()) > 0.0


def test_processes_switched_off_leave_only_the_uplift():
    bed, grid, outlets = _cliff()
    params = cycle.SurfaceParams(hillslope=None, debris=None, fluvial=None, uplift=2e-3)
    new = cycle.IceFreeErosion(params, grid, outlets)(coupled.GlacierState(bed, np.zeros_like(bed)), 500.0)
    change = new.bed - bed
    assert change[outlets].max() == 0.0
    assert change[~outlets] == pytest.approx(1.0, abs=1e-12)


def test_a_long_debris_step_relaxes_the_free_cliff_to_the_critical_angle():
    bed, grid, outlets = _cliff()
    params = cycle.SurfaceParams(hillslope=None, fluvial=None, debris=DebrisParams(k_df=1.0))
    new = cycle.IceFreeErosion(params, grid, outlets)(coupled.GlacierState(bed, np.zeros_like(bed)), 1e4)
    slope = np.abs(np.diff(new.bed[12], axis=0)) / 20.0
    assert slope.max() == pytest.approx(np.tan(np.radians(37.0)), rel=0.02)


def test_a_negative_shield_is_refused():
    bed, grid, outlets = _cliff()
    with pytest.raises(ValueError, match="shield"):
        cycle.IceFreeErosion(cycle.SurfaceParams(shield=-1.0), grid, outlets)


def _coast(n: int = 24) -> tuple[np.ndarray, Grid, np.ndarray]:
    """A plane rising 4 m per 20 m cell towards the east from −40 m on the west edge: cells of
    columns 0–10 are at or below 0 m. Outlets on every edge (as glaciate)."""
    grid = Grid.full((n, n), 20.0)
    bed = np.broadcast_to(-40.0 + 4.0 * np.arange(n), (n, n)).astype(np.float64)
    outlets = np.zeros((n, n), dtype=bool)
    outlets[[0, -1], :] = outlets[:, [0, -1]] = True
    return bed, grid, outlets


def test_cells_at_or_below_sea_level_are_outlets_where_the_rivers_end():
    bed, grid, outlets = _coast()
    params = cycle.SurfaceParams(hillslope=None, debris=None, fluvial=cycle.fluvial_of_table_1(k_f=1e-4),
                                 uplift=1e-4)
    state = coupled.GlacierState(bed, np.zeros_like(bed), time=100.0)
    coast = cycle.IceFreeErosion(params, grid, outlets, sea_level=lambda t: 0.0)
    change = coast(state, 100.0).bed - bed
    sea = bed <= 0.0
    assert np.array_equal(coast.base_level, outlets | sea) and sea[:, :11].all() and not sea[:, 11:].any()
    assert np.all(change[sea] == 0.0)                 # neither eroded nor uplifted: base level
    # the rivers run west and end at the coast: a land column drains the 12, 11, … 1 cells east of
    # it; Δz = U·dt − k_f·A^m·S^n·dt with A in m², S = 4/20 to the receiver, m = 0.4, n = 1
    area = np.arange(12, 0, -1) * 400.0
    expected = 1e-4 * 100.0 - 1e-4 * area ** 0.4 * 0.2 * 100.0
    np.testing.assert_allclose(change[1:-1, 11:-1], np.broadcast_to(expected, (22, 12)), rtol=1e-9)
    inland = cycle.IceFreeErosion(params, grid, outlets)(state, 100.0).bed - bed
    np.testing.assert_array_equal(inland[:, 11:], change[:, 11:])   # the same rivers upstream …
    assert inland[1:-1, 1:11].max() < -0.05          # … that, without a sea, cut on to the west edge


def test_the_sea_is_found_again_at_each_update_of_the_drainage():
    bed, grid, outlets = _coast()
    params = cycle.SurfaceParams(hillslope=None, debris=None, fluvial=None, drainage_every=2)
    rising = cycle.IceFreeErosion(params, grid, outlets, sea_level=lambda t: -40.0 + t / 10.0)  # m
    flooded = []
    for t in (100.0, 200.0, 300.0):                   # sea at −30, −20, −10 m at the steps' ends
        rising(coupled.GlacierState(bed, np.zeros_like(bed), time=t), 100.0)
        flooded.append(int(np.count_nonzero(rising.base_level[5])))
    assert flooded == [3 + 1, 3 + 1, 8 + 1]          # west columns ≤ sea, and the east edge
