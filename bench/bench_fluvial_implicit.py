"""The implicit forward fluvial step beside fastscapelib's SPLEroder, in ``make bench``.

One step of 1000 years, routing included, on the tilted random surface of ``bench_hydro``
(K 1e-5, m 0.5, n 1): fastscapelib's priority flood + D8 + SPLEroder, and ours with D8 and
MFD, without and with deposition. Wall-time medians on the bench's cores; the single-thread
CPU figures with the explicit scheme beside them come from ``bench/fluvial_implicit.py``.
"""

from __future__ import annotations

from bench_hydro import _FASTSCAPELIB, DX, surface
from harness import benchmark, ratio
from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask, route
from unerode_cli.processes import fluvial, fluvial_implicit

SIZES = (1024, 2048)
DT = 1000.0


def _implicit_case(n: int, method: str, k_d: float):
    z = surface(n)
    grid = Grid.full((n, n), DX)
    outlets = outlet_mask(grid, "all")
    params = fluvial.FluvialParams(k=1e-5, k_d=k_d, m=0.5, n=1.0)

    def work():
        return fluvial_implicit.step(z, grid, outlets, params, DT, routing=route(z, grid, outlets, method))
    return work, n * n, "cells"


def _fastscapelib_case(n: int):
    import fastscapelib as fs

    z = surface(n)
    grid = fs.RasterGrid([n, n], [DX, DX], fs.NodeStatus.FIXED_VALUE)
    graph = fs.FlowGraph(grid, [fs.PFloodSinkResolver(), fs.SingleFlowRouter()])
    eroder = fs.SPLEroder(graph, 1e-5, 0.5, 1.0, 1e-5)

    def work(keep_alive=grid):  # the flow graph does not own its grid
        filled = graph.update_routes(z)
        return eroder.erode(filled, graph.accumulate(1.0), DT)
    return work, n * n, "cells"


for _n in SIZES:
    for _method in ("d8", "mfd"):
        for _k_d in (0.0, 1.0):
            benchmark(f"fluvial/implicit {_method} K_d={_k_d:g} 1000 y {_n}²")(
                lambda n=_n, m=_method, k=_k_d: _implicit_case(n, m, k))
    if _FASTSCAPELIB:
        theirs = f"fluvial/fastscapelib pflood+d8+SPLEroder 1000 y {_n}²"
        benchmark(theirs)(lambda n=_n: _fastscapelib_case(n))
        ratio(f"implicit d8 K_d=0 / fastscapelib SPLEroder, {_n}²", f"fluvial/implicit d8 K_d=0 1000 y {_n}²",
              theirs)
