"""Parsers of option values (typer ``parser=``) and the command class that reports their errors.

A value is checked when the command line is parsed, before a job plans anything, and
``pipeline run`` checks a spec's values with the same parsers before its first step. Each
parser's ``parse(value)`` returns the value or raises ValueError with the end of a sentence
("must be > 0 years, got '-5'"); calling the parser, as typer does, turns that into a
``BadParameter`` naming the option, which :class:`Command` reports as one line, exit code 2.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import Any

import typer
from typer.core import TyperCommand

from unerode_cli.cli.errors import EXIT_BAD_INPUT
from unerode_cli.run import values
from unerode_cli.run.values import OptionParser, finite_number, unit_suffix  # noqa: F401


class Command(TyperCommand):
    """A subcommand whose bad option values (wrong type, out of range, missing) are reported as
    bad input: ``error: <one sentence>`` on stderr and exit code 2."""

    def parse_args(self, ctx: typer.Context, args: list[str]) -> list[str]:
        try:
            return super().parse_args(ctx, args)
        except typer.BadParameter as exc:
            print(f"error: {exc.format_message().rstrip('.')}.", file=sys.stderr)
            raise typer.Exit(EXIT_BAD_INPUT) from None


class TyperParser:
    """Mixin: calling the parser, as typer does, turns its ValueError into a BadParameter that
    names the option (reported by :class:`Command`)."""

    def __call__(self, value: Any) -> Any:
        try:
            return self.parse(value)  # type: ignore[attr-defined]
        except ValueError as exc:
            raise typer.BadParameter(str(exc)) from None


def for_typer(parser: OptionParser) -> Any:
    """``parser`` as a typer ``parser=`` callable."""

    def parse(value: Any) -> Any:
        try:
            return parser.parse(value)
        except ValueError as exc:
            raise typer.BadParameter(str(exc)) from None

    return parse


@dataclass(frozen=True)
class Number(TyperParser, values.Number):
    """:class:`unerode_cli.run.values.Number` for typer."""


@dataclass(frozen=True)
class Numbers(TyperParser, values.Numbers):
    """:class:`unerode_cli.run.values.Numbers` for typer."""


@dataclass(frozen=True)
class ParameterValue(TyperParser, values.ParameterValue):
    """:class:`unerode_cli.run.values.ParameterValue` for typer."""
