"""Numba kernels of the L-BFGS minimisation of the Blatter–Pattyn energy (001 Eq. 7).

Vector passes over the unknowns x = [u_dof, v_dof] (m/y) and gradients (Pa·m³/y per m/y):
dot products, the fused update-and-dot of the two-loop recursion and the pair (s, y) of a step,
each summed in blocks of ``BLOCK`` entries whose partial sums are added in order, so that the
bits are the same on one thread or many (threads from ``PARALLEL_MIN_UNKNOWNS`` unknowns); and
``lbfgs_direction``, the two-loop recursion (Nocedal & Wright, Algorithm 7.4) preconditioned by
the column solves of ``blatter_preconditioner``.
"""

from __future__ import annotations

import numba
import numpy as np

from unerode_cli.glacier.blatter_preconditioner import PARALLEL_MIN_UNKNOWNS, column_solve_factored

#: Entries per block of the passes over vectors (``dot``, ``_add_scaled_dot``, ``new_pair``): each
#: block's partial sum is taken alone and the blocks are added in their order, on one thread or
#: many, so the bits do not depend on the thread count.
BLOCK = 16_384


@numba.njit(cache=True, inline="always")
def _block_dot(a, b, lo, hi):
    """aᵀb over [lo, hi) in four interleaved partial sums (independent, so the loop runs at the
    memory's speed, not the adder's)."""
    s0 = s1 = s2 = s3 = 0.0
    end = hi - (hi - lo) % 4
    for i in range(lo, end, 4):
        s0 += a[i] * b[i]
        s1 += a[i + 1] * b[i + 1]
        s2 += a[i + 2] * b[i + 2]
        s3 += a[i + 3] * b[i + 3]
    for i in range(end, hi):
        s0 += a[i] * b[i]
    return (s0 + s1) + (s2 + s3)


@numba.njit(cache=True, inline="always")
def _block_add_scaled_dot(y, alpha, x, w, lo, hi):
    """y += α·x over [lo, hi), then wᵀy there (``_block_dot``'s order), in one pass."""
    s0 = s1 = s2 = s3 = 0.0
    end = hi - (hi - lo) % 4
    for i in range(lo, end, 4):
        y[i] += alpha * x[i]
        y[i + 1] += alpha * x[i + 1]
        y[i + 2] += alpha * x[i + 2]
        y[i + 3] += alpha * x[i + 3]
        s0 += w[i] * y[i]
        s1 += w[i + 1] * y[i + 1]
        s2 += w[i + 2] * y[i + 2]
        s3 += w[i + 3] * y[i + 3]
    for i in range(end, hi):
        y[i] += alpha * x[i]
        s0 += w[i] * y[i]
    return (s0 + s1) + (s2 + s3)


@numba.njit(cache=True, inline="always")
def _block_pair(x_new, x, g_new, g, s, y, lo, hi):
    """s = x_new − x and y = g_new − g over [lo, hi), then sᵀy there (``_block_dot``'s order)."""
    for i in range(lo, hi):
        s[i] = x_new[i] - x[i]
        y[i] = g_new[i] - g[i]
    return _block_dot(s, y, lo, hi)


@numba.njit(cache=True, inline="always")
def _blocks(size):
    return (size + BLOCK - 1) // BLOCK


@numba.njit(cache=True, inline="always")
def _ordered_sum(partial):
    total = 0.0
    for b in range(partial.size):
        total += partial[b]
    return total


@numba.njit(cache=True, parallel=True)
def _dot_threads(a, b):
    partial = np.empty(_blocks(a.size))
    for k in numba.prange(partial.size):
        partial[k] = _block_dot(a, b, k * BLOCK, min((k + 1) * BLOCK, a.size))
    return _ordered_sum(partial)


@numba.njit(cache=True)
def dot(a, b):
    """aᵀb: block partial sums (BLOCK) added in order, on threads from PARALLEL_MIN_UNKNOWNS
    entries, the same bits either way."""
    if a.size >= PARALLEL_MIN_UNKNOWNS:
        return _dot_threads(a, b)
    total = 0.0
    for k in range(_blocks(a.size)):
        total += _block_dot(a, b, k * BLOCK, min((k + 1) * BLOCK, a.size))
    return total


@numba.njit(cache=True, parallel=True)
def _add_scaled_dot_threads(y, alpha, x, w):
    partial = np.empty(_blocks(y.size))
    for k in numba.prange(partial.size):
        partial[k] = _block_add_scaled_dot(y, alpha, x, w, k * BLOCK, min((k + 1) * BLOCK, y.size))
    return _ordered_sum(partial)


@numba.njit(cache=True)
def _add_scaled_dot(y, alpha, x, w):
    """y += α·x in place, and wᵀy of the updated y (``dot``'s order) in the same pass."""
    if y.size >= PARALLEL_MIN_UNKNOWNS:
        return _add_scaled_dot_threads(y, alpha, x, w)
    total = 0.0
    for k in range(_blocks(y.size)):
        total += _block_add_scaled_dot(y, alpha, x, w, k * BLOCK, min((k + 1) * BLOCK, y.size))
    return total


@numba.njit(cache=True, parallel=True)
def _new_pair_threads(x_new, x, g_new, g, s, y):
    partial = np.empty(_blocks(x.size))
    for k in numba.prange(partial.size):
        partial[k] = _block_pair(x_new, x, g_new, g, s, y, k * BLOCK, min((k + 1) * BLOCK, x.size))
    return _ordered_sum(partial)


@numba.njit(cache=True)
def new_pair(x_new, x, g_new, g, s, y):
    """The L-BFGS pair of a step: s = x_new − x and y = g_new − g written in place, and sᵀy
    (``dot``'s order), in one pass."""
    if x.size >= PARALLEL_MIN_UNKNOWNS:
        return _new_pair_threads(x_new, x, g_new, g, s, y)
    total = 0.0
    for k in range(_blocks(x.size)):
        total += _block_pair(x_new, x, g_new, g, s, y, k * BLOCK, min((k + 1) * BLOCK, x.size))
    return total


@numba.njit(cache=True)
def lbfgs_direction(g, s_hist, y_hist, rho, count, newest, inv, ratio, upper, chains, out):
    """The L-BFGS step −H·g by the two-loop recursion (Nocedal & Wright, Algorithm 7.4), with
    the initial inverse Hessian γ·T⁻¹: T the column preconditioner (``picard_columns``,
    factorised by ``column_factor`` into inv, ratio) and γ = sᵀy / yᵀT⁻¹y of the newest pair.

    Args:
        g: float64[2n] gradient.
        s_hist, y_hist: float64[m, 2n] ring buffers of the last ``count`` steps s and gradient
            changes y, the newest in row ``newest``; rho: float64[m], 1 / sᵀy of each row.
        inv, ratio, upper, chains: the factorised preconditioner; out: float64[2n] scratch.
    """
    m = s_hist.shape[0]
    q = g.copy()
    alphas = np.zeros(m)
    curvature = 0.0
    # each pass updates q and takes the next pair's dot product with it (Algorithm 7.4's loops,
    # the dot of one iteration fused with the update of the one before)
    product = dot(s_hist[newest], q) if count > 0 else 0.0
    for back in range(count):
        row = (newest - back) % m
        alphas[row] = rho[row] * product
        following = s_hist[(row - 1) % m] if back + 1 < count else q
        product = _add_scaled_dot(q, -alphas[row], y_hist[row], following)
    if count > 0:
        column_solve_factored(inv, ratio, upper, chains, y_hist[newest], out)
        curvature = rho[newest] * dot(y_hist[newest], out)
    column_solve_factored(inv, ratio, upper, chains, q, out)
    scale = 1.0 / curvature if count > 0 and curvature > 0.0 else 1.0
    first = (newest - count + 1) % m
    for i in range(q.size):
        q[i] = scale * out[i]
    product = dot(y_hist[first], q) if count > 0 else 0.0
    for forward in range(count):
        row = (newest - count + 1 + forward) % m
        following = y_hist[(row + 1) % m] if forward + 1 < count else q
        product = _add_scaled_dot(q, alphas[row] - rho[row] * product, s_hist[row], following)
    for i in range(q.size):
        q[i] = -q[i]
    return q

