"""Flow routing and fluvial step benchmarks, with fastscapelib side by side when installed.

Surfaces are a tilted random field (all edges drain), the same for every library. Routing
cases time what a fluvial step needs: depression handling + receivers + order + accumulation.
"""

from __future__ import annotations

import numpy as np

from harness import benchmark
from unerode_cli.grid import Grid
from unerode_cli.hydro import accumulate, outlet_mask, route
from unerode_cli.processes import fluvial

SIZES = (256, 512, 1024, 2048)
DX = 30.0


def surface(n: int) -> np.ndarray:
    rng = np.random.default_rng(n)
    rows = np.arange(n)[:, None]
    return 1000.0 - 0.1 * rows * DX / 30.0 + 5.0 * rng.random((n, n))


def _setup(n: int) -> tuple[np.ndarray, Grid, np.ndarray]:
    grid = Grid.full((n, n), DX)
    return surface(n), grid, outlet_mask(grid, "all")


def _routing_case(n: int, method: str):
    z, grid, outlets = _setup(n)

    def work():
        accumulate(route(z, grid, outlets, method), 1.0)
    return work, n * n, "cells"


def _fluvial_case(n: int, dt: float):
    z, grid, outlets = _setup(n)
    params = fluvial.FluvialParams(k=1e-5, k_d=1.0)
    return (lambda: fluvial.step(z, grid, outlets, params, dt)), n * n, "cells"


def _fastscapelib_case(n: int, method: str, resolve_sinks: bool = True):
    import fastscapelib as fs

    z = surface(n)
    grid = fs.RasterGrid([n, n], [DX, DX], fs.NodeStatus.FIXED_VALUE)
    router = fs.SingleFlowRouter() if method == "d8" else fs.MultiFlowRouter(1.0)
    operators = [fs.PFloodSinkResolver(), router] if resolve_sinks else [router]
    graph = fs.FlowGraph(grid, operators)

    def work(keep_alive=grid):  # the flow graph does not own its grid
        graph.update_routes(z)
        graph.accumulate(1.0)
    return work, n * n, "cells"


def _priority_flood_case(n: int):
    from unerode_cli.hydro import kernels

    z, grid, outlets = _setup(n)
    return (lambda: kernels.priority_flood_epsilon(z, grid.valid, outlets)), n * n, "cells"


def _have_fastscapelib() -> bool:
    try:
        import fastscapelib  # noqa: F401
    except ImportError:
        print("note: fastscapelib is not installed; comparison cases skipped "
              "(pip install fastscapelib)")
        return False
    return True


_FASTSCAPELIB = _have_fastscapelib()
for _n in SIZES:
    for _method in ("mfd", "d8"):
        benchmark(f"routing/{_method} route+accumulate {_n}²")(
            lambda n=_n, m=_method: _routing_case(n, m))
        if _FASTSCAPELIB:
            benchmark(f"routing/fastscapelib {_method} pflood+route+accumulate {_n}²")(
                lambda n=_n, m=_method: _fastscapelib_case(n, m))
    if _FASTSCAPELIB:  # priority-flood cost = this case subtracted from the d8 one above
        benchmark(f"routing/fastscapelib d8 route+accumulate, no pflood {_n}²")(
            lambda n=_n: _fastscapelib_case(n, "d8", resolve_sinks=False))
    benchmark(f"routing/priority-flood+eps {_n}²")(lambda n=_n: _priority_flood_case(n))
    benchmark(f"fluvial/forward step {_n}²")(lambda n=_n: _fluvial_case(n, 100.0))
    benchmark(f"fluvial/backward step (limiter) {_n}²")(lambda n=_n: _fluvial_case(n, -100.0))
