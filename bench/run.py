"""Run the registered benchmarks: ``python bench/run.py [-k SUBSTRING ...] [--repeats N]``.

Writes bench/results.json and bench/results.md (markdown table, then the ratios of
``harness.RATIOS``). With ``-k`` (repeatable: a benchmark runs when its name contains any of
them), the earlier results of the benchmarks that were not run are kept."""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from harness import REGISTRY, load_results, measure, write_reports  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("-k", action="append", default=[],
                        help="run only benchmarks whose name contains this (repeatable: any of them)")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per case (≥ 3)")
    args = parser.parse_args()
    for module in sorted(HERE.glob("bench_*.py")):
        importlib.import_module(module.stem)
    results = []
    for name, case in REGISTRY.items():
        if not args.k or any(k in name for k in args.k):
            result = measure(name, case, args.repeats)
            print(f"{name:45s} {result.median_s * 1e3:10.1f} ms", flush=True)
            results.append(result)
    if args.k:
        fresh = {r.name for r in results}
        results += [r for r in load_results(HERE) if r.name not in fresh]
    json_path, md_path = write_reports(results, HERE)
    print(md_path.read_text())
    print(f"wrote {json_path} and {md_path}")


if __name__ == "__main__":
    main()
