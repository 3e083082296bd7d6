"""Unit of K_th: m per 1000 years per unit of slope above the talus slope (000 Table 2, Eq. 15)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from unerode_cli.climate.phases import GLACIAL, INTERGLACIAL
from unerode_cli.climate.schedule import Schedule
from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask
from unerode_cli.processes import thermal, thermal_ca

TAN30 = math.tan(math.radians(30.0))


def talus_plane(n: int, dx: float, slope: float) -> tuple[np.ndarray, Grid, np.ndarray]:
    """A plane dipping north at ``slope`` (m/m), its grid of ``dx`` m cells and edge outlets."""
    rows = np.mgrid[0:n, 0:n][0].astype(float)
    grid = Grid.full((n, n), dx)
    return slope * dx * rows, grid, outlet_mask(grid, "all")


@pytest.mark.parametrize("k_th", [0.002, 0.008, 0.5])
@pytest.mark.parametrize("dx", [2.0, 30.0])
def test_a_talus_slope_is_lowered_by_k_th_metres_per_ky_per_unit_of_excess_slope(k_th, dx):
    """000 Eq. 15: Δh = −Δt·K_th·(|∇h| − tan θ), K_th in m/ky: a plane of slope 1 under the
    glacial 0.008 loses 0.008·(1 − tan 30°) m in one 1000-year step, whatever the cell size."""
    h, grid, outlets = talus_plane(12, dx, 1.0)
    change = thermal.step(h, grid, outlets, thermal.ThermalParams(k_th=k_th, talus_angle=30.0),
                          1000.0)
    expected = -k_th * (1.0 - TAN30)
    np.testing.assert_allclose(change.dh[1:-1, 1:-1], expected, rtol=0.0, atol=1e-9)
    half = thermal.step(h, grid, outlets, thermal.ThermalParams(k_th=k_th), 500.0).dh
    np.testing.assert_allclose(half[1:-1, 1:-1], 0.5 * expected, rtol=0.0, atol=1e-9)


def test_per_year_divides_by_a_thousand_for_numbers_and_rasters():
    assert thermal.per_year(0.008) == pytest.approx(8e-6, rel=1e-15)
    raster = np.array([[0.002, 0.008]])
    np.testing.assert_allclose(thermal.per_year(raster), [[2e-6, 8e-6]], rtol=1e-15)
    assert thermal.K_TH.unit == "m/ky" and thermal.K_TH.default == 0.002


@pytest.mark.parametrize("dx", [2.0, 30.0])
def test_every_table_2_combination_is_stable_at_the_paper_step(dx):
    """000 Table 2: Δt = 1000 years, Δx 2–30 m, K_th up to 0.5 (1000 years)⁻¹; the CFL limit
    Δx / (√2·K_th/1000) stays above 1000 years (m/y would give 2.8 years on 2 m cells)."""
    h, grid, outlets = talus_plane(12, dx, 1.0)
    for k_th in (0.002, 0.008, 0.5):
        limit = thermal.max_stable_dt(h, grid, thermal.ThermalParams(k_th=k_th), outlets)
        assert limit == pytest.approx(dx / (math.sqrt(2.0) * k_th / 1000.0), rel=1e-12)
        assert limit >= 1000.0
    assert thermal_ca.max_stable_dt(grid, thermal_ca.ThermalCAParams(k_th=0.5)) == pytest.approx(
        0.5 * dx / 5e-4, rel=1e-12)


def test_the_schedule_gives_the_paper_numbers_in_m_per_ky():
    """000 §5.2: 0.002 in interglacials, 0.008 in glacials, in K_th's unit (m/ky); over the 814 ka
    of the Tautavel run even the glacial value lowers a slope one unit above tan θ by < 7 m."""
    schedule = Schedule()
    assert schedule.values(INTERGLACIAL, 0.0)["k_th"] == 0.002
    glacial = schedule.values(GLACIAL, -120.0)["k_th"]
    assert glacial == 0.008
    assert thermal.per_year(glacial) * 814_000.0 == pytest.approx(6.512, rel=1e-12)
