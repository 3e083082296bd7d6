"""Turn exceptions into one sentence on stderr and an exit code (DESIGN §5)."""

from __future__ import annotations

import contextlib
import sys
import traceback
from collections.abc import Iterator

import typer

from unerode_cli.errors import InputError

EXIT_BAD_INPUT = 2
EXIT_RUNTIME = 1


@contextlib.contextmanager
def reported_errors(verbosity: int) -> Iterator[None]:
    """Bad input → exit 2, anything else → exit 1; a traceback only with ``-v``."""
    try:
        yield
    except (typer.Exit, typer.Abort):
        raise
    except InputError as exc:
        _say(f"error: {exc}", verbosity)
        raise typer.Exit(EXIT_BAD_INPUT) from None
    except KeyboardInterrupt:
        print("interrupted; no output was written under its final name.", file=sys.stderr)
        raise typer.Exit(130) from None
    except Exception as exc:  # noqa: BLE001 - the last line of defence of the CLI
        _say(f"error: {type(exc).__name__}: {exc} (run with -v for the traceback)", verbosity)
        raise typer.Exit(EXIT_RUNTIME) from None


def _say(message: str, verbosity: int) -> None:
    if verbosity > 0:
        traceback.print_exc(file=sys.stderr)
    print(message, file=sys.stderr)
