"""Run independent tasks on dask.distributed: a ``LocalCluster`` sized to the machine, or the
cluster of an existing scheduler (``tcp://HOST:PORT``).

The engine knows nothing of what a task does: ``run_tasks`` takes the function that runs one
(it must be importable by the workers, i.e. a module-level function or a ``functools.partial``
of one) and hands each result or error back as it comes. A task that raises is retried
``retries`` times; a worker that dies has its task moved to another worker, up to ``retries``
times on a local cluster (dask's ``allowed-failures``; a remote scheduler keeps its own).

**One task at a time per process.** Every worker process runs its tasks one after the other
(a process-wide lock), whatever its number of threads: a task may change the process's working
folder and standard streams. Each task runs with ``numba_threads`` numba threads, chosen so
that workers × threads ≤ the machine's cores on a local cluster.

**Nothing left behind.** A local cluster keeps its scratch space (dask's
``dask-scratch-space`` folder, the workers' locks and spilled data) in a temporary folder of its
own, removed when the cluster closes, also after an error or Ctrl-C.
"""

from __future__ import annotations

import contextlib
import logging
import os
import tempfile
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from unerode_cli.ensemble.progress import slow_cluster_warning

Task = TypeVar("Task")

_ONE_AT_A_TIME = threading.Lock()
#: The variables that size the thread pools of numba and of the BLAS/OpenMP libraries of a
#: worker process (set in its environment before it imports them).
THREAD_VARIABLES = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


class SchedulerUnreachable(Exception):
    """The scheduler address did not answer, or no worker joined it, within the timeout; the
    message completes "the scheduler ADDRESS …"."""


@dataclass(frozen=True)
class Engine:
    """Where tasks run: ``scheduler`` None starts a local cluster of ``workers`` processes
    (default: one per core, at most one per task), each task with ``threads`` numba threads
    (default: the cores shared among the workers)."""

    scheduler: str | None = None
    workers: int | None = None
    threads: int | None = None
    retries: int = 1
    timeout_s: float = 10.0

    def sizes(self, tasks: int, cores: int | None = None) -> tuple[int, int]:
        """(worker processes, numba threads per task) of a local cluster for ``tasks`` tasks:
        workers × threads ≤ ``cores`` (the machine's usable cores by default)."""
        cores = cores or available_cores()
        workers = self.workers or max(1, min(cores, tasks))
        threads = max(1, min(self.threads or cores, cores // workers))
        return workers, threads


def available_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


@dataclass
class Cluster:
    """A dask client ready to run tasks, each with ``threads`` numba threads; ``local`` for a
    cluster of this machine, ``start_s`` the seconds it took to start (or to answer)."""

    client: Any
    threads: int
    retries: int
    local: bool = False
    start_s: float = 0.0

    def workers(self) -> set[str]:
        """Addresses of the workers the scheduler knows now."""
        try:
            return set(self.client.scheduler_info().get("workers", {}))
        except Exception:  # noqa: BLE001 - a scheduler going away: no worker known
            return set()

    def running(self) -> int:
        """Tasks the workers are processing now."""
        try:
            return sum(len(keys) for keys in self.client.processing().values())
        except Exception:  # noqa: BLE001 - a scheduler going away: none known to run
            return 0

    @contextlib.contextmanager
    def watched(self, on_note: Callable[[str], None], every_s: float = 1.0) -> Iterator[None]:
        """While the block runs, say a line (``on_note``) when a worker leaves or joins the
        cluster (checked every ``every_s`` seconds, in a thread)."""
        stop = threading.Event()
        known = self.workers()

        def watch() -> None:
            nonlocal known
            while not stop.wait(every_s):
                now = self.workers()
                for address in sorted(known - now):
                    on_note(f"worker {address} lost; its member runs again elsewhere "
                            f"({len(now)} worker(s) left)")
                for address in sorted(now - known):
                    on_note(f"worker {address} joined ({len(now)} worker(s))")
                known = now

        thread = threading.Thread(target=watch, name="unerode-worker-watch", daemon=True)
        thread.start()
        try:
            yield
        finally:
            stop.set()
            thread.join()

    def run(self, tasks: Sequence[Task], run: Callable[[Task], Any],
            on_result: Callable[[int, Any, BaseException | None], None]) -> None:
        """Run ``run(task)`` for every task; ``on_result(i, result, error)`` hears each task
        ``i`` as it finishes (``error`` set, ``result`` None, when it failed after its
        retries). Returns when all are done."""
        from distributed import as_completed

        futures = {self.client.submit(_one_at_a_time, run, self.threads, task, pure=False,
                                      key=f"task-{i:06d}-{os.getpid()}-{id(tasks)}",
                                      retries=self.retries): i
                   for i, task in enumerate(tasks)}
        try:
            for future in as_completed(futures):
                index = futures[future]
                if future.status == "error":
                    on_result(index, None, future.exception())
                else:
                    on_result(index, future.result(), None)
                future.release()
        except BaseException:
            self.client.cancel(list(futures))
            raise


@contextlib.contextmanager
def connect(engine: Engine, tasks: int,
            on_note: Callable[[str], None] = lambda text: None) -> Iterator[Cluster]:
    """The engine's cluster for ``tasks`` tasks: a local cluster started (and closed after), or
    the scheduler's. Raises :class:`SchedulerUnreachable`."""
    import dask
    from distributed import Client, LocalCluster

    started = time.perf_counter()
    if engine.scheduler is not None:
        try:
            client = Client(engine.scheduler, timeout=engine.timeout_s)
        except (OSError, TimeoutError) as exc:
            raise SchedulerUnreachable(f"does not answer within {engine.timeout_s:g} s ({exc})") from None
        with client:
            try:   # a scheduler without workers would hold the tasks for ever
                client.wait_for_workers(1, timeout=engine.timeout_s)
            except TimeoutError:
                raise SchedulerUnreachable(
                    f"has no worker: none joined within {engine.timeout_s:g} s") from None
            workers = client.scheduler_info().get("workers", {})
            on_note(f"scheduler {engine.scheduler}: {len(workers)} worker(s); "
                    f"dashboard {client.dashboard_link}")
            yield Cluster(client, engine.threads or 1, engine.retries, False, time.perf_counter() - started)
        return
    workers, threads = engine.sizes(tasks)
    slow = slow_cluster_warning(True, available_cores(), workers, os.getloadavg()[0])
    if slow:
        warnings.warn(slow, stacklevel=3)
    with tempfile.TemporaryDirectory(prefix="unerode-dask-", ignore_cleanup_errors=True) as scratch:
        settings = {"distributed.scheduler.allowed-failures": engine.retries, "temporary-directory": scratch}
        with dask.config.set(settings):
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=":0", silence_logs=logging.ERROR,
                                   local_directory=scratch,
                                   env={name: str(threads) for name in THREAD_VARIABLES})
            with cluster, Client(cluster) as client:
                on_note(f"local cluster: {workers} worker(s) × {threads} numba thread(s); "
                        f"dashboard {client.dashboard_link}")
                yield Cluster(client, threads, engine.retries, True, time.perf_counter() - started)


def run_tasks(tasks: Sequence[Task], run: Callable[[Task], Any], engine: Engine,
              on_result: Callable[[int, Any, BaseException | None], None],
              on_note: Callable[[str], None] = lambda text: None) -> None:
    """Connect, run every task (see :meth:`Cluster.run`) and close."""
    if tasks:
        with connect(engine, len(tasks), on_note) as cluster:
            cluster.run(tasks, run, on_result)


def _one_at_a_time(run: Callable[[Task], Any], threads: int, task: Task) -> Any:
    """``run(task)`` in a worker: alone in its process, with ``threads`` numba threads (at
    most the process's pool)."""
    with _ONE_AT_A_TIME:
        import numba

        numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
        return run(task)
