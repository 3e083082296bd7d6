"""The sweep sampler: Latin hypercube strata, seeds, distributions and the grid of lists."""

from __future__ import annotations

import math

import numpy as np
import pytest

from unerode_cli.ensemble.sweep import Listed, Sampled, Sweep, latin_hypercube, parse_parameter


@pytest.mark.parametrize(("samples", "dimensions", "seed"), [(1, 3, 0), (7, 2, 1), (64, 5, 42)])
def test_each_stratum_is_hit_exactly_once(samples: int, dimensions: int, seed: int) -> None:
    draws = latin_hypercube(samples, dimensions, seed)
    assert draws.shape == (samples, dimensions)
    assert ((draws >= 0.0) & (draws < 1.0)).all()
    for column in draws.T:
        assert sorted(np.floor(column * samples).astype(int)) == list(range(samples))


def test_the_same_seed_gives_the_same_members_and_another_seed_others() -> None:
    sweep = Sweep((parse_parameter("a", {"uniform": [0.1, 3.0]}),
                   parse_parameter("b", {"log-uniform": [1e-5, 1e-3]}),
                   parse_parameter("c", ["x.txt", "y.txt"])))
    first, again, other = sweep.members(8, seed=3), sweep.members(8, seed=3), sweep.members(8, seed=4)
    assert first == again
    assert first != other
    assert len(first) == 16                               # 8 samples × 2 listed values
    # the two values of the list see the same draws (paired), in the order of the list
    assert [m["a"] for m in first[:8]] == [m["a"] for m in first[8:]]
    assert [m["c"] for m in first] == ["x.txt"] * 8 + ["y.txt"] * 8


def test_distributions_map_the_strata_through_their_quantiles() -> None:
    n = 1000
    members = Sweep((parse_parameter("u", {"uniform": [2.0, 4.0]}),
                     parse_parameter("l", {"log-uniform": [1e-5, 1e-3]}),
                     parse_parameter("g", {"normal": [10.0, 2.0]}),
                     parse_parameter("k", {"choice": ["a", "b", "c", "d"]}))).members(n, seed=0)
    u = np.array([m["u"] for m in members])
    log_l = np.log10([m["l"] for m in members])
    g = np.array([m["g"] for m in members])
    # one sample per stratum: the sorted samples lie in consecutive strata of the range
    assert np.all(np.floor((np.sort(u) - 2.0) / 2.0 * n) == np.arange(n))
    assert np.all(np.floor((np.sort(log_l) + 5.0) / 2.0 * n) == np.arange(n))
    assert np.mean(g) == pytest.approx(10.0, abs=0.01)        # stratified: far below 2/√n
    assert np.std(g) == pytest.approx(2.0, rel=0.02)
    assert np.median(g) == pytest.approx(10.0, abs=0.02)
    counts = {c: sum(m["k"] == c for m in members) for c in "abcd"}
    assert counts == {"a": 250, "b": 250, "c": 250, "d": 250}


def test_lists_only_make_the_full_grid() -> None:
    sweep = Sweep((Listed("K", (1e-5, 2e-5, 4e-5)), Listed("sea", ("a", "b"))))
    members = sweep.members(None, seed=0)
    assert len(members) == 6 == sweep.grid_size()
    assert {(m["K"], m["sea"]) for m in members} == {(k, s) for k in (1e-5, 2e-5, 4e-5) for s in "ab"}


@pytest.mark.parametrize(("raw", "message"), [
    ([], "empty list"),
    ({"uniform": [3.0, 3.0]}, "is empty"),
    ({"uniform": [3.0, 1.0]}, "is empty"),
    ({"log-uniform": [0.0, 1.0]}, "must be positive"),
    ({"normal": [1.0, 0.0]}, "sd > 0"),
    ({"gamma": [1.0, 2.0]}, "unknown distribution"),
    ({"uniform": [1.0]}, "two numbers"),
    ({"choice": []}, "empty list"),
    ("1e-5", "a list of values or one distribution"),
])
def test_malformed_entries_are_refused(raw: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        parse_parameter("K", raw)


def test_samples_are_needed_exactly_when_the_sweep_samples() -> None:
    sampled = Sweep((Sampled("a", "uniform", (0.0, 1.0)),))
    listed = Sweep((Listed("b", (1, 2)),))
    with pytest.raises(ValueError, match="--members"):
        sampled.members(None, 0)
    with pytest.raises(ValueError, match="lists only"):
        listed.members(4, 0)
    with pytest.raises(ValueError, match="at least 1"):
        sampled.members(0, 0)
    assert math.isclose(sampled.members(1, 0)[0]["a"], latin_hypercube(1, 1, 0)[0, 0])
