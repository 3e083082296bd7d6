"""Benchmark registry and timing: median of ≥ 3 timed runs after one warm-up run."""

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
#: throughput: ``(work, amount, unit)``, e.g. ``(fn, 4096 * 4096, "cells")``.
Case = Callable[[], tuple[Callable[[], Any], float, str]]

REGISTRY: dict[str, Case] = {}


def benchmark(name: str) -> Callable[[Case], Case]:
    """Register a benchmark case under ``name`` (group/what/size)."""

    def register(case: Case) -> Case:
        REGISTRY[name] = case
        return case

    return register


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
    """Warm up once, then time ``repeats`` (≥ 3) runs and keep the median."""
    work, amount, unit = case()
    work()
    runs = []
    for _ in range(max(3, repeats)):
        start = time.perf_counter()
        work()
        runs.append(time.perf_counter() - start)
    return Result(name, statistics.median(runs), runs, amount, unit)


def write_reports(results: list[Result], folder: Path) -> tuple[Path, Path]:
    """Write ``results.json`` and ``results.md`` (a markdown table) into ``folder``."""
    machine = {"python": platform.python_version(), "machine": platform.machine(),
               "processor": platform.processor(), "node_cpus": _cpus()}
    json_path, md_path = folder / "results.json", folder / "results.md"
    json_path.write_text(json.dumps({"machine": machine,
                                     "results": [asdict(r) for r in results]}, indent=2) + "\n")
    lines = ["| benchmark | median | throughput |", "|---|---:|---:|"]
    for r in sorted(results, key=lambda r: r.name):
        lines.append(f"| {r.name} | {_time(r.median_s)} | {_rate(r.throughput, r.unit)} |")
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
