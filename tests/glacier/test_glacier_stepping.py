"""``coupled.Stepping``: one accepted step per ``advance`` (ramp, rejected steps, ``after``), the
steps of ``coupled.run``; a run saved (``RunResult.saved``) through a state checkpoint and
continued ends bit for bit where an uninterrupted one does, rejected steps and all."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from unerode_cli.glacier import blatter, coupled
from unerode_cli.grid import Grid
from unerode_cli.io.checkpoints import read_state_checkpoint, write_state_checkpoint

SIA = coupled.CoupledParams(flow=blatter.FlowParams(sliding_c=1e5), iceflow="sia")


def _cap(shape: tuple[int, int] = (40, 40), dx: float = 200.0) -> tuple[coupled.GlacierState, Grid]:
    """A parabolic ice cap of 300 m on a flat bed at 1000 m."""
    y, x = np.mgrid[0:shape[0], 0:shape[1]]
    r2 = ((x - 19.5) ** 2 + (y - 19.5) ** 2) / 12.0**2
    thickness = np.where(r2 < 1.0, 300.0 * np.sqrt(np.clip(1.0 - r2, 0.0, 1.0)), 0.0)
    return coupled.GlacierState(np.full(shape, 1000.0), thickness), Grid.full(shape, dx)


@pytest.fixture
def spiky(monkeypatch: pytest.MonkeyPatch) -> None:
    """Steps longer than 13 y put a spike of ice in a corner: rejected (``surface_overshoot``)."""
    true_step = coupled.step

    def step(state, grid, params, ela, dt):
        new, report = true_step(state, grid, params, ela, dt)
        if dt > 13.0:
            h = new.thickness.copy()
            h[0, 0] = 5000.0
            new = replace(new, thickness=h)
        return new, report

    monkeypatch.setattr(coupled, "step", step)


def _erode(state: coupled.GlacierState, dt: float) -> coupled.GlacierState:
    """A process of ice-free ground: lowers the bed by 1 mm/y."""
    return replace(state, bed=state.bed - 1e-3 * dt)


def test_a_saved_and_continued_run_ends_as_an_uninterrupted_one(spiky: None, tmp_path: Path) -> None:
    state, grid = _cap()
    times = coupled.step_times(200.0, 50.0)
    straight = coupled.run(state, grid, SIA, 1100.0, times, after=_erode)
    assert straight.retries >= 3

    first = coupled.Stepping(state, grid, SIA, 1100.0, times, _erode)
    for _ in range(3):
        first.advance()
    assert first.result.retries >= 1 and not first.finished
    path = tmp_path / "run.npz"
    write_state_checkpoint(path, "run", 3, first.result.saved())
    _, done, saved = read_state_checkpoint(path)
    assert done == 3
    result = coupled.RunResult.restored(saved)
    again = coupled.Stepping(result.state, grid, SIA, 1100.0, times, _erode, result)
    while not again.finished:
        again.advance()
    assert again.next_end() is None
    for name in ("bed", "thickness"):
        assert np.array_equal(getattr(again.state, name), getattr(straight.state, name)), name
    assert again.state.time == straight.state.time == 200.0
    assert again.result.times == straight.times and again.result.volumes == straight.volumes
    for name in ("steps", "retries", "substeps", "eroded", "cap"):
        assert getattr(again.result, name) == getattr(straight, name), name


def test_advance_takes_one_accepted_step_and_refuses_past_the_end(spiky: None) -> None:
    state, grid = _cap()
    stepping = coupled.Stepping(state, grid, SIA, 1100.0, [50.0])
    report = stepping.advance()
    assert report.dt == 12.5 and stepping.state.time == 12.5  # 50 and 25 y rejected
    assert stepping.result.retries == 2 and stepping.result.steps == 1
    assert stepping.result.cap == 12.5 * coupled.RAMP_FACTOR
    while not stepping.finished:
        stepping.advance()
    assert stepping.state.time == 50.0
    with pytest.raises(ValueError, match="reached its end"):
        stepping.advance()
