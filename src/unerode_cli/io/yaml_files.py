"""Reading the YAML files of a run (parameter files, climate schedules, pipeline specs)."""

from __future__ import annotations

import functools
from collections.abc import Hashable
from pathlib import Path
from typing import Any

from unerode_cli.errors import InputError


class _DuplicateKey(Exception):
    """A mapping of the YAML text gives ``key`` twice, the second time on ``line`` (1-based)."""

    def __init__(self, key: Any, line: int) -> None:
        super().__init__(key, line)
        self.key, self.line = key, line


@functools.cache
def _loader() -> type:
    """yaml's SafeLoader, except that a key given twice in one mapping is an error (YAML
    would silently keep the last value)."""
    import yaml

    class UniqueKeyLoader(yaml.SafeLoader):
        def construct_mapping(self, node: Any, deep: bool = False) -> dict[Any, Any]:
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                if not isinstance(key, Hashable):
                    continue
                if key in seen:
                    raise _DuplicateKey(key, key_node.start_mark.line + 1)
                seen.add(key)
            return super().construct_mapping(node, deep)

    return UniqueKeyLoader


def read_yaml_mapping(path: Path, what: str, mapping_of: str, allow_empty: bool = True) -> dict[str, Any]:
    """The top-level mapping of the YAML file ``path``; an empty file is ``{}`` when
    ``allow_empty``.

    Raises:
        InputError: one sentence naming ``what`` (e.g. "the parameter file") and ``path`` for an
            unreadable file, text that is not UTF-8 or not valid YAML (with the line), a key
            given twice in one mapping (with the line), or a document that is not ``mapping_of``
            (e.g. "a mapping of phases to parameters").
    """
    import yaml

    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{what} {path} is not a UTF-8 text file.") from None
    except OSError as exc:
        raise InputError(f"cannot read {what} {path}: {exc.strerror}.") from None
    try:
        document = yaml.load(text, Loader=_loader())  # a SafeLoader that refuses duplicate keys
    except _DuplicateKey as exc:
        raise InputError(f"{what} {path} gives the key '{exc.key}' twice (line {exc.line}); "
                         "keep one.") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise InputError(f"{what} {path} is not valid YAML{where}.") from None
    if document is None and allow_empty:
        return {}
    if not isinstance(document, dict):
        raise InputError(f"{what} {path} must be {mapping_of}.")
    return document
