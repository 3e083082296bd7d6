"""Start-up stays light: --help and info answer without importing numba."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

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
