"""Hill-slope diffusion (ADI) and debris-flow (implicit, 001 Eq. 8) step benchmarks.

Hill slope: one Peaceman–Rachford step on a rough surface, all edges fixed. Debris flow: one
step on a steep rough surface (mean slope 0.9, above s_c = tan 37°, plus 30 m of noise), the
D8 routing and drainage area computed inside the step as a plain call does.
"""

from __future__ import annotations

import numpy as np

from harness import benchmark
from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask
from unerode_cli.processes import debris, hillslope

SIZES = (512, 2048)
DX = 30.0


def _surface(n: int, slope: float) -> np.ndarray:
    rng = np.random.default_rng(n)
    rows = np.arange(n)[:, None]
    return 1000.0 + slope * (n - rows) * DX + 30.0 * rng.random((n, n))


def _hillslope_case(n: int):
    grid = Grid.full((n, n), DX)
    z, fixed = _surface(n, 0.1), outlet_mask(grid, "all")
    params = hillslope.HillslopeParams(k_h=0.02, uplift=1e-4)
    return (lambda: hillslope.step(z, grid, fixed, params, 1e4)), n * n, "cells"


def _debris_case(n: int):
    grid = Grid.full((n, n), DX)
    z, fixed = _surface(n, 0.9), outlet_mask(grid, "all")
    params = debris.DebrisParams()
    return (lambda: debris.step(z, grid, fixed, params, 100.0)), n * n, "cells"


for _n in SIZES:
    benchmark(f"hillslope/step {_n}²")(lambda n=_n: _hillslope_case(n))
    benchmark(f"debris/step {_n}²")(lambda n=_n: _debris_case(n))
