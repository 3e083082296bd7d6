"""001 §7.1 and Fig. 13: a glacier alone turns a V valley into a U (Blatter–Pattyn), the SIA does
not (a narrow defile, or numerical divergence).

The experiment is ``bench/glacier_u_valley.py`` with its defaults (its docstring has the setup):
the valley of 40 × 128 cells of 50 m (30° walls up to the map's north and south edges, floor
graded at 0.1 down to the east, headwall at the west), ELA 2100 m, 1000 y of spin-up without
erosion, then 2250 y of abrasion and quarrying at 001 Table 1's top values (k_e = 1.1e-6,
k_q = 2.6e-4) multiplied by F = 20 (a morphological acceleration as in 001 Fig. 17: 2250 y erode
like 45 ky), 20-year steps, while the ELA falls linearly to 1763 m. The U-shape exponent b
(``landforms.fit_power_law``) is the median over the 34 columns of the glacier's middle reach,
fitted between the walls' tops; the trough's b within the spun-up trunk glacier's margins.

Measured (converged Blatter–Pattyn solves, FLOW_RTOL = 1e-3): b = 1.00 before, 1.58 after
(1.16, 1.28, 1.43 and 1.54 at 10, 20, 30 and 40 ky-equivalent); in the trough 1.00 → 1.52; the
glacier grows with the cooling from 0.43 to 1.17 km³ (thickest ice 221 m → 332 m) and lowers
its floor by up to 339 m. The run takes ~5 min on one loaded core. Under a constant ELA the
glacier thins as it sinks with its bed and b fitted between the walls' tops stays at 1.0–1.09
(docs/glaciate.md §6).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))

import glacier_u_valley as uv  # noqa: E402


@pytest.fixture(scope="module")
def blatter() -> dict:
    return uv.experiment(uv.Setup(snapshot_every=250.0))


@pytest.mark.slow
def test_the_blatter_glacier_carves_a_u(blatter):
    """001 §7.1, Fig. 13: Blatter–Pattyn erosion turns the V (b ≈ 1) into a U (b ≥ 1.5), fitted
    between the walls' tops and within the trunk glacier's margins, with every solve converged."""
    assert blatter["diverged"] is None
    assert blatter["unconverged_solves"] == 0
    assert len(blatter["b_before"]) >= 30
    assert blatter["median_b_before"] == pytest.approx(1.0, abs=0.01)
    assert blatter["median_b_trough_before"] == pytest.approx(1.0, abs=0.01)
    assert blatter["median_b_after"] >= 1.5
    assert blatter["median_b_after"] == pytest.approx(1.58, abs=0.06)
    assert blatter["median_b_trough_after"] >= 1.5


@pytest.mark.slow
def test_the_u_deepens_steadily_under_a_glacier_that_keeps_its_valley(blatter):
    """The exponent rises at every snapshot (no gorge cut into the floor on the way), the glacier
    thickens with the cooling (221 m → 332 m) and the floor is lowered by a few hundred metres."""
    b = [s["median_b"] for s in blatter["series"]]
    assert all(later > earlier for earlier, later in zip(b, b[1:], strict=False))
    assert blatter["spinup_max_ice_m"] == pytest.approx(221.0, abs=20.0)
    assert blatter["series"][-1]["max_ice_m"] == pytest.approx(332.0, abs=35.0)
    assert 250.0 <= blatter["max_lowering_m"] <= 450.0


@pytest.mark.slow
def test_the_sia_glacier_cuts_a_defile_and_diverges_as_001_fig13_reports():
    """001 Fig. 13: eroding with the SIA carves a narrow defile and ends in numerical divergence.
    Measured on the same experiment: the SIA glacier (thickest 137 m after the spin-up, less
    than Blatter's 221 m) diverges after ~190 y (×F = 3.8 ky) of erosion, its floor notched by a
    cut two to three cells wide; b = 1.22 at its last snapshot (150 y), where Blatter–Pattyn had
    1.10 at 250 y on its way to 1.58."""
    out = uv.experiment(uv.Setup(iceflow="sia", snapshot_every=50.0))
    assert out["diverged"] is not None
    assert out["spinup_max_ice_m"] == pytest.approx(137.0, abs=20.0)
    eroded_before = out["series"][-1]["years"]
    assert 100.0 <= eroded_before <= 400.0
    assert out["series"][-1]["median_b"] == pytest.approx(1.22, abs=0.06)
