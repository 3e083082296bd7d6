"""Option values on the command line: the declared parsers (:mod:`unerode_cli.run.values`)
as typer ``parser=`` callables, and the command class that reports their errors.

A value is checked when the command line is parsed, before a job plans anything (``pipeline
run`` checks a spec's values with the same parsers before its first step). A parser's
ValueError becomes a ``BadParameter`` naming the option, which :class:`Command` reports as one
line, exit code 2.
"""

from __future__ import annotations

import sys
from typing import Any

import typer
from typer.core import TyperCommand

from unerode_cli.cli.errors import EXIT_BAD_INPUT
from unerode_cli.run.values import OptionParser


class Command(TyperCommand):
    """A subcommand whose bad option values (wrong type, out of range, missing) are reported as
    bad input: ``error: <one sentence>`` on stderr and exit code 2."""

    def parse_args(self, ctx: typer.Context, args: list[str]) -> list[str]:
        try:
            return super().parse_args(ctx, args)
        except typer.BadParameter as exc:
            print(f"error: {exc.format_message().rstrip('.')}.", file=sys.stderr)
            raise typer.Exit(EXIT_BAD_INPUT) from None


def for_typer(parser: OptionParser) -> Any:
    """``parser`` as a typer ``parser=`` callable."""

    def parse(value: Any) -> Any:
        try:
            return parser.parse(value)
        except ValueError as exc:
            raise typer.BadParameter(str(exc)) from None

    return parse
