"""001 Fig. 11 (left) with ``--iceflow cnn``: the ice volume of a valley glacier under a cooling
climate for time steps of 5, 10 and 20 y, the CNN against the converged Blatter–Pattyn solver.

The experiment is ``bench/glacier_fig11_cnn.py`` with its defaults (its docstring has the setup):
the V valley of ``bench/glacier_u_valley.py`` on 20 × 64 cells of 100 m, grown for 600 y at ELA
2100 m by the converged solver, then the ELA falling to 1900 m over 600 y and held to 800 y, no
erosion; volumes every 50 y. Each solver runs each dt from that start; the CNN (seed 0, a new
network per run) predicts every step, and the converged solver takes over wherever its refined
residual is above 1e-3.

Measured (busy cores, one thread): the CNN's volumes lie within 0.005 % of the converged
solver's at every sample and every dt (it was taken over in all of its 160, 80 and 48 solves),
so its time-step errors are the converged solver's. Neither meets 001's "below 1%" on this case:
against dt = 5 y the volume of dt = 10 y is 5.8 % low at the end (1.077 against 1.143 km³) and
up to 23 % low on the way, dt = 20 y 23 % low at the end (0.875 km³) and up to 37 % on the way.
The glacier grows 3.6-fold in 800 y (0.31 → 1.14 km³), ELA falling 333 m per ky, where 001's
falls 10 m per ky: the multi-scale step takes in only min(f^i·δt, dt)/dt of the tendency where
the ice is fast (``glacier/multiscale.py``), so the longer step lags a fast-growing glacier.
``test_001s_one_percent_holds_for_10_and_20_year_steps`` states 001's target as a strict xfail.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))

import glacier_fig11_cnn as fig11  # noqa: E402

#: Largest relative difference of the CNN's volume from the converged solver's at the same dt.
SAME_DT_TOLERANCE = 1e-3


@pytest.fixture(scope="module")
def runs() -> dict:
    out = fig11.experiment(fig11.Case())
    return {(r["iceflow"], r["dt"]): r for r in out["runs"]}


@pytest.mark.slow
def test_the_cnn_volumes_are_the_converged_solvers_at_every_time_step(runs):
    """At dt = 5, 10 and 20 y the CNN's ice volume keeps within 0.1 % of the converged solver's
    at every sample (measured: ≤ 0.005 %), every solve converged."""
    for dt in fig11.DTS:
        cnn, converged = runs[("cnn", dt)], runs[("blatter", dt)]
        assert cnn["unconverged"] == 0 and converged["unconverged"] == 0
        assert cnn["cnn_solves"] > 0 and cnn["cnn_takeovers"] <= cnn["cnn_solves"]
        np.testing.assert_allclose(cnn["volumes"], converged["volumes"], rtol=SAME_DT_TOLERANCE)


@pytest.mark.slow
def test_the_cnn_time_step_errors_are_the_converged_solvers(runs):
    """(V_dt − V_5)/V_5 of the CNN within 0.1 percentage points of the converged solver's, at the
    end and at its largest (measured, both: −5.8 % and 23 % at dt = 10 y, −23 % and 37 % at 20 y)."""
    for dt in fig11.DTS[1:]:
        cnn, converged = runs[("cnn", dt)], runs[("blatter", dt)]
        assert cnn["error_end"] == pytest.approx(converged["error_end"], abs=SAME_DT_TOLERANCE)
        assert cnn["error_max"] == pytest.approx(converged["error_max"], abs=SAME_DT_TOLERANCE)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the 10- and 20-year steps lag the growing glacier by 6–37 %, "
                   "the converged solver's as much as the CNN's (module docstring)")
def test_001s_one_percent_holds_for_10_and_20_year_steps(runs):
    """001 Fig. 11: time steps of 10 and 20 y keep the ice volume within 1 % of the 5-year run."""
    for iceflow in ("blatter", "cnn"):
        for dt in fig11.DTS[1:]:
            assert runs[(iceflow, dt)]["error_max"] < 0.01
