"""Map edges do not drive a glacier run on a crop (``coupled._erosion_rate``, issue #46 item 5).

A 128 × 128 window (5.9 km square, 46 m cells) of the Grindelwald DEM, cut across two valley
glaciers that leave it through its south and east edges, under an ELA of 2900 m for 2000 years
with the defaults of ``glaciate`` (Blatter–Pattyn, open edges whose bed follows the interior,
steps of 50 y) but velocity solves to a residual of 0.03 (minutes instead of an hour). The band
of cells within 500 m of the map's edge (31 % of the area) must not take more of the eroded rock
than 1.2 times its share of the area, nor more than its share of the ice area of the fastest 1 %
of the ice; across every edge the bed keeps its slope.

Measured with the former solver rule (solves ended by an energy estimate): the band holds 24 % of
the eroded rock (0.78 of its share of the area) and none of the fastest 1 % of the ice (the
fastest ice, 128 m/y, lies 35 cells from the edge); at 0.03 the test passes in 92 s on two busy
cores. Slow: ``pytest -m slow``.
"""

from __future__ import annotations

import numpy as np
import pytest
from tests.conftest import SHARED_DATA
from tests.glacier.test_glacier_plausibility import grindelwald_run

from unerode_cli.glacier import coupled
from unerode_cli.hydro import outlet_mask

GRINDELWALD = SHARED_DATA / "dem" / "alps_grindelwald" / "dem.tif"
WINDOW = (slice(216, 344), slice(100, 228))
BAND = 500.0  # m


@pytest.mark.slow
@pytest.mark.skipif(not GRINDELWALD.exists(), reason="needs ../shared/data/dem/alps_grindelwald")
def test_the_edge_band_erodes_no_more_than_the_interior_on_a_crop():
    terrain, bed0, grid, params, result = grindelwald_run(
        WINDOW, lambda grid: coupled.CoupledParams(edge_cells=outlet_mask(grid), flow_rtol=0.03))
    final = result.state
    flow = coupled.flow_field(final.bed, final.thickness, grid, params, warm=final.lattice)
    ny, nx = bed0.shape
    rows, cols = np.mgrid[0:ny, 0:nx]
    distance = np.minimum.reduce([rows, ny - 1 - rows, cols, nx - 1 - cols]) * terrain.dx
    band = distance < BAND
    eroded = bed0 - final.bed
    assert eroded.sum() * grid.cell_area > 1e7  # m³: the glaciers cut their beds
    erosion_ratio = (eroded[band].sum() / eroded.sum()) / band.mean()
    assert erosion_ratio <= 1.2
    assert erosion_ratio == pytest.approx(0.78, abs=0.15)
    ice = final.thickness >= 1.0
    speed = np.hypot(*flow.surface)
    fastest = ice & (speed >= np.percentile(speed[ice], 99))
    assert (fastest & band).sum() / fastest.sum() <= (ice & band).sum() / ice.sum()
    lowering = bed0 - final.bed
    np.testing.assert_allclose(lowering[1:-1, -1], lowering[1:-1, -2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(lowering[-1, 1:-1], lowering[-2, 1:-1], rtol=0, atol=1e-9)
