"""Start-up stays light: --help and info answer without importing numba, and a missing input file
is reported before numba, scipy, rasterio, matplotlib or dask are imported."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from tests.conftest import SAMPLE_DEMS

PROBE = """
import sys
from unerode_cli.cli.app import app
try:
    app(sys.argv[1:], standalone_mode=False)
finally:
    print("NUMBA_IMPORTED=" + str("numba" in sys.modules), file=sys.stderr)
"""


def run_probe(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", PROBE, *args], capture_output=True, text=True,
                          timeout=120)


def test_help_does_not_import_numba() -> None:
    result = run_probe("--help")
    assert "info" in result.stdout
    assert "NUMBA_IMPORTED=False" in result.stderr


def test_info_does_not_import_numba() -> None:
    result = run_probe("info", str(Path(SAMPLE_DEMS) / "valley_utm32n_30m.tif"))
    assert "256 × 256" in result.stdout
    assert "NUMBA_IMPORTED=False" in result.stderr


def test_version_lists_the_libraries() -> None:
    result = subprocess.run([sys.executable, "-m", "unerode_cli", "--version"],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0
    for name in ("unerode-cli", "numpy", "numba", "rasterio", "GDAL", "PROJ", "OpenEXR"):
        assert name in result.stdout


ENTRY_PROBE = """
import sys
from unerode_cli.cli.app import main
sys.argv[0] = "unerode-cli"
try:
    main()
finally:
    heavy = sorted(m for m in ("numba", "scipy", "rasterio", "matplotlib", "dask") if m in sys.modules)
    print("HEAVY=" + ",".join(heavy), file=sys.stderr)
"""


def run_entry(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """The command line's entry point in a fresh interpreter, reporting on stderr which heavy
    libraries were imported when it ended."""
    return subprocess.run([sys.executable, "-c", ENTRY_PROBE, *args], capture_output=True, text=True,
                          timeout=120, cwd=cwd)


@pytest.mark.parametrize(("args", "message"), [
    (("erode", "missing.tif", "out.tif"), "error: input missing.tif does not exist."),
    (("unerode", "missing.tif", "out.tif", "--steps", "3"), "error: input missing.tif does not exist."),
    (("diff", "missing.tif", "missing.tif", "d.tif"), "error: input missing.tif does not exist."),
    (("climate-run", "missing.tif", "out.tif", "--chronology", "c.txt"),
     "error: input missing.tif does not exist."),
    (("ensemble", "missing.yaml", "out"), "error: ensemble spec missing.yaml does not exist."),
    (("report", "missing"), "error: the run folder missing does not exist or is not a folder."),
    (("pipeline", "run", "missing.yaml"), "error: pipeline spec missing.yaml does not exist."),
])
def test_a_missing_input_is_reported_before_the_heavy_imports(tmp_path: Path, args: tuple[str, ...],
                                                              message: str) -> None:
    result = run_entry(*args, cwd=tmp_path)
    lines = result.stderr.splitlines()
    assert result.returncode == 2
    assert lines == [message, "HEAVY="]
    assert not list(tmp_path.iterdir())


def test_the_second_of_several_inputs_is_checked_too(tmp_path: Path) -> None:
    dem = Path(SAMPLE_DEMS) / "valley_utm32n_30m.tif"
    result = run_entry("hypsometry", str(dem), "gone.tif", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.splitlines()[0] == "error: input gone.tif does not exist."


def test_the_same_message_comes_from_the_full_checks() -> None:
    """The early check says what the reading of the input says when it is missing."""
    from unerode_cli.cli.declared import MISSING_INPUT
    from unerode_cli.errors import InputError
    from unerode_cli.io.rasters import read_header

    with pytest.raises(InputError) as refused:
        read_header(Path("missing.tif"))
    assert str(refused.value) == MISSING_INPUT.format(path=Path("missing.tif"))
