"""001 §7.1 and Fig. 13 with ``--iceflow cnn`` (001 §4–5): the network trained on the fly carves
the same U as the converged Blatter–Pattyn solver.

The experiment is ``bench/glacier_u_valley.py`` with its defaults and ``iceflow="cnn"`` (seed 0:
one network for the spin-up and the erosion, 10 Adam steps and 2 L-BFGS iterations a step, the
converged solver finishing every step whose refined residual is above 1e-3): the 40 × 128 V
valley of 50 m cells, 1000 y of spin-up at ELA 2100 m, then 2250 y of abrasion and quarrying at
001 Table 1's top values × F = 20 (45 ky-equivalent) in 20-year steps while the ELA falls to
1763 m; b (``landforms.fit_power_law``) is the median over the glacier's middle reach, fitted
between the walls' tops, and in the trough within the spun-up trunk glacier's margins.

The reference is the converged solver's run of ``tests/glacier/test_u_valley.py``, recorded
here (``CONVERGED_B``, every 250 y = 5 ky-equivalent) rather than run again, so that this test
stays at one run (~9 min on a loaded core against ~5 min for the converged run): the U's
exponent must keep within ``B_TOLERANCE`` = 0.1 of it at every snapshot and at the end.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))

import glacier_u_valley as uv  # noqa: E402

#: Median b of the converged solver's run every 250 y of erosion (5 ky-equivalent), from 0 y.
CONVERGED_B = (1.000, 1.097, 1.160, 1.208, 1.282, 1.363, 1.428, 1.495, 1.544, 1.578)
#: The converged run's median b of the trough at the end.
CONVERGED_B_TROUGH = 1.52
B_TOLERANCE = 0.1


@pytest.fixture(scope="module")
def cnn() -> dict:
    out = uv.experiment(uv.Setup(iceflow="cnn", snapshot_every=250.0))
    print(f"\nCNN: b {[round(s['median_b'], 3) for s in out['series']]}, trough "
          f"{out['median_b_trough_after']:.3f}; taken over in {out['spinup_cnn'][1]} of "
          f"{out['spinup_cnn'][0]} spin-up solves and {out['cnn'][1]} of {out['cnn'][0]} eroding ones; "
          f"{out['seconds']:.0f} s")
    return out


@pytest.mark.slow
def test_the_cnn_glacier_carves_the_converged_solvers_u(cnn):
    """001 §7.1, Fig. 13 with the CNN: b from 1.00 to within 0.1 of the converged run's 1.58
    between the walls' tops and of its 1.52 in the trough, every solve converged, the network
    predicting in every step with ice."""
    assert cnn["diverged"] is None
    assert cnn["unconverged_solves"] == 0
    assert cnn["cnn"][0] > 0 and cnn["cnn"][1] <= cnn["cnn"][0]
    assert cnn["median_b_before"] == pytest.approx(1.0, abs=0.01)
    assert cnn["median_b_after"] == pytest.approx(CONVERGED_B[-1], abs=B_TOLERANCE)
    assert cnn["median_b_trough_after"] == pytest.approx(CONVERGED_B_TROUGH, abs=B_TOLERANCE)


@pytest.mark.slow
def test_the_cnn_u_keeps_to_the_converged_one_every_5_ky(cnn):
    """The median b every 250 y of erosion (5 ky-equivalent) within 0.1 of the converged run's
    at the same time."""
    b = np.array([s["median_b"] for s in cnn["series"]])
    assert len(b) == len(CONVERGED_B)
    np.testing.assert_allclose(b, CONVERGED_B, atol=B_TOLERANCE, rtol=0.0)
