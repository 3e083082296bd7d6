"""Sandstone scene files (YAML, ``sandstone.scene``): read and validated, errors in one
sentence naming the file."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.errors import InputError
from unerode_cli.io.yaml_files import read_yaml_mapping
from unerode_cli.sandstone.scene import Scene, parse_scene

SCENE_SUFFIXES = (".yaml", ".yml")


def is_scene_file(path: Path) -> bool:
    return path.suffix.lower() in SCENE_SUFFIXES


def read_scene(path: Path) -> Scene:
    """The scene of a YAML file; InputError for an unreadable file or an invalid scene."""
    if not path.is_file():
        raise InputError(f"scene file {path} does not exist.")
    document = read_yaml_mapping(path, "the scene file", "a mapping (domain, shape, layers, ...)",
                                 allow_empty=False)
    try:
        return parse_scene(document)
    except ValueError as exc:
        raise InputError(f"the scene file {path} is invalid: {str(exc).rstrip('.')}.") from None
