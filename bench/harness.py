"""Benchmark registry and timing: median of ≥ 3 timed runs after one warm-up run; a whole run
that lasts minutes (``benchmark(..., whole_run=True)``) is timed once, without a warm-up (numba's
kernels come from its on-disk cache after any earlier run)."""

from __future__ import annotations

import json
import platform
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

#: A case returns a zero-argument callable to time (set-up done outside it) and a size for
#: throughput: ``(work, amount, unit)``, e.g. ``(fn, 4096 * 4096, "cells")``. A ``work`` that
#: returns ``Timed(seconds)`` times itself: that figure is kept instead of its wall time.
Case = Callable[[], tuple[Callable[[], Any], float, str]]

REGISTRY: dict[str, Case] = {}
#: The names of the cases registered as whole runs (timed once, no warm-up).
WHOLE_RUNS: set[str] = set()

#: Ratios of two benchmarks' medians, reported when both were measured: label → (numerator,
#: denominator), e.g. the per-step cost of a command over that of its kernels.
RATIOS: dict[str, tuple[str, str]] = {}


@dataclass(frozen=True)
class Timed:
    """What a self-timing ``work`` returns: the seconds to record for this run (e.g. the
    difference of two commands timed back to back)."""

    seconds: float


def benchmark(name: str, whole_run: bool = False) -> Callable[[Case], Case]:
    """Register a benchmark case under ``name`` (group/what/size); ``whole_run``: a run of
    minutes, timed once without a warm-up."""

    def register(case: Case) -> Case:
        REGISTRY[name] = case
        if whole_run:
            WHOLE_RUNS.add(name)
        return case

    return register


def ratio(label: str, numerator: str, denominator: str) -> None:
    """Report ``numerator``'s median over ``denominator``'s under ``label``."""
    RATIOS[label] = (numerator, denominator)


@dataclass
class Result:
    name: str
    median_s: float
    runs_s: list[float]
    amount: float
    unit: str
    throughput: float = field(init=False)

    def __post_init__(self) -> None:
        self.throughput = self.amount / self.median_s if self.median_s > 0 else float("inf")


def measure(name: str, case: Case, repeats: int = 5) -> Result:
    """Warm up once, then time ``repeats`` (≥ 3) runs and keep the median; a whole run once."""
    work, amount, unit = case()
    whole = name in WHOLE_RUNS
    if not whole:
        work()
    runs = []
    for _ in range(1 if whole else max(3, repeats)):
        start = time.perf_counter()
        value = work()
        elapsed = time.perf_counter() - start
        runs.append(value.seconds if isinstance(value, Timed) else elapsed)
    return Result(name, statistics.median(runs), runs, amount, unit)


def ratios(results: list[Result]) -> dict[str, float]:
    """The ``RATIOS`` whose two benchmarks are among ``results``."""
    median = {r.name: r.median_s for r in results}
    return {label: median[num] / median[den] for label, (num, den) in RATIOS.items()
            if num in median and den in median and median[den] > 0}


def write_reports(results: list[Result], folder: Path) -> tuple[Path, Path]:
    """Write ``results.json`` and ``results.md`` (a markdown table) into ``folder``."""
    machine = {"python": platform.python_version(), "machine": platform.machine(),
               "processor": platform.processor(), "node_cpus": _cpus()}
    json_path, md_path = folder / "results.json", folder / "results.md"
    found = ratios(results)
    json_path.write_text(json.dumps({"machine": machine,
                                     "results": [asdict(r) for r in results],
                                     "ratios": found}, indent=2) + "\n")
    lines = ["| benchmark | median | throughput |", "|---|---:|---:|"]
    for r in sorted(results, key=lambda r: r.name):
        lines.append(f"| {r.name} | {_time(r.median_s)} | {_rate(r.throughput, r.unit)} |")
    if found:
        lines += ["", "| ratio | value |", "|---|---:|"]
        lines += [f"| {label} | {value:.2f}× |" for label, value in sorted(found.items())]
    md_path.write_text("\n".join(lines) + "\n")
    return json_path, md_path


def load_results(folder: Path) -> list[Result]:
    """The results of ``folder/results.json`` (none when it is missing)."""
    path = folder / "results.json"
    if not path.exists():
        return []
    rows = json.loads(path.read_text())["results"]
    return [Result(r["name"], r["median_s"], r["runs_s"], r["amount"], r["unit"]) for r in rows]


def _cpus() -> int:
    import os

    return os.cpu_count() or 1


def _time(seconds: float) -> str:
    return f"{seconds * 1e3:.1f} ms" if seconds < 10 else f"{seconds:.2f} s"


def _rate(value: float, unit: str) -> str:
    for scale, prefix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if value >= scale:
            return f"{value / scale:.2f} {prefix}{unit}/s"
    return f"{value:.2f} {unit}/s"
