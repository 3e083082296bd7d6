"""001 §7.1 and Fig. 8: a glacier leaves a tributary valley hanging above the trunk it deepened.

The experiment is ``bench/glacier_hanging_valley.py`` with its defaults (its docstring has the
setup): a trunk V valley and a 1.6 km tributary graded to it (accordant at the junction),
glaciated under the cooling climate of the U-valley experiment (``glacier_u_valley.py``), Table 1
erosion × 20 for 2250 years. Measured: the trunk glacier (161 m at the junction after the
spin-up) lowers the trunk's floor there by 258 m, the tributary glacier (117 m, 600 m up the
tributary) its floor by 196 m; the tributary's floor, carried down at its own gradient from its
mouth, meets the trunk's axis 63 m above the trunk's floor (0 before): a hanging valley whose
ice surface stays continuous with the trunk's, as 001 describes. 4 min on one loaded core.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))

import glacier_hanging_valley as hv  # noqa: E402
import glacier_u_valley as uv  # noqa: E402


@pytest.mark.slow
def test_the_trunk_glacier_leaves_its_tributary_hanging():
    out = hv.experiment(hv.Confluence(), uv.Setup())
    assert out["unconverged_solves"] == 0
    assert out["hanging_before_m"] == pytest.approx(0.0, abs=1e-6)
    assert out["trunk_ice_m"] > out["tributary_ice_m"]
    assert out["trunk_lowered_m"] - out["tributary_lowered_m"] == pytest.approx(62.0, abs=15.0)
    assert out["hanging_after_m"] >= 20.0  # the landforms command's threshold of a hanging step
    assert out["hanging_after_m"] == pytest.approx(63.0, abs=10.0)
