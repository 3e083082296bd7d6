"""The dask engine: results come back, a task's error does not stop the others, a worker that
dies has its task moved to another worker, and the cluster is sized to the cores."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from unerode_cli.ensemble.engine import Engine, run_tasks


def _task(job: tuple[str, Path]) -> tuple[int, int]:
    """``square`` returns (pid, numba threads); ``die-once`` kills its worker the first time;
    ``raise`` raises every time."""
    kind, marker = job
    if kind == "die-once" and not marker.exists():
        marker.write_text("died")
        os._exit(1)
    if kind == "raise":
        marker.write_text(marker.read_text() + "x" if marker.exists() else "x")
        raise ValueError("refused")
    import numba

    return os.getpid(), numba.get_num_threads()


def test_results_errors_and_a_dying_worker(tmp_path: Path) -> None:
    jobs = [("square", tmp_path / "a"), ("die-once", tmp_path / "b"), ("raise", tmp_path / "c"),
            ("square", tmp_path / "d")]
    heard: dict[int, tuple[object, BaseException | None]] = {}
    notes: list[str] = []
    run_tasks(jobs, _task, Engine(workers=2, retries=1), lambda i, r, e: heard.setdefault(i, (r, e)),
              notes.append)
    assert sorted(heard) == [0, 1, 2, 3]
    assert heard[1][1] is None and (tmp_path / "b").read_text() == "died"   # moved, then done
    assert isinstance(heard[2][1], ValueError)
    assert (tmp_path / "c").read_text() == "xx"                             # run once + 1 retry
    for i in (0, 1, 3):
        pid, threads = heard[i][0]
        assert pid != os.getpid() and threads == 1       # 2 workers × 1 thread on 2 cores
    assert "2 worker(s) × 1 numba thread(s)" in notes[0]


@pytest.mark.parametrize(("engine", "tasks", "cores", "sizes"), [
    (Engine(), 8, 2, (2, 1)),
    (Engine(), 1, 8, (1, 8)),
    (Engine(workers=2), 8, 8, (2, 4)),
    (Engine(workers=2, threads=8), 8, 8, (2, 4)),     # capped: workers × threads ≤ cores
    (Engine(workers=3, threads=1), 8, 2, (3, 1)),
])
def test_local_cluster_sizes(engine: Engine, tasks: int, cores: int, sizes: tuple[int, int]) -> None:
    assert engine.sizes(tasks, cores) == sizes
