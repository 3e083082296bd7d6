"""Run the probe of bad inputs and hostile cases (issue 45; tests/probe/cases.py) and print, per
class of the issue, the cases, passed, failed and skipped, then every failure with its reasons.

    .venv/bin/python bench/probe_bad_inputs.py                      # in process (fast)
    .venv/bin/python bench/probe_bad_inputs.py --subprocess         # each case in its own interpreter
    .venv/bin/python bench/probe_bad_inputs.py --only erode- --keep # some cases; keep their folders
    PYTHONPATH=/other/checkout/src .venv/bin/python bench/probe_bad_inputs.py   # probe other code

The table of cases is loaded from this checkout's tests/probe/cases.py by its file location;
``unerode_cli`` is imported from ``sys.path`` (``PYTHONPATH`` first), so the probe measures the
code that ``PYTHONPATH`` names. Exit code: 0 when every case passed, 1 otherwise.
"""

from __future__ import annotations

import argparse
import fnmatch
import importlib.util
import json
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

CASES_FILE = Path(__file__).resolve().parents[1] / "tests" / "probe" / "cases.py"


def load_cases_module():
    """tests/probe/cases.py as the module ``probe_cases`` (not through the ``tests`` package)."""
    spec = importlib.util.spec_from_file_location("probe_cases", CASES_FILE)
    module = importlib.util.module_from_spec(spec)
    sys.modules["probe_cases"] = module
    spec.loader.exec_module(module)
    return module


def selected(cases, only: list[str], classes: list[str]):
    """The cases whose name contains (or matches, as a glob) one of ``only`` and whose class
    starts with one of ``classes`` (all when empty)."""
    chosen = []
    for case in cases:
        if only and not any(p in case.name or fnmatch.fnmatch(case.name, p) for p in only):
            continue
        if classes and not any(case.cls.startswith(c) for c in classes):
            continue
        chosen.append(case)
    return chosen


def print_table(probe, outcomes) -> None:
    """Per class: cases, passed, failed, skipped; then the failures with their reasons."""
    width = max(len(c) for c in probe.CLASSES) + 2
    print(f"\n{'class':<{width}}{'cases':>6}{'passed':>8}{'failed':>8}{'skipped':>9}")
    totals = Counter()
    for cls in probe.CLASSES:
        mine = [o for o in outcomes if o.case.cls == cls]
        if not mine:
            continue
        row = Counter(cases=len(mine), passed=sum(o.passed for o in mine),
                      failed=sum(bool(o.failures) for o in mine), skipped=sum(bool(o.skipped) for o in mine))
        totals.update(row)
        print(f"{cls:<{width}}{row['cases']:>6}{row['passed']:>8}{row['failed']:>8}{row['skipped']:>9}")
    print(f"{'total':<{width}}{totals['cases']:>6}{totals['passed']:>8}{totals['failed']:>8}{totals['skipped']:>9}")
    failed = [o for o in outcomes if o.failures]
    if failed:
        print(f"\nfailures ({len(failed)}):")
        for o in failed:
            said = o.stderr.strip().splitlines()
            last = said[-1][:160] if said else ""
            print(f"  {o.case.name} [{o.case.cls[0]}] exit {o.exit_code}: {'; '.join(o.failures)}")
            if last:
                print(f"      stderr: {last}")
    skipped = [o for o in outcomes if o.skipped]
    for o in skipped:
        print(f"  skipped {o.case.name}: {o.skipped}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subprocess", action="store_true", help="run each case in its own interpreter")
    parser.add_argument("--only", action="append", default=[], help="case names containing this (or a glob)")
    parser.add_argument("--class", dest="classes", action="append", default=[],
                        help="classes starting with this (e.g. 1, 8)")
    parser.add_argument("--keep", action="store_true", help="keep the case folders (printed)")
    parser.add_argument("--json", type=Path, help="also write the outcomes to this JSON file")
    args = parser.parse_args(argv)

    probe = load_cases_module()
    import unerode_cli

    cases = selected(probe.CASES, args.only, args.classes)
    print(f"probing {Path(unerode_cli.__file__).resolve().parent} with {len(cases)} case(s), "
          f"{'each in its own interpreter' if args.subprocess else 'in process'}", flush=True)
    root = Path(tempfile.mkdtemp(prefix="probe45."))
    outcomes = []
    start = time.perf_counter()
    for case in cases:
        outcome = probe.run_case(case, root / case.name, isolated=args.subprocess)
        outcomes.append(outcome)
        status = "skip" if outcome.skipped else ("ok" if outcome.passed else "FAIL")
        print(f"{status:>4} {outcome.seconds:6.1f} s  {case.name}", flush=True)
    elapsed = time.perf_counter() - start
    print_table(probe, outcomes)
    print(f"\n{len(cases)} case(s) in {elapsed:.0f} s")
    if args.keep:
        print(f"case folders kept in {root}")
    else:
        import shutil

        shutil.rmtree(root, ignore_errors=True)
    if args.json:
        args.json.write_text(json.dumps([
            {"name": o.case.name, "class": o.case.cls, "subcommand": o.case.subcommand, "exit": o.exit_code,
             "expected": list(o.case.exits), "passed": o.passed, "failures": o.failures, "skipped": o.skipped,
             "stderr": o.stderr, "seconds": round(o.seconds, 2)} for o in outcomes], indent=1) + "\n")
    return 0 if all(o.passed or o.skipped for o in outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
