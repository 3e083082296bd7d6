"""The probe of bad inputs and hostile cases of every subcommand (issue 45), one test per case of
``tests/probe/cases.py``: the exit code the issue demands, one sentence on stderr without a
Python class name, every input byte-identical, and no file written besides those the case
allows. Cases run in process (interrupt cases in their own interpreter); the totals per class
are printed by ``bench/probe_bad_inputs.py``."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.probe.cases import CASES, Case, run_case


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_bad_input(case: Case, tmp_path: Path) -> None:
    outcome = run_case(case, tmp_path / "case")
    if outcome.skipped:
        pytest.skip(outcome.skipped)
    assert not outcome.failures, (
        f"{case.name} ({case.cls}): unerode-cli {' '.join(case.argv)}\n"
        f"failed: {'; '.join(outcome.failures)}\nstderr: {outcome.stderr.strip()}")
