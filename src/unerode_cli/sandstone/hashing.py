"""Counter-based random numbers of the sandstone simulator: a uniform draw is a hash of
(seed, frame, index, draw), so it does not depend on the order in which cells or particles are
visited, nor on the number of threads.

The hash is splitmix64's finaliser (Steele, Lea & Flood 2014) applied to each key in turn.
Each kind of random choice has its own ``draw`` key below, so that two choices about the same
cell or particle in the same frame are independent.
"""

from __future__ import annotations

import numba
import numpy as np

# splitmix64: the increment and the finaliser's constants
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_TWO_M53 = 1.0 / 9007199254740992.0

#: What each random draw is for (the last key of the hash).
#: Deposition (``deposition``): the grid's offset along x and y, the receiver of an unstable
#: site, the side a particle leaves a wall by, its position in its cell along x and y.
DRAW_OFFSET_X, DRAW_OFFSET_Y, DRAW_RECEIVER, DRAW_WALL, DRAW_X, DRAW_Y = 0, 1, 2, 3, 4, 5
#: Water (``water_receivers``): the empty side neighbour a cell drains into, the lower
#: surface neighbour a surface cell drains into.
DRAW_WATER_SIDE, DRAW_WATER_SURFACE = 6, 7


@numba.njit(cache=True, inline="always")
def mix64(z):
    """The splitmix64 finaliser: a bijective 64-bit hash."""
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


@numba.njit(cache=True)
def uniform(seed, frame, index, draw):
    """A uniform number in [0, 1) keyed by (seed, frame, index, draw), all integers ≥ 0."""
    z = mix64(np.uint64(seed) + _GOLDEN)
    z = mix64(z ^ (np.uint64(frame) * _GOLDEN + _M1))
    z = mix64(z ^ (np.uint64(index) * _GOLDEN + _M2))
    z = mix64(z ^ (np.uint64(draw) * _GOLDEN))
    return float(z >> np.uint64(11)) * _TWO_M53
