"""Cell statistics of member rasters and the ranking of scores."""

from __future__ import annotations

import math

import numpy as np
import pytest

from unerode_cli.ensemble.summary import STATISTICS, cell_statistics, ranks


def test_statistics_equal_numpy_on_the_stack() -> None:
    rng = np.random.default_rng(5)
    stack = rng.normal(100.0, 20.0, (9, 6, 7))
    stats = cell_statistics(stack)
    assert tuple(stats) == STATISTICS
    np.testing.assert_allclose(stats["mean"], stack.mean(axis=0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(stats["std"], stack.std(axis=0), rtol=0, atol=1e-12)
    for name, q in (("p5", 5), ("p50", 50), ("p95", 95)):
        np.testing.assert_allclose(stats[name], np.percentile(stack, q, axis=0), rtol=0, atol=1e-12)
    assert (stats["p5"] <= stats["p50"]).all() and (stats["p50"] <= stats["p95"]).all()


def test_a_cell_missing_in_one_member_is_missing_in_every_statistic() -> None:
    stack = np.ones((3, 2, 2))
    stack[1, 0, 1] = np.nan
    stats = cell_statistics(stack)
    for raster in stats.values():
        assert np.isnan(raster[0, 1]) and np.isfinite(np.delete(raster.ravel(), 1)).all()
    assert stats["std"][0, 0] == 0.0 and stats["mean"][1, 1] == 1.0


def test_two_members_percentiles_interpolate_linearly() -> None:
    stats = cell_statistics(np.array([[[0.0]], [[10.0]]]))
    assert (stats["p5"][0, 0], stats["p50"][0, 0], stats["p95"][0, 0]) == pytest.approx((0.5, 5.0, 9.5))
    assert stats["std"][0, 0] == pytest.approx(5.0)


def test_ranks_put_the_lowest_score_first_and_skip_missing_ones() -> None:
    assert ranks([3.0, None, 1.0, math.nan, 2.0, 1.0]) == [4, None, 1, None, 3, 2]
