"""A pipeline or ensemble spec stays in its folder (issue 45, class 8), and its steps never
clobber each other or their inputs (class 1).

Every path a spec names — outputs, ``workdir``, ``--var`` values, raster paths inside
``--params`` files, folders of glob patterns — resolves (symbolic links followed) inside the
workdir (outputs) or inside the workdir, the spec's folder or a ``--data`` folder (inputs);
anything else is refused before any step with one sentence and exit code 2, unless the user
passes ``--allow-outside``. ``options: {overwrite: true}`` replaces only files the spec wrote.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from tests.conftest import write_geotiff
from tests.refusals import cli as run_in


def cli(*args: object, cwd: Path) -> tuple[int, str]:
    """Run ``unerode-cli ARGS`` in this process in ``cwd``: (exit code, stderr)."""
    return run_in(cwd, *args)


def files(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (relative name → content), links as their target's name."""
    found = {}
    for path in sorted(folder.rglob("*")):
        name = path.relative_to(folder).as_posix()
        if path.is_symlink():
            found[name] = os.readlink(path).encode()
        elif path.is_file():
            found[name] = path.read_bytes()
    return found


def one_sentence(stderr: str, phrase: str) -> None:
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1, stderr
    assert lines[0].startswith("error: ") and phrase in lines[0], stderr
    assert "Error:" not in lines[0] and "Traceback" not in stderr


def dem(path: Path, value: float | None = None) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    rows, cols = np.mgrid[0:16, 0:16].astype(np.float32)
    data = (100.0 + 3.0 * rows + cols) if value is None else np.full((16, 16), value, np.float32)
    return write_geotiff(path, data.astype(np.float32))


def spec(path: Path, *steps: dict, **extra: object) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump({"version": 1, **extra, "steps": list(steps)}, sort_keys=False))
    return path


def copy(output: str, source: str = "dem.tif", **options: object) -> dict:
    step: dict = {"name": "copy", "run": "convert", "args": [source, output]}
    return {**step, "options": options} if options else step


@pytest.fixture
def case(tmp_path: Path) -> Path:
    """A case folder with ``spec/dem.tif`` and a file outside the spec's folder."""
    dem(tmp_path / "spec" / "dem.tif")
    dem(tmp_path / "outside" / "k.tif", 1e-5)
    return tmp_path


def refused(case: Path, argv: tuple[object, ...], phrase: str) -> None:
    """``argv`` exits 2 with one sentence holding ``phrase`` and leaves every file as it was."""
    before = files(case)
    code, stderr = cli(*argv, cwd=case)
    assert code == 2, stderr
    one_sentence(stderr, phrase)
    assert files(case) == before


RUN = ("pipeline", "run", "spec/p.yaml")


@pytest.mark.parametrize(("name", "steps", "extra", "argv", "phrase"), [
    ("output in the parent folder", [copy("../escape.tif")], {}, (), "outside the workdir"),
    ("absolute output", [copy("ABS/escape.tif")], {}, (), "outside the workdir"),
    ("workdir outside", [copy("out.tif", "../spec/dem.tif")], {"workdir": "../outside"}, (),
     "outside the spec's folder"),
    ("--var escapes", [copy("${out}")], {"vars": {"out": "out.tif"}}, ("--var", "out=../escape.tif"),
     "outside the workdir"),
    ("input outside", [copy("out.tif", "../outside/k.tif")], {}, (),
     "outside the workdir, the spec's folder"),
    ("absolute input", [copy("out.tif", "ABS/outside/k.tif")], {}, (), "--data"),
    ("preview outside", [copy("out.tif", preview="../p.png")], {}, (), "outside the workdir"),
    ("glob outside", [{"name": "c", "run": "compare-terraces",
                       "options": {"present": "dem.tif", "snapshots": "../outside/*.tif", "out": "report"}}],
     {}, (), "the pattern ../outside/*.tif"),
])
def test_a_path_out_of_the_spec_folder_is_refused_before_any_step(
        case: Path, name: str, steps: list[dict], extra: dict, argv: tuple[str, ...], phrase: str) -> None:
    text = json.dumps(steps).replace("ABS", str(case))
    spec(case / "spec" / "p.yaml", *json.loads(text), **extra)
    refused(case, (*RUN, *argv), phrase)


def test_a_parameter_file_naming_a_raster_outside_is_refused(case: Path) -> None:
    (case / "spec" / "params.yaml").write_text("K: ../outside/k.tif\n")
    spec(case / "spec" / "p.yaml", {"name": "e", "run": "erode", "args": ["dem.tif", "out.tif"],
                                    "options": {"steps": 1, "params": "params.yaml"}})
    refused(case, RUN, "params.yaml names the raster ../outside/k.tif")
    # the user's --data folder admits it (checked by a dry run: nothing is written)
    code, stderr = cli(*RUN, "--dry-run", "--data", "outside", cwd=case)
    assert code == 0, stderr


def test_a_symbolic_link_out_of_the_workdir_is_refused(case: Path) -> None:
    victim = dem(case / "victim.tif", 7.0)
    (case / "spec" / "link.tif").symlink_to("../victim.tif")
    spec(case / "spec" / "p.yaml", copy("link.tif", overwrite=True))
    before = victim.read_bytes()
    refused(case, RUN, "outside the workdir")
    assert victim.read_bytes() == before
    # an input folder holding a link that leads out is refused as well
    (case / "spec" / "in").mkdir()
    (case / "spec" / "in" / "k.tif").symlink_to(case / "outside" / "k.tif")
    spec(case / "spec" / "p.yaml", {"name": "c", "run": "compare-terraces",
                                    "options": {"present": "dem.tif", "snapshots": "in", "out": "report"}})
    refused(case, RUN, "outside the workdir, the spec's folder")


def test_data_and_allow_outside_widen_the_confinement_for_the_users_own_specs(case: Path) -> None:
    spec(case / "spec" / "p.yaml", copy("out.tif", "../outside/k.tif"))
    code, stderr = cli(*RUN, "--data", "outside", cwd=case)
    assert code == 0, stderr
    assert (case / "spec" / "out.tif").is_file()

    spec(case / "spec" / "q.yaml", copy("../written/out.tif"))
    (case / "written").mkdir()
    refused(case, ("pipeline", "run", "spec/q.yaml"), "outside the workdir")
    code, stderr = cli("pipeline", "run", "spec/q.yaml", "--allow-outside", "written", cwd=case)
    assert code == 0, stderr
    assert (case / "written" / "out.tif").is_file()


def test_a_data_folder_that_is_not_one_is_refused(case: Path) -> None:
    spec(case / "spec" / "p.yaml", copy("out.tif"))
    refused(case, (*RUN, "--data", "nowhere"), "--data nowhere: no such folder")


def test_overwrite_true_replaces_only_what_the_spec_wrote(case: Path) -> None:
    precious = dem(case / "spec" / "precious.tif", 7.0)
    before = precious.read_bytes()
    spec(case / "spec" / "p.yaml", copy("precious.tif", overwrite=True))
    refused(case, RUN, "was not written by this pipeline")
    assert precious.read_bytes() == before

    # a file the same spec wrote in an earlier run is its own: a rerun replaces it
    spec(case / "spec" / "p.yaml", copy("out.tif", overwrite=True))
    assert cli(*RUN, cwd=case)[0] == 0
    state = json.loads((case / "spec" / ".p.state.json").read_text())
    assert {"out.tif", "out.tif.json"} <= set(state["written"])     # the manifest, with sha256
    code, stderr = cli(*RUN, cwd=case)
    assert code == 0, stderr

    # a side file the step would write beside its output, not written by the spec, is kept
    spec(case / "spec" / "p.yaml", copy("new.tif", overwrite=True))
    (case / "spec" / "new.tif.json").write_text("precious")
    refused(case, RUN, "new.tif.json, which the step writes beside its output")


def test_two_steps_writing_one_output_are_refused(case: Path) -> None:
    spec(case / "spec" / "p.yaml", copy("out.tif"), {**copy("out.tif"), "name": "again"})
    refused(case, RUN, "out.tif is also written by step 'copy'")


def test_a_step_output_that_is_its_own_input_is_refused(case: Path) -> None:
    spec(case / "spec" / "p.yaml", copy("dem.tif", overwrite=True))
    refused(case, RUN, "is also an input")


# ---------------------------------------------------------------------------------------------
# Ensembles: the same confinement, members writing in their own folder; sizes refused early.

ENSEMBLE = ("ensemble", "spec/ens.yaml", "out")
ERODE = {"name": "e", "run": "erode", "args": ["dem.tif", "past.tif"], "options": {"steps": 1}}


def ensemble(case: Path, step: dict, sweep: dict | None = None, **extra: object) -> None:
    spec(case / "spec" / "ens.yaml", step, **extra, sweep=sweep or {"e.K": [1e-5, 2e-5]})


@pytest.mark.parametrize(("step", "sweep", "argv", "phrase"), [
    ({**ERODE, "args": ["dem.tif", "../../../escape.tif"]}, None, (), "outside"),
    ({**ERODE, "args": ["../outside/k.tif", "past.tif"]}, None, (), "outside the workdir, the spec's folder"),
    (ERODE, {"e.K": ["../outside/k.tif", "1e-5"]}, (), "member 0 (e.K=../outside/k.tif)"),
    ({**ERODE, "args": ["dem.tif", "${out}"]}, None, ("--var", "out=../../../escape.tif"), "outside"),
])
def test_an_ensemble_path_out_of_its_folders_is_refused_before_any_member(
        case: Path, step: dict, sweep: dict | None, argv: tuple[str, ...], phrase: str) -> None:
    extra = {"vars": {"out": "past.tif"}} if "${out}" in json.dumps(step) else {}
    ensemble(case, step, sweep, **extra)
    refused(case, (*ENSEMBLE, *argv), phrase)
    assert not (case / "out").exists()


def test_an_absurd_sweep_is_refused_with_its_count_before_any_member(case: Path) -> None:
    ensemble(case, ERODE, {"e.K": {"uniform": [1e-5, 2e-5]}, "e.K-d": [0.5, 1.0]})
    refused(case, (*ENSEMBLE, "--members", "1000000000000"), "2,000,000,000,000 members")


def test_a_spec_that_is_the_ensembles_own_record_is_refused(case: Path) -> None:
    dem(case / "out" / "dem.tif")
    spec(case / "out" / "ensemble.json", ERODE, sweep={"e.K": [1e-5, 2e-5]})
    refused(case, ("ensemble", "out/ensemble.json", "out", "--overwrite"), "the ensemble's record")


def test_an_ensemble_leaves_no_dask_scratch_space(case: Path, tmp_path_factory: pytest.TempPathFactory,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """The local cluster's scratch space (workers' locks) lives in a temporary folder removed
    with the cluster: nothing in the case folder, its working folder or the temporary folder."""
    scratch_root = tmp_path_factory.mktemp("tmp")
    monkeypatch.setenv("TMPDIR", str(scratch_root))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    ensemble(case, ERODE)
    code, stderr = cli(*ENSEMBLE, "--workers", "1", cwd=case)
    assert code == 0, stderr
    assert not list(case.rglob("dask-scratch-space")) and not list(scratch_root.rglob("*"))
    assert sorted(p.name for p in (case / "out" / "members").iterdir()) == ["0000", "0001"]
