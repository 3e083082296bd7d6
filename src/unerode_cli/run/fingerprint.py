"""Fingerprints of runs: which checkpoint belongs to which run (``--resume``)."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from unerode_cli import __version__
from unerode_cli.io.paths import file_sha256


def run_fingerprint(fields: dict[str, Any], files: Iterable[Path | str | None]) -> str:
    """SHA-256 (hex) of a run's options ``fields`` (JSON, keys sorted, other types as text), the
    contents of its input ``files`` (None skipped) and the program's version: equal for two runs
    that give the same result, so a checkpoint is only ever continued by its own run."""
    digest = hashlib.sha256(json.dumps(fields, sort_keys=True, default=str).encode())
    for path in files:
        if path is not None:
            digest.update(file_sha256(Path(path)).encode())
    digest.update(__version__.encode())
    return digest.hexdigest()
