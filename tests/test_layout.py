"""The package layout (DESIGN §3): only ``io/`` opens files (``viz/`` writes its PNGs), and the
import-linter contracts of pyproject.toml hold."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "unerode_cli"
ROOT = PACKAGE.parents[1]

#: Folders whose code may open files: io/ for everything, viz/ for the PNGs it draws.
FILE_ROOMS = ("io", "viz")
#: The one other module that touches a file, with its reason: the stamp of numba's own cache
#: inside the package (no user file), kept by the package's import before any subpackage loads.
EXCEPTIONS = {"kernel_cache.py"}

#: Libraries that read or write files, imported nowhere outside io/.
FILE_LIBRARIES = {"rasterio", "OpenEXR", "yaml"}
#: Methods that open, read or write a file, whatever object they are called on.
FILE_METHODS = {"open", "read_text", "write_text", "read_bytes", "write_bytes", "safe_load",
                "loadtxt", "genfromtxt", "savetxt", "savez", "savez_compressed", "fromfile", "tofile"}
#: numpy's own readers and writers (``np.load``, ``np.save``).
NUMPY_FILE_FUNCTIONS = {"load", "save"}


def file_access(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, what) of every call or import in ``tree`` that opens, reads or writes a file."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, f"import {a.name}") for a in node.names
                      if a.name.split(".")[0] in FILE_LIBRARIES]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] in FILE_LIBRARIES:
                found.append((node.lineno, f"from {node.module} import ..."))
        elif isinstance(node, ast.Call):
            func = node.func
            if isinstance(func, ast.Name) and func.id == "open":
                found.append((node.lineno, "open()"))
            elif isinstance(func, ast.Attribute):
                owner = func.value.id if isinstance(func.value, ast.Name) else ""
                if func.attr in FILE_METHODS:
                    found.append((node.lineno, f".{func.attr}()"))
                elif owner in ("np", "numpy") and func.attr in NUMPY_FILE_FUNCTIONS:
                    found.append((node.lineno, f"{owner}.{func.attr}()"))
    return found


def outside_file_rooms() -> list[Path]:
    modules = []
    for path in sorted(PACKAGE.rglob("*.py")):
        relative = path.relative_to(PACKAGE)
        if relative.parts[0] in FILE_ROOMS or relative.as_posix() in EXCEPTIONS:
            continue
        modules.append(path)
    return modules


def test_only_io_opens_files() -> None:
    offenders = [f"{path.relative_to(PACKAGE)}:{line}: {what}"
                 for path in outside_file_rooms()
                 for line, what in file_access(ast.parse(path.read_text(encoding="utf-8")))]
    assert offenders == []


@pytest.mark.parametrize("source, expected", [
    ("open('a')", ["open()"]),
    ("import rasterio", ["import rasterio"]),
    ("from rasterio.crs import CRS", ["from rasterio.crs import ..."]),
    ("Path('a').write_text('x')", [".write_text()"]),
    ("yaml.safe_load(text)", [".safe_load()"]),
    ("np.load(p)", ["np.load()"]),
    ("np.loadtxt(p)", [".loadtxt()"]),
    ("rasterio.open(p)", [".open()"]),
    ("json.loads(text); np.savez_compressed", []),
])
def test_the_file_access_check_sees_each_kind_of_call(source: str, expected: list[str]) -> None:
    assert [what for _, what in file_access(ast.parse(source))] == expected


def test_the_package_has_the_rooms_of_the_design() -> None:
    rooms = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert {"cli", "pipeline", "jobs", "run", "io", "viz", "hydro", "processes"} <= rooms
    assert "raster" not in rooms
    pipeline = {p.name for p in (PACKAGE / "pipeline").glob("*.py")}
    assert pipeline == {"__init__.py", "spec.py", "pipeline_run.py", "ensemble_spec.py", "ensemble_run.py",
                        "ensemble_member.py", "commands.py", "ensemble_options.py"}


def test_import_contracts_hold() -> None:
    lint_imports = shutil.which("lint-imports", path=str(Path(sys.executable).parent))
    if lint_imports is None:
        pytest.skip("import-linter is not installed (pip install -e '.[dev]')")
    result = subprocess.run([lint_imports, "--no-cache"], cwd=ROOT, capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]


#: Longest job module (lines): a job holds its plan, run and write; more goes into a module of
#: its package or below the jobs layer.
JOB_MODULE_LINES = 400
#: Longest function (lines, ``def`` to its last line) whose docstring gives no reason.
FUNCTION_LINES = 80
#: How a longer function's docstring gives its reason.
KEPT_WHOLE = "Kept whole:"


def test_no_job_module_is_oversized() -> None:
    sizes = {path.relative_to(PACKAGE).as_posix(): len(path.read_text(encoding="utf-8").splitlines())
             for path in (PACKAGE / "jobs").rglob("*.py")}
    assert {name: n for name, n in sizes.items() if n > JOB_MODULE_LINES} == {}


def long_functions(tree: ast.AST) -> list[tuple[str, int]]:
    """(name, lines) of the functions longer than FUNCTION_LINES without a "Kept whole:" reason."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            lines = node.end_lineno - node.lineno + 1
            if lines > FUNCTION_LINES and KEPT_WHOLE not in (ast.get_docstring(node) or ""):
                found.append((node.name, lines))
    return found


def test_long_functions_say_why() -> None:
    offenders = [f"{path.relative_to(PACKAGE)}:{name} ({lines} lines)"
                 for path in sorted(PACKAGE.rglob("*.py"))
                 for name, lines in long_functions(ast.parse(path.read_text(encoding="utf-8")))]
    assert offenders == []


def test_the_length_check_sees_a_long_function() -> None:
    body = "\n".join(f"    x = {i}" for i in range(FUNCTION_LINES))
    assert long_functions(ast.parse(f"def f():\n{body}\n")) == [("f", FUNCTION_LINES + 1)]
    kept = f'def f():\n    """{KEPT_WHOLE} one loop nest."""\n{body}\n'
    assert long_functions(ast.parse(kept)) == []
