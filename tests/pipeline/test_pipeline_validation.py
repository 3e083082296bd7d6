"""`pipeline run` checks every step's option values with the subcommands' own parsers before the
first step runs, refuses a key given twice, and logs the command lines its dry run shows."""

from __future__ import annotations

from pathlib import Path

import pytest
from tests.conftest import run_cli

SPEC = """\
version: 1
steps:
  - {name: terrain, run: synth, args: [terrain.tif], options: {size: 16, seed: 3}}
  - name: eroded
    run: erode
    args: ["${steps.terrain.output}", eroded.tif]
    options: {OPTIONS}
"""


def write_spec(folder: Path, options: str = "{dt: 1000, steps: 1}", text: str = SPEC) -> Path:
    spec = folder / "spec.yaml"
    spec.write_text(text.replace("{OPTIONS}", options))
    return spec


@pytest.mark.parametrize(("options", "mentions"), [
    ("{dt: -5, steps: 1}", "step 'eroded' (options.dt): must be > 0 years, got -5."),
    ("{dt: .nan, steps: 1}", "step 'eroded' (options.dt): must be a finite number (years), got 'nan'."),
    ("{dt: 1000, steps: 0}", "step 'eroded' (options.steps): must be ≥ 1, got 0."),
    ("{dt: 1000, steps: 1, K: -1}", "step 'eroded' (options.K): parameter k must be ≥ 0"),
    ("{dt: 1000, steps: 1, n: 9}", "step 'eroded' (options.n): parameter n must be ≤ 4, got 9."),
    ("{dt: 1000, steps: 1, snapshot-every: abc}",
     "step 'eroded' (options.snapshot-every): expected a number"),
])
def test_a_bad_option_value_of_a_later_step_stops_the_run_before_the_first_step(
        tmp_path: Path, options: str, mentions: str) -> None:
    spec = write_spec(tmp_path, options)
    result = run_cli("pipeline", "run", spec)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and mentions in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.yaml"]   # step 1 did not run


def test_a_key_given_twice_in_a_spec_is_refused_with_its_line(tmp_path: Path) -> None:
    spec = write_spec(tmp_path, "{dt: 1000, steps: 1, dt: 500}")
    result = run_cli("pipeline", "run", spec)
    assert result.returncode == 2
    assert result.stderr.strip() == (f"error: pipeline spec {spec} gives the key 'dt' twice (line 7); "
                                     "keep one.")


@pytest.mark.parametrize("verbosity", [0, 1, 2])
def test_the_run_log_shows_the_command_lines_of_the_dry_run(tmp_path: Path, verbosity: int) -> None:
    spec = write_spec(tmp_path, text=SPEC.split("  - name: eroded")[0])
    flags = ["-v"] * verbosity
    dry = run_cli("pipeline", "run", spec, "--dry-run", *flags)
    assert dry.returncode == 0, dry.stderr
    shown = [line.split(": ", 1)[1] for line in dry.stdout.splitlines()]
    result = run_cli("pipeline", "run", spec, *flags)
    assert result.returncode == 0, result.stderr
    logged = [line.split(": ", 1)[1] for line in result.stderr.splitlines()
              if line.startswith("[") and ": unerode-cli " in line]
    assert logged == shown == [" ".join(["unerode-cli synth terrain.tif --size 16 --seed 3", *flags])]


def test_a_missing_workdir_is_created_by_the_run_not_by_a_dry_run(tmp_path: Path) -> None:
    spec = tmp_path / "spec.yaml"
    spec.write_text("version: 1\nworkdir: runs/new\nsteps:\n"
                    "  - {name: terrain, run: synth, args: [terrain.tif], options: {size: 16}}\n")
    dry = run_cli("pipeline", "run", spec, "--dry-run")
    assert dry.returncode == 0, dry.stderr
    assert not (tmp_path / "runs").exists()
    result = run_cli("pipeline", "run", spec)
    assert result.returncode == 0, result.stderr
    assert "created the workdir" in result.stderr
    assert (tmp_path / "runs" / "new" / "terrain.tif").is_file()
