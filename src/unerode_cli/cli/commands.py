"""The table of unerode-cli subcommands (name → typer command function), registered on the
root app by :mod:`unerode_cli.cli.app` and read by ``pipeline run`` to learn what each
subcommand accepts."""

from __future__ import annotations

from collections.abc import Callable

import typer

from unerode_cli.cli.climate_run import climate_run
from unerode_cli.cli.compare_terraces import compare_terraces
from unerode_cli.cli.convert import convert
from unerode_cli.cli.diff import diff
from unerode_cli.cli.ensemble import ensemble
from unerode_cli.cli.erode import erode, unerode
from unerode_cli.cli.examples import epilog
from unerode_cli.cli.flow import flow
from unerode_cli.cli.glaciate import glaciate
from unerode_cli.cli.hypsometry import hypsometry
from unerode_cli.cli.info import info
from unerode_cli.cli.landforms import landforms
from unerode_cli.cli.particle_erode import particle_erode
from unerode_cli.cli.preview import preview
from unerode_cli.cli.report import report
from unerode_cli.cli.sandstone import sandstone
from unerode_cli.cli.synth import synth
from unerode_cli.cli.values import Command

COMMANDS: dict[str, Callable[..., None]] = {
    "info": info, "convert": convert, "preview": preview, "synth": synth, "flow": flow,
    "erode": erode, "unerode": unerode, "diff": diff, "hypsometry": hypsometry,
    "glaciate": glaciate, "climate-run": climate_run, "compare-terraces": compare_terraces,
    "particle-erode": particle_erode, "landforms": landforms, "sandstone": sandstone,
    "ensemble": ensemble, "report": report,
}


def register(app: typer.Typer) -> typer.Typer:
    """Add every subcommand of :data:`COMMANDS` to ``app`` (in table order), each reporting bad
    option values as bad input (:class:`~unerode_cli.cli.values.Command`) and ending its help
    with its examples (:mod:`unerode_cli.cli.examples`); returns ``app``."""
    for name, command in COMMANDS.items():
        app.command(name, cls=Command, epilog=epilog(name))(command)
    return app
