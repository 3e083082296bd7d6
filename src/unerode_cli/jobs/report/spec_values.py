"""The values of an ensemble as a reader wants them: ``${var}`` references of the spec replaced
by the variables' values (the spec's ``vars:`` with the run's ``--var`` values over them) and
paths resolved against the spec's folder, shown relative to the run folder when they lie in it
and whole otherwise; the sweep as the spec gives it (which parameters are log-uniform)."""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from unerode_cli.ensemble.sweep import Sampled, parse_parameter
from unerode_cli.errors import InputError
from unerode_cli.io.yaml_files import read_yaml_mapping

_REFERENCE = re.compile(r"\$\{([^}]*)\}")


@dataclass(frozen=True)
class SpecValues:
    """``variables`` (name → text) of the spec, its folder ``base`` (None when the spec cannot
    be read), the ``run_dir`` and the spec's ``sweep`` mapping (key → list or distribution)."""

    run_dir: Path
    base: Path | None = None
    variables: dict[str, str] = field(default_factory=dict)
    sweep: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, record: dict[str, Any], run_dir: Path) -> SpecValues:
        """The values of the ensemble recorded in ``record`` (ensemble.json) in ``run_dir``."""
        spec = Path(str(record.get("spec", "")))
        overrides = {str(k): str(v) for k, v in (record.get("vars") or {}).items()}
        try:
            document = read_yaml_mapping(spec, "the ensemble spec", "a mapping") if spec.is_file() else None
        except InputError:
            document = None
        if document is None:
            return cls(run_dir.resolve(), None, overrides)
        declared = document.get("vars") if isinstance(document.get("vars"), dict) else {}
        variables = {str(k): str(v) for k, v in declared.items() if v is not None} | overrides
        sweep = document.get("sweep") if isinstance(document.get("sweep"), dict) else {}
        return cls(run_dir.resolve(), spec.resolve().parent, variables, sweep)

    def log_keys(self) -> frozenset[str]:
        """The swept parameters sampled log-uniformly (drawn on log axes)."""
        keys = set()
        for key, raw in self.sweep.items():
            try:
                parameter = parse_parameter(str(key), raw)
            except ValueError:
                continue
            if isinstance(parameter, Sampled) and parameter.kind == "log-uniform":
                keys.add(str(key))
        return frozenset(keys)

    def swept_as(self, key: str) -> str:
        """How the spec sweeps ``key``: "log-uniform [1e-05, 4e-05]", "2 values: a, b" …"""
        raw = self.sweep.get(key)
        if isinstance(raw, list):
            return f"{len(raw)} value(s): " + ", ".join(str(self.shown(v)) for v in raw)
        if isinstance(raw, dict) and len(raw) == 1:
            (kind, bounds), = raw.items()
            return f"{kind} {bounds}"
        return "?"

    def shown(self, value: Any) -> Any:
        """``value`` with its ``${var}`` references replaced and, when it names a path (text
        without spaces that had a reference, or that names a file or folder from the spec's
        folder), that path resolved and shown relative to the run folder when inside it. Other
        values are returned as they are."""
        if not isinstance(value, str) or not value:
            return value
        text = _REFERENCE.sub(lambda m: self.variables.get(m.group(1).strip(), m.group(0)), value)
        if "${" in text or self.base is None or any(c.isspace() for c in text):
            return text                     # an unknown reference, no spec, or a sentence
        path = Path(text).expanduser()
        candidate = path if path.is_absolute() else self.base / path
        if text == value and not (("/" in text or os.sep in text or path.suffix) and candidate.exists()):
            return text
        resolved = Path(os.path.normpath(candidate))
        if resolved.is_relative_to(self.run_dir):
            return resolved.relative_to(self.run_dir).as_posix()
        return resolved.as_posix()
