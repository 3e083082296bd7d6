"""Process parameters from a YAML file (``--params FILE``), for runs with many of them.

The file is a mapping of parameter names (or the papers' symbols, e.g. ``K_d``) to a number or
a raster path; parameters may also be grouped under the name of the process they belong to::

    uplift: 2.5e-5
    fluvial:
      K: 2.0e-5
      K_d: maps/kd.tif        # relative paths are read from the YAML file's folder
    thermal:
      k_th: 0.008
      talus_angle: 32

Values given on the command line win over the file's. A parameter given twice (``K`` and
``k``, or at the top level and in its process's group) is refused, and so is a group of a
process that the run does not run: the file is read for the processes of ``--process`` only.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from unerode_cli.errors import InputError
from unerode_cli.io.yaml_files import read_yaml_mapping
from unerode_cli.processes.parameters import ParamSpec


def read_parameter_file(path: Path, processes: Mapping[str, Sequence[ParamSpec]]) -> dict[str, str]:
    """Parameter values (name → text: a number or an absolute raster path) read from ``path``.

    Args:
        path: the YAML file.
        processes: the processes of the run and their parameter declarations; a key must be a
            parameter of one of them, or the name of one of them holding such parameters.

    Raises:
        InputError: unreadable or malformed file, unknown name, a parameter given twice, a
            group of a process not in ``processes``, or a value that is neither a number nor a
            path.
    """
    document = read_yaml_mapping(path, "the parameter file",
                                 "a mapping of parameter names to values")
    every = _lookup([spec for specs in processes.values() for spec in specs])
    values: dict[str, str] = {}
    given_as: dict[str, str] = {}

    def put(name: str, key: str, value: Any) -> None:
        if name in values:
            raise InputError(f"the parameter file {path} gives {name} twice, as '{given_as[name]}' "
                             f"and as '{key}'; keep one.")
        values[name], given_as[name] = _text(value, key, path), key

    for key, value in document.items():
        if isinstance(key, str) and key in processes and isinstance(value, dict):
            own = _lookup(processes[key])
            for name, item in value.items():
                put(_name(own, name, path, f"process {key}"), f"{key}.{name}", item)
        elif isinstance(value, dict):
            raise InputError(f"the parameter file {path} groups parameters under '{key}', which is not "
                             f"a process of this run ({', '.join(processes)}): add it to --process "
                             "or remove the group.")
        else:
            put(_name(every, key, path, "the processes of this run"), str(key), value)
    return values


def named_rasters(path: Path) -> list[tuple[str, Path]]:
    """(text, resolved path) of every raster the parameter file ``path`` names: its values that
    are text and not numbers, at the top level or in a process's group, resolved from the
    file's folder as :func:`read_parameter_file` resolves them (symbolic links followed). The
    names are not checked here; a file that is not a YAML mapping names none (the run that
    reads it refuses it)."""
    try:
        document = read_yaml_mapping(path, "the parameter file", "a mapping of parameter names to values")
    except InputError:
        return []
    values = [v for value in document.values()
              for v in (value.values() if isinstance(value, dict) else (value,))]
    return [(value, _raster_path(path, value)) for value in values
            if isinstance(value, str) and not _is_number(value)]


def _raster_path(path: Path, value: str) -> Path:
    """A raster path of the parameter file ``path``, made absolute from the file's folder."""
    return (path.parent / value).resolve()


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _lookup(specs: Sequence[ParamSpec]) -> dict[str, str]:
    """Every accepted spelling (name, symbol, with - or _) → parameter name."""
    names = {}
    for spec in specs:
        for spelling in (spec.name, spec.symbol):
            if spelling:
                names[spelling] = spec.name
                names[spelling.replace("_", "-")] = spec.name
    return names


def _name(lookup: dict[str, str], key: Any, path: Path, owner: str) -> str:
    if not isinstance(key, str) or key not in lookup:
        known = ", ".join(sorted({v for v in lookup.values()}))
        raise InputError(f"the parameter file {path} names '{key}', which is not a parameter of "
                         f"{owner} (known: {known}).")
    return lookup[key]


def _text(value: Any, key: Any, path: Path) -> str:
    """A number as text, or a raster path made absolute from the file's folder."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise InputError(f"parameter '{key}' in {path} must be a number or a raster path.")
    if isinstance(value, str) and not _is_number(value):
        return str(_raster_path(path, value))
    return str(value)
