"""Pipeline specs: resolution into command lines, and refusal of malformed specs (exit 2)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from tests.conftest import run_cli

from unerode_cli.errors import InputError
from unerode_cli.pipeline.commands import schemas as command_schemas
from unerode_cli.pipeline.spec import load_spec, parse_var_overrides, resolve

GOOD = """\
version: 1
vars: {size: 32, dt: 1000, name: run}
steps:
  - {name: terrain, run: synth, args: [terrain.tif], options: {size: "${size}", seed: 3}}
  - name: eroded
    run: erode
    args: ["${steps.terrain.output}", "${name}_eroded.tif"]
    options: {dt: "${dt}", steps: 2, no_substep: true, cog: false, co: [ZLEVEL=9, NUM_THREADS=1],
              K-d: 0.5, preview: eroded.png, verbose: 1}
    outputs: [notes.txt]
  - name: picture
    run: preview
    args: ["${steps.eroded.output}", picture.png]
    options: {title: "$${literal} ${size} cells"}
"""


@pytest.fixture(scope="module")
def schemas():
    return command_schemas()


def write_spec(folder: Path, text: str, name: str = "spec.yaml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


def test_a_spec_resolves_to_command_lines(tmp_path: Path, schemas) -> None:
    spec = write_spec(tmp_path, GOOD)
    pipeline = resolve(load_spec(spec), spec, schemas)
    assert pipeline.workdir == tmp_path.resolve()
    assert pipeline.state_path == tmp_path.resolve() / ".spec.state.json"
    terrain, eroded, picture = pipeline.steps
    assert terrain.argv == ["synth", "terrain.tif", "--size", "32", "--seed", "3"]
    assert terrain.outputs == [tmp_path.resolve() / "terrain.tif"]
    assert eroded.argv == ["erode", "terrain.tif", "run_eroded.tif", "--dt", "1000", "--steps", "2",
                           "--no-substep", "--co", "ZLEVEL=9", "--co", "NUM_THREADS=1",
                           "--k-d", "0.5", "--preview", "eroded.png", "--verbose"]
    assert [p.name for p in eroded.outputs] == ["run_eroded.tif", "eroded.png", "notes.txt"]
    assert eroded.inputs == [tmp_path.resolve() / "terrain.tif"]
    assert eroded.produced_by == {"terrain"}
    assert picture.argv == ["preview", "run_eroded.tif", "picture.png", "--title",
                            "${literal} 32 cells"]
    assert picture.produced_by == {"eroded"}


def test_var_overrides_replace_declared_values(tmp_path: Path, schemas) -> None:
    spec = write_spec(tmp_path, GOOD)
    pipeline = resolve(load_spec(spec), spec, schemas, parse_var_overrides(["dt=250", "size=64"]))
    assert pipeline.steps[0].argv[3] == "64"
    assert pipeline.steps[1].argv[3:5] == ["--dt", "250"]


def test_workdir_is_relative_to_the_spec(tmp_path: Path, schemas) -> None:
    (tmp_path / "out").mkdir()
    spec = write_spec(tmp_path, GOOD.replace("steps:\n", "workdir: out\nsteps:\n", 1))
    pipeline = resolve(load_spec(spec), spec, schemas)
    assert pipeline.workdir == (tmp_path / "out").resolve()
    assert pipeline.steps[0].outputs == [(tmp_path / "out" / "terrain.tif").resolve()]
    assert pipeline.state_path.parent == (tmp_path / "out").resolve()


def test_an_existing_file_given_as_text_is_hashed_as_an_input(tmp_path: Path, schemas) -> None:
    (tmp_path / "dem.tif").write_bytes(b"x")
    (tmp_path / "k.tif").write_bytes(b"y")
    spec = write_spec(tmp_path, """\
version: 1
steps:
  - {name: e, run: erode, args: [dem.tif, out.tif], options: {K: k.tif, process: fluvial}}
""")
    step = resolve(load_spec(spec), spec, schemas).steps[0]
    assert step.inputs == [tmp_path.resolve() / "dem.tif", tmp_path.resolve() / "k.tif"]


SYNTH = "version: 1\nsteps:\n  - {name: dem, run: synth, args: [dem.tif]}\n"
MALFORMED = {
    "unknown subcommand": (
        "version: 1\nsteps: [{name: a, run: sculpt, args: [x.tif]}]\n",
        "step 'a' (run): unknown subcommand 'sculpt'"),
    "unknown option": (
        SYNTH + "  - {name: past, run: unerode, args: [dem.tif, p.tif], options: {dtt: 5}}\n",
        "step 'past' (options.dtt): unerode has no option --dtt"),
    "list for a flag": (
        SYNTH + "  - {name: past, run: unerode, args: [dem.tif, p.tif], options: {no-substep: [1]}}\n",
        "step 'past' (options.no-substep): this flag takes true or false, got a list"),
    "list for a value": (
        SYNTH + "  - {name: past, run: unerode, args: [dem.tif, p.tif], options: {dt: [1, 2]}}\n",
        "step 'past' (options.dt): --dt takes one value, got a list"),
    "text for a number": (
        SYNTH + "  - {name: past, run: unerode, args: [dem.tif, p.tif], options: {dt: soon}}\n",
        "step 'past' (options.dt): expected a number, got 'soon'"),
    "number for a flag": (
        SYNTH + "  - {name: past, run: unerode, args: [dem.tif, p.tif], options: {cog: 3}}\n",
        "step 'past' (options.cog): this flag takes true or false, got 3"),
    "choice not offered": (
        SYNTH + "  - {name: past, run: unerode, args: [dem.tif, p.tif], options: {method: d16}}\n",
        "step 'past' (options.method): expected one of mfd, d8, got 'd16'"),
    "below the minimum": (
        "version: 1\nsteps: [{name: a, run: synth, args: [x.tif], options: {size: 4}}]\n",
        "step 'a' (options.size): must be ≥ 8, got 4"),
    "undefined variable": (
        SYNTH + "  - {name: past, run: unerode, args: [dem.tif, p.tif], options: {dt: '${step}'}}\n",
        "step 'past' (options.dt): variable 'step' is not defined in vars"),
    "variable without value": (
        "version: 1\nvars: {dt: null}\n" + SYNTH.split("\n", 1)[1]
        + "  - {name: past, run: unerode, args: [dem.tif, p.tif], options: {dt: '${dt}'}}\n",
        "step 'past' (options.dt): variable 'dt' has no value; pass --var dt=VALUE"),
    "later step": (
        "version: 1\nsteps:\n  - {name: past, run: unerode, args: ['${steps.dem.output}', p.tif]}\n"
        "  - {name: dem, run: synth, args: [dem.tif]}\n",
        "step 'past' (args[0]): '${steps.dem.output}' refers to step 'dem', which does not run before"),
    "unknown step": (
        SYNTH + "  - {name: past, run: unerode, args: ['${steps.demo.output}', p.tif]}\n",
        "step 'past' (args[0]): '${steps.demo.output}' refers to step 'demo', which is not a step"),
    "missing input": (
        SYNTH + "  - {name: past, run: unerode, args: [dme.tif, p.tif]}\n",
        "step 'past' (args[0]): input file dme.tif does not exist and no earlier step writes it"),
    "missing input option": (
        SYNTH + "  - {name: past, run: unerode, args: [dem.tif, p.tif], options: {params: p.yaml}}\n",
        "step 'past' (options.params): input file p.yaml does not exist"),
    "duplicate name": (
        SYNTH + "  - {name: dem, run: unerode, args: [dem.tif, p.tif]}\n",
        "step 'dem' (name): the name is used by an earlier step"),
    "same output twice": (
        SYNTH + "  - {name: past, run: unerode, args: [dem.tif, p.tif], options: {preview: x.png}}\n"
        "  - {name: pic, run: preview, args: [p.tif, x.png]}\n",
        "step 'pic' (outputs): x.png is also written by step 'past'"),
    "too many arguments": (
        "version: 1\nsteps: [{name: a, run: synth, args: [x.tif, y.tif]}]\n",
        "step 'a' (args): synth takes 1 positional argument(s), got 2"),
    "missing argument": (
        "version: 1\nsteps: [{name: a, run: preview, args: [x.tif]}]\n",
        "step 'a' (args): preview needs 2 positional argument(s) (DEM PNG), got 1"),
    "unknown step field": (
        "version: 1\nsteps: [{name: a, run: synth, args: [x.tif], option: {size: 8}}]\n",
        "step 'a' (option): is not a known field"),
    "null option": (
        "version: 1\nsteps: [{name: a, run: synth, args: [x.tif], options: {size: null}}]\n",
        "step 'a' (options.size): has no value (null)"),
    "mapping option": (
        "version: 1\nsteps: [{name: a, run: synth, args: [x.tif], options: {size: {a: 1}}}]\n",
        "step 'a' (options.size): expected text, a number, true/false or a list of them"),
    "wrong version": (
        "version: 2\nsteps: [{name: a, run: synth, args: [x.tif]}]\n",
        "spec field 'version': must be 1"),
    "no steps": ("version: 1\nsteps: []\n", "spec field 'steps'"),
    "not yaml": ("version: 1\nsteps: [{name: a\n", "is not valid YAML (line 3)"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_specs_are_refused_naming_step_and_field(tmp_path: Path, schemas, case: str) -> None:
    text, message = MALFORMED[case]
    spec = write_spec(tmp_path, text)
    with pytest.raises(InputError) as caught:
        resolve(load_spec(spec), spec, schemas)
    assert message in str(caught.value)
    assert str(caught.value).count(". ") == 0 or "e.g." in str(caught.value)  # one sentence


def test_unknown_var_on_the_command_line_is_refused(tmp_path: Path, schemas) -> None:
    spec = write_spec(tmp_path, GOOD)
    declared = r"--var dtt: the spec declares no variable 'dtt' \(declared: dt, name, size\)"
    with pytest.raises(InputError, match=declared):
        resolve(load_spec(spec), spec, schemas, parse_var_overrides(["dtt=3"]))
    with pytest.raises(InputError, match="--var expects NAME=VALUE, got 'dt'"):
        parse_var_overrides(["dt"])


def assert_refused_before_running(result: subprocess.CompletedProcess[str], folder: Path,
                                  mentions: str) -> None:
    """Exit 2, one sentence on stderr, no traceback, nothing written in the workdir."""
    assert result.returncode == 2, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert lines == [lines[0]] and lines[0].startswith("error: "), result.stderr
    assert mentions in lines[0]
    assert "Traceback" not in result.stderr
    assert sorted(p.name for p in folder.iterdir()) == ["spec.yaml"]


@pytest.mark.parametrize("case", ["unknown subcommand", "unknown option", "list for a flag",
                                  "missing input", "undefined variable", "duplicate name"])
def test_the_cli_refuses_malformed_specs_before_any_step_runs(tmp_path: Path, case: str) -> None:
    text, message = MALFORMED[case]
    spec = write_spec(tmp_path, text)
    assert_refused_before_running(run_cli("pipeline", "run", spec, cwd=tmp_path), tmp_path, message)


def test_the_cli_refuses_a_missing_spec_and_a_bad_var(tmp_path: Path) -> None:
    result = run_cli("pipeline", "run", tmp_path / "nope.yaml")
    assert result.returncode == 2
    assert result.stderr.strip() == f"error: pipeline spec {tmp_path / 'nope.yaml'} does not exist."
    spec = write_spec(tmp_path, GOOD)
    assert_refused_before_running(run_cli("pipeline", "run", spec, "--var", "size=big"), tmp_path,
                                  "step 'terrain' (options.size): expected an integer, got 'big'.")


def test_schemas_know_inputs_outputs_and_kinds(schemas) -> None:
    erode = schemas["erode"]
    assert [(a.name, a.type, a.role) for a in erode.arguments] == [
        ("source", "path", "input"), ("output", "path", "output")]
    assert erode.option("dt").type == "float"
    assert erode.option("steps").type == "int"
    assert erode.option("co").kind == "multiple"
    assert erode.option("overwrite").kind == "flag"
    assert erode.option("verbose").kind == "count"
    assert erode.option("K-d") is erode.option("k_d")
    assert (erode.option("preview").role, erode.option("change-map").role) == ("output", "output")
    assert (erode.option("params").role, erode.option("dirichlet").role) == ("input", "input")
    assert erode.option("method").choices == ("mfd", "d8")
    assert [a.role for a in schemas["preview"].arguments] == ["input", "output"]
    assert [a.role for a in schemas["synth"].arguments] == ["output"]
    assert "pipeline" not in schemas


def test_the_pipeline_command_module_imports_nothing_heavy() -> None:
    probe = ("import sys, unerode_cli.cli.pipeline_cmd; "
             "print(sorted(m for m in ('numba', 'rasterio', 'pydantic', 'yaml') if m in sys.modules))")
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert result.stdout.strip() == "[]", result.stderr


def test_help_shows_examples() -> None:
    result = run_cli("pipeline", "run", "--help")
    assert result.returncode == 0
    assert "--resume" in result.stdout and "--dry-run" in result.stdout
    assert "unerode-cli pipeline run pipelines/last_glacial_cycle.yaml --resume" in result.stdout
    assert (Path(__file__).resolve().parents[2] / "pipelines" / "last_glacial_cycle.yaml").is_file()
