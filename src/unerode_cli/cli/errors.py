"""Turn exceptions into one sentence on stderr and an exit code (DESIGN §5), and say which
files a failed or interrupted command had already written."""

from __future__ import annotations

import contextlib
import sys
import traceback
from collections.abc import Iterator

import typer

from unerode_cli.errors import InputError, RunFailure
from unerode_cli.io.paths import OutputPlan

EXIT_BAD_INPUT = 2
EXIT_RUNTIME = 1
EXIT_INTERRUPTED = 130


@contextlib.contextmanager
def reported_errors(verbosity: int) -> Iterator[OutputPlan]:
    """Run a command with a new output plan active (yielded): bad input → exit 2, a run that
    failed → exit 1 (the files it wrote are removed), anything else → exit 1; Ctrl-C → 130
    with the list of files written before it. A traceback only with ``-v``."""
    plan = OutputPlan()
    with plan.active():
        try:
            yield plan
        except (typer.Exit, typer.Abort):
            raise
        except InputError as exc:
            _say(_joined(f"error: {exc}", _written_note(plan)), verbosity)
            raise typer.Exit(EXIT_BAD_INPUT) from None
        except RunFailure as exc:
            _say(_joined(f"error: {exc}", _discard_written(plan)), verbosity)
            raise typer.Exit(EXIT_RUNTIME) from None
        except KeyboardInterrupt:
            print(_joined("interrupted", _written_note(plan) or "; no output was written."), file=sys.stderr)
            raise typer.Exit(EXIT_INTERRUPTED) from None
        except Exception as exc:  # noqa: BLE001 - the last line of defence of the CLI
            hint = "" if verbosity > 0 else " (run with -v for the traceback)"
            _say(_joined(f"error: {type(exc).__name__}: {exc}{hint}", _written_note(plan)), verbosity)
            raise typer.Exit(EXIT_RUNTIME) from None
        finally:
            plan.remove_own_temporaries()


def _joined(message: str, note: str) -> str:
    """``message`` followed by ``note`` (which starts with '; '), as one sentence."""
    return f"{message.rstrip('.')}{note}" if note else message


def _written_note(plan: OutputPlan) -> str:
    """'; it had written: a, b' naming the files already written ('' when none)."""
    written = plan.written
    if not written:
        return ""
    return (f"; {len(written)} file(s) had been written and are kept: {', '.join(map(str, written))} "
            "(rerun with --overwrite to replace them).")


def _discard_written(plan: OutputPlan) -> str:
    """Remove the files written by a run that failed; ' (removed …)' saying which."""
    removed = plan.discard_written()
    if not removed:
        return "; nothing was written."
    return f"; nothing is kept (removed {', '.join(map(str, removed))})."


def _say(message: str, verbosity: int) -> None:
    if verbosity > 0:
        traceback.print_exc(file=sys.stderr)
    print(message, file=sys.stderr)
