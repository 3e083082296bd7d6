"""Thermal erosion (000 §4) and the thermal cellular automaton: one step at 512² and 2048².

The thermal step includes its flow routing (priority-flood + MFD order), as in a run.
"""

from __future__ import annotations

from harness import benchmark
from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask
from unerode_cli.processes import thermal, thermal_ca
from unerode_cli.synthetic import synthesize

SIZES = (512, 2048)
DX = 10.0


def _setup(n: int):
    grid = Grid.full((n, n), DX)
    return synthesize("mountain", (n, n), 0.3 * DX * n, 1), grid, outlet_mask(grid, "all")


def _thermal_case(n: int, dt: float):
    h, grid, outlets = _setup(n)
    params = thermal.ThermalParams(k_th=0.004)
    return (lambda: thermal.step(h, grid, outlets, params, dt)), n * n, "cells"


def _automaton_case(n: int):
    h, grid, outlets = _setup(n)
    params = thermal_ca.ThermalCAParams(k_th=0.004)
    dt = thermal_ca.max_stable_dt(grid, params)
    return (lambda: thermal_ca.step(h, grid, outlets, params, dt)), n * n, "cells"


for _n in SIZES:
    benchmark(f"thermal/forward step {_n}²")(lambda n=_n: _thermal_case(n, 500.0))
    benchmark(f"thermal/backward step (constraints on) {_n}²")(lambda n=_n: _thermal_case(n, -500.0))
    benchmark(f"thermal/cellular automaton step {_n}²")(lambda n=_n: _automaton_case(n))
