"""Following an ensemble: members done/running/failed with the time left on each member's line,
a line when a worker leaves or joins, and warnings when the cluster is not expected to be (or
was not) faster than running the members one after the other."""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest
from tests.conftest import run_cli
from tests.ensemble.case import needs_data, write_case

from unerode_cli.ensemble.engine import Cluster
from unerode_cli.ensemble.progress import (
    Tally,
    duration,
    short_members_warning,
    slow_cluster_warning,
)


def test_the_counts_and_the_time_left() -> None:
    tally = Tally(8, started_s=100.0)
    assert tally.line(running=2, now=101.0) == "0 done, 2 running, 0 failed of 8"
    tally.heard(True, 10.0)
    tally.heard(False, 2.0)
    # 2 ended in 30 s: 15 s each, 6 left → 90 s
    assert tally.eta_s(now=130.0) == pytest.approx(90.0)
    assert tally.line(running=2, now=130.0) == "1 done, 2 running, 1 failed of 8; about 1 min 30 s left"
    assert tally.line(running=9, now=130.0).startswith("1 done, 6 running")    # at most those left
    for _ in range(6):
        tally.heard(True, 4.0)
    assert tally.line(running=0, now=160.0) == "7 done, 0 running, 1 failed of 8"
    assert tally.speedup(now=160.0) == pytest.approx(36.0 / 60.0)


@pytest.mark.parametrize(("seconds", "text"), [(0.4, "0 s"), (59, "59 s"), (200, "3 min 20 s"),
                                               (7500, "2 h 05 min")])
def test_durations(seconds: float, text: str) -> None:
    assert duration(seconds) == text


def test_a_local_cluster_on_busy_cores_is_said_to_be_no_faster() -> None:
    text = slow_cluster_warning(local=True, cores=2, workers=2, load=2.3)
    assert text is not None and "load 2.3 on 2 core(s)" in text and "--workers 1" in text
    assert slow_cluster_warning(local=True, cores=2, workers=2, load=0.9) is None   # idle: 2 workers win
    assert slow_cluster_warning(local=True, cores=2, workers=1, load=2.3) is None
    assert slow_cluster_warning(local=True, cores=16, workers=4, load=4.0) is None
    assert slow_cluster_warning(local=False, cores=2, workers=2, load=2.3) is None


def test_members_shorter_than_the_cluster_start_are_said() -> None:
    tally = Tally(2)
    tally.heard(True, 1.0)
    tally.heard(True, 2.0)
    text = short_members_warning(tally, start_s=4.0, workers=2)
    assert text is not None and "1.5 s each" in text and "4.0 s" in text
    assert short_members_warning(tally, start_s=1.0, workers=2) is None
    assert short_members_warning(tally, start_s=4.0, workers=1) is None


class _Scheduler:
    """A client whose scheduler knows the workers of ``rounds``, one round per call."""

    def __init__(self, rounds: list[set[str]]) -> None:
        self.rounds = rounds

    def scheduler_info(self) -> dict[str, dict[str, dict]]:
        workers = self.rounds.pop(0) if len(self.rounds) > 1 else self.rounds[0]
        return {"workers": {address: {} for address in workers}}

    def processing(self) -> dict[str, list[str]]:
        return {"tcp://a": ["task-1"], "tcp://b": ["task-2", "task-3"]}


def test_a_lost_and_a_joined_worker_are_said() -> None:
    client = _Scheduler([{"tcp://a", "tcp://b"}, {"tcp://a"}, {"tcp://a", "tcp://c"}])
    cluster = Cluster(client, threads=1, retries=1)
    notes: list[str] = []
    with cluster.watched(notes.append, every_s=0.01):
        deadline = time.monotonic() + 5
        while len(notes) < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
    assert notes[0] == "worker tcp://b lost; its member runs again elsewhere (1 worker(s) left)"
    assert notes[1] == "worker tcp://c joined (2 worker(s))"
    assert cluster.running() == 3


@pytest.mark.slow
@pytest.mark.skipif(not needs_data, reason="needs the shared LR04 and sea-level tables")
def test_each_member_line_carries_the_counts(tmp_path: Path) -> None:
    spec = write_case(tmp_path, "  past.dt: [5000, 3000]\n")          # 3000 fails: not a divisor of 20 ka
    result = run_cli("ensemble", spec, tmp_path / "out", "--workers", "1")
    assert result.returncode == 1, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.startswith("member ")]
    assert len(lines) == 2
    counts = [re.search(r"\((\d) done, (\d) running, (\d) failed of 2", line).groups() for line in lines]
    done, running, failed = zip(*(map(int, c) for c in counts), strict=True)
    assert [d + f for d, f in zip(done, failed, strict=True)] == [1, 2]   # one more ended on each line
    assert (done[-1], failed[-1], running[-1]) == (1, 1, 0)
    assert "left)" in lines[0] and "left" not in lines[1]
