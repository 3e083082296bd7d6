"""Fixtures of the sandstone tests: numba's thread count, restored after each test."""

from __future__ import annotations

import numba
import pytest


@pytest.fixture
def threads():
    """Lets a test set numba's thread count (``numba.set_num_threads``); restored after it."""
    before = numba.get_num_threads()
    yield
    numba.set_num_threads(before)


@pytest.fixture
def one_thread(threads):
    """One numba thread: on small grids thread start-up costs more than it saves (the result
    is the same whatever the count)."""
    numba.set_num_threads(1)
