"""One command-line option per declared process parameter (ParamSpec → ``--name``)."""

from __future__ import annotations

import functools
import inspect
import typing
from collections.abc import Callable, Mapping, Sequence
from typing import Annotated, Any

import typer

from unerode_cli.cli.values import ParameterValue, unit_suffix
from unerode_cli.processes.parameters import ParamSpec

VALUES_ARGUMENT = "parameter_values"


def option_help(spec: ParamSpec) -> str:
    """Help text with unit, default, range and whether a raster is accepted.

    Brackets are escaped: rich would read ``[m/y; ...]`` as a markup tag and drop it."""
    bounds = []
    if spec.minimum is not None:
        bounds.append(f"≥ {spec.minimum:g}")
    if spec.maximum is not None:
        bounds.append(f"≤ {spec.maximum:g}")
    extra = f"; {', '.join(bounds)}" if bounds else ""
    raster = "; a number or a raster on the DEM's grid" if spec.raster else ""
    unit = unit_suffix(spec.unit).strip() or "dimensionless"
    text = spec.help.replace("[", "\\[")
    return f"{text} \\[{unit}; default {spec.default:g}{extra}{raster}]"


def with_parameter_options(
    groups: Mapping[str, Sequence[ParamSpec]],
) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Give a typer command one ``--NAME`` option per spec (``_`` → ``-``), shown in one help
    panel per group (e.g. per process); a spec in several groups gets one option, in the
    panel of its first group.

    The decorated function receives the given values as ``parameter_values`` (a dict of name →
    text, ``None`` where the option was not given) instead of one argument per option.
    """
    panels: dict[str, str] = {}
    unique: dict[str, ParamSpec] = {}
    for panel, group in groups.items():
        for spec in group:
            panels.setdefault(spec.name, panel)
            unique.setdefault(spec.name, spec)
    specs = list(unique.values())

    def decorate(func: Callable[..., Any]) -> Callable[..., Any]:
        signature = inspect.signature(func)
        resolved = typing.get_type_hints(func, include_extras=True)
        base = [p.replace(annotation=resolved.get(p.name, p.annotation))
                for p in signature.parameters.values() if p.name != VALUES_ARGUMENT]
        added = []
        for spec in specs:
            names = [f"--{spec.name.replace('_', '-')}"]
            if spec.symbol and spec.symbol != spec.name:
                names.append(f"--{spec.symbol.replace('_', '-')}")
            annotation = Annotated[str | None, typer.Option(
                *names, parser=ParameterValue(spec), help=option_help(spec), show_default=False,
                rich_help_panel=panels[spec.name])]
            added.append(inspect.Parameter(spec.name, inspect.Parameter.KEYWORD_ONLY,
                                           default=None, annotation=annotation))

        @functools.wraps(func)
        def command(**kwargs: Any) -> Any:
            values = {spec.name: kwargs.pop(spec.name) for spec in specs}
            return func(**kwargs, **{VALUES_ARGUMENT: values})

        hints = {p.name: p.annotation for p in base}
        command.__signature__ = signature.replace(parameters=base + added)  # type: ignore[attr-defined]
        command.__annotations__ = {**hints, **{p.name: p.annotation for p in added}}
        return command

    return decorate
