"""The ``unerode-cli`` entry point. Start-up stays light: subcommand modules import numerical
and GIS libraries only when they run, so ``--help`` answers at once."""

from __future__ import annotations

import sys
from typing import Annotated

import typer
import typer.core
from typer.core import TyperGroup

from unerode_cli import __version__
from unerode_cli.cli.commands import register
from unerode_cli.cli.pipeline_cmd import pipeline_app

#: The click that parses the command line: typer's own copy where it has one, else click.
_parser_click = getattr(typer.core, "_click", None) or __import__("click")
#: The exit status of a command whose standard output was closed by its reader (``| head``,
#: ``| grep -q``): 128 + SIGPIPE, what the shell reports for a program that SIGPIPE ended.
EXIT_BROKEN_PIPE = 141


class OneLineUsageErrors(TyperGroup):
    """The root group: a usage error (unknown option, missing argument, bad value) is one line on
    stderr, ``error: …; see 'unerode-cli erode -h'.``, exit 2, instead of a framed panel. A
    standard output closed by its reader (``unerode-cli erode -h | grep -q Usage``) ends the
    command quietly with :data:`EXIT_BROKEN_PIPE`."""

    def main(self, *args, standalone_mode: bool = True, **kwargs):  # type: ignore[override]
        if not standalone_mode:
            return super().main(*args, standalone_mode=False, **kwargs)
        try:
            returned = super().main(*args, standalone_mode=False, **kwargs)
        except BrokenPipeError:
            _quiet_broken_pipe()
        except SystemExit as exiting:    # rich's console exits when its output pipe is closed
            if isinstance(exiting.__context__, BrokenPipeError):
                _quiet_broken_pipe()
            raise
        except _parser_click.exceptions.UsageError as error:
            message = error.format_message().rstrip(".")
            message = message[:1].lower() + message[1:]
            where = f"; see '{error.ctx.command_path} -h'" if error.ctx is not None else ""
            typer.echo(f"error: {message}{where}.", err=True)
            sys.exit(error.exit_code)
        except _parser_click.exceptions.ClickException as error:
            typer.echo(f"error: {error.format_message().rstrip('.')}.", err=True)
            sys.exit(error.exit_code)
        except typer.Abort:
            typer.echo("error: aborted.", err=True)
            sys.exit(1)
        sys.exit(returned if isinstance(returned, int) else 0)


def _quiet_broken_pipe() -> None:
    """Exit with :data:`EXIT_BROKEN_PIPE`, standard output and error wrapped so that Python's
    last flush at exit cannot fail on the closed pipe again (click's wrapper)."""
    sys.stdout = _parser_click.utils.PacifyFlushWrapper(sys.stdout)
    sys.stderr = _parser_click.utils.PacifyFlushWrapper(sys.stderr)
    sys.exit(EXIT_BROKEN_PIPE)


app = typer.Typer(
    name="unerode-cli",
    cls=OneLineUsageErrors,
    help="Erode terrains forward in time and unerode them backward (DEM toolchain).",
    no_args_is_help=True,
    add_completion=True,     # --install-completion / --show-completion (bash, zsh, fish, PowerShell)
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)

register(app)
app.add_typer(pipeline_app, name="pipeline")


def versions() -> str:
    """Versions of unerode-cli and the libraries a bug report needs."""
    import numba
    import numpy

    from unerode_cli.io.versions import io_library_versions

    names = {"unerode-cli": __version__, "numpy": numpy.__version__, "numba": numba.__version__,
             **io_library_versions()}
    return "\n".join(f"{name:<11} {version}" if name != "unerode-cli" else f"{name} {version}"
                     for name, version in names.items())


def _print_version(value: bool) -> None:
    if value:
        typer.echo(versions())
        raise typer.Exit()


@app.callback()
def root(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                          help="Print versions and exit.")] = False,
) -> None:
    """Erode terrains forward in time and unerode them backward (DEM toolchain)."""


def main() -> None:
    app()
