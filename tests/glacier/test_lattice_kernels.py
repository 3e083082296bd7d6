"""The lattice kernels against the vectorised NumPy definitions of 001 §4.2's lattice: the node
elevations ζ and the numbering of the degrees of freedom, bit for bit, on random columns of
ice from none to far above N·dz_min, with frozen beds and halos."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.glacier.lattice import dof_map, ice_columns_with_halo, layer_elevations


def _numpy_elevations(b, h, n_layers, dz_min):
    k = np.arange(n_layers + 1, dtype=np.float64)[:, None, None]
    zeta = b + np.where(h >= n_layers * dz_min, k * (h / n_layers), np.minimum(k * dz_min, h))
    zeta[-1] = b + h
    return zeta


def _numpy_dofs(zeta, active, frozen):
    m = np.count_nonzero(np.diff(zeta, axis=0) > 0, axis=0)
    k = np.arange(zeta.shape[0])[:, None, None]
    free = active[None] & (k <= m[None]) & ~(frozen[None] & (k == 0))
    ids = np.where(free, np.cumsum(free.ravel()).reshape(free.shape) - 1, -1)
    return np.take_along_axis(ids, np.minimum(k, m[None]), axis=0), int(free.sum())


@pytest.mark.parametrize("seed", range(12))
def test_kernels_match_the_numpy_definitions_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    shape = tuple(int(s) for s in rng.integers(1, 25, 2))
    h = np.where(rng.random(shape) < 0.4, 0.0, rng.random(shape) * rng.choice([0.5, 5.0, 50.0, 500.0]))
    b = rng.normal(1000.0, 300.0, shape)
    n_layers, dz_min = int(rng.integers(1, 12)), float(rng.choice([0.3, 1.0, 2.5]))
    zeta = layer_elevations(b, h, n_layers, dz_min)
    assert np.array_equal(zeta, _numpy_elevations(b, h, n_layers, dz_min))
    active = ice_columns_with_halo(h, periodic=bool(seed % 2))
    frozen = rng.random(shape) < 0.2
    dof, count = dof_map(zeta, active, frozen)
    want, want_count = _numpy_dofs(zeta, active, frozen)
    assert count == want_count
    assert np.array_equal(dof, want)
    assert dof.max() == count - 1 or count == 0


def test_elevations_refuse_beds_and_thicknesses_of_different_shapes():
    with pytest.raises(ValueError, match="one shape"):
        layer_elevations(np.zeros((3, 4)), np.ones((4, 3)), 5, 1.0)
