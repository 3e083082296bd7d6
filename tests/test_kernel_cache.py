"""The numba cache is started afresh when, and only when, a source file changes."""

from __future__ import annotations

import os
from pathlib import Path

from unerode_cli.kernel_cache import refresh, sources_fingerprint


def _package(root: Path) -> Path:
    package = root / "pkg"
    (package / "sub" / "__pycache__").mkdir(parents=True)
    (package / "a.py").write_text("x = 1\n")
    (package / "sub" / "b.py").write_text("y = 2\n")
    return package


def _cache_files(package: Path) -> list[Path]:
    cache = package / "sub" / "__pycache__"
    files = [cache / "b.f-1.py311.nbi", cache / "b.f-1.py311.1.nbc"]
    for path in files:
        path.write_bytes(b"cached")
    return files


def test_unchanged_sources_keep_the_cache(tmp_path: Path) -> None:
    package = _package(tmp_path)
    stamp = package / "__pycache__" / "stamp"
    assert refresh(package, stamp)  # first run: no stamp yet
    files = _cache_files(package)
    assert not refresh(package, stamp)
    assert all(path.exists() for path in files)


def test_a_changed_source_clears_the_cache(tmp_path: Path) -> None:
    package = _package(tmp_path)
    stamp = package / "__pycache__" / "stamp"
    refresh(package, stamp)
    files = _cache_files(package)
    before = sources_fingerprint(package)
    source = package / "sub" / "b.py"
    stat = source.stat()
    os.utime(source, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000_000))  # a git pull
    assert sources_fingerprint(package) != before
    assert refresh(package, stamp)
    assert not any(path.exists() for path in files)
    assert (package / "a.py").exists() and source.exists()
    assert stamp.read_text() == sources_fingerprint(package)


def test_nothing_is_deleted_where_the_stamp_cannot_be_written(tmp_path: Path) -> None:
    package = _package(tmp_path)
    (tmp_path / "blocked").write_text("a file where the stamp's folder should be")
    files = _cache_files(package)
    assert not refresh(package, tmp_path / "blocked" / "stamp")
    assert all(path.exists() for path in files)
