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
