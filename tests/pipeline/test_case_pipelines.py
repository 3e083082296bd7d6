"""The example pipelines in pipelines/ stay valid: every step, option and input checks out."""

from __future__ import annotations

from pathlib import Path

import pytest
from tests.conftest import SHARED_DATA, run_cli

PIPELINES = Path(__file__).resolve().parents[2] / "pipelines"


@pytest.mark.skipif(not (SHARED_DATA / "lr04").is_dir(), reason="needs ../shared/data")
def test_last_glacial_cycle_spec_validates() -> None:
    (PIPELINES / "runs" / "last_glacial_cycle").mkdir(parents=True, exist_ok=True)
    result = run_cli("pipeline", "run", PIPELINES / "last_glacial_cycle.yaml", "--dry-run")
    assert result.returncode == 0, result.stderr
    lines = [line for line in result.stdout.splitlines() if line.strip()]
    assert [line.split(":")[0].split()[-1] for line in lines] == ["past", "lgm-preview",
                                                                  "lgm-rivers"]
    assert "--to 120" in lines[0] and "--snapshots 12,20,60,120" in lines[0]
