"""Blatter–Pattyn energy + analytic gradient (001 Eq. 7): one evaluation on an N = 10 lattice.

A rough ice cap (ice on ~70 % of the columns) on a rough inclined bed, open edges, sliding
σ = 3/2, random velocities; the timed call is ``blatter_kernels.objective`` (expand the
unknowns, energy and gradient, restrict), i.e. one iteration's evaluation of the minimiser.
"""

from __future__ import annotations

import numpy as np

from harness import benchmark
from unerode_cli.glacier import blatter, blatter_kernels
from unerode_cli.glacier.lattice import dof_map, ice_columns_with_halo, layer_elevations

SIZES = (256, 512)
DX = 50.0
N_LAYERS = 10


def _energy_case(n: int):
    rng = np.random.default_rng(n)
    y, x = np.mgrid[0:n, 0:n] / n
    bed = 3000.0 - 1500.0 * x + 50.0 * rng.random((n, n))
    r2 = (x - 0.5) ** 2 + (y - 0.5) ** 2
    h = np.clip(400.0 * (1.0 - r2 / 0.22), 0.0, None)
    zeta = layer_elevations(bed, h, N_LAYERS, 1.0)
    dof, ndof = dof_map(zeta, ice_columns_with_halo(h, False), np.zeros((n, n), dtype=bool))
    c_face = blatter.basal_face_friction(np.full((n, n), 1000.0), h, False)
    params = blatter.FlowParams()
    args = (dof, zeta, c_face, DX, DX, 0.0, params.b, 4.0 / 3.0, 1.5, params.rho * params.gravity,
            params.strain_rate_reg**2, params.sliding_reg**2, False)
    x0 = 20.0 * rng.standard_normal(2 * ndof)
    return (lambda: blatter_kernels.objective(x0, *args)), n * n * N_LAYERS, "cells"


for _n in SIZES:
    benchmark(f"glacier/blatter energy+gradient {_n}²×{N_LAYERS}")(lambda n=_n: _energy_case(n))
