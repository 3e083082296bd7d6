"""Turn exceptions into one sentence on stderr and an exit code (DESIGN §5), and say which
files a failed or interrupted command had already written.

No message names a Python exception class: an unexpected exception is said as "the run failed
unexpectedly: MESSAGE" (its traceback with ``-v``)."""

from __future__ import annotations

import contextlib
import select
import sys
import traceback
import warnings
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import typer

from unerode_cli.errors import InputError, RunFailure, WriteFailure

if TYPE_CHECKING:
    from unerode_cli.io.paths import OutputPlan

EXIT_BAD_INPUT = 2
EXIT_RUNTIME = 1
EXIT_INTERRUPTED = 130

@contextlib.contextmanager
def reported_errors(verbosity: int) -> Iterator[OutputPlan]:
    """Run a command with a new output plan active (yielded): bad input → exit 2, a run that
    failed → exit 1 (the files it wrote are removed; those of a run whose output could not be
    written are kept and listed), anything else → exit 1; Ctrl-C → 130 with the list of files
    written before it; a standard output closed by its reader is left to the app (a quiet end).
    Each is one sentence without a Python class name; a traceback only
    with ``-v``. Python warnings raised meanwhile are shown as ``warning: MESSAGE.``."""
    from unerode_cli.io.paths import OutputPlan  # opens the io package only when a command runs

    plan = OutputPlan()
    with plan.active(), warnings.catch_warnings():
        warnings.showwarning = _show_warning
        try:
            yield plan
        except (typer.Exit, typer.Abort):
            raise
        except InputError as exc:
            _say(_joined(f"error: {exc}", _written_note(plan)), verbosity)
            raise typer.Exit(EXIT_BAD_INPUT) from None
        except WriteFailure as exc:
            _say(_joined(f"error: {exc}", _written_note(plan) or "; nothing was written."), verbosity)
            raise typer.Exit(EXIT_RUNTIME) from None
        except RunFailure as exc:
            _say(_joined(f"error: {exc}", _discard_written(plan)), verbosity)
            raise typer.Exit(EXIT_RUNTIME) from None
        except KeyboardInterrupt:
            _say(_joined("interrupted", _written_note(plan) or "; no output was written."), 0)
            raise typer.Exit(EXIT_INTERRUPTED) from None
        except Exception as exc:  # noqa: BLE001 - the last line of defence of the CLI
            if isinstance(exc, BrokenPipeError) and stdout_closed():
                raise                     # the app ends quietly (its reader closed the pipe)
            from unerode_cli.run.unexpected import unexpected

            hint = "" if verbosity > 0 else " (run with -v for the details)"
            _say(_joined(f"error: {unexpected(exc)}{hint}", _written_note(plan)), verbosity)
            raise typer.Exit(EXIT_RUNTIME) from None
        finally:
            plan.remove_own_temporaries()


def stdout_closed() -> bool:
    """Whether the reader of standard output has gone (a pipe whose other end is closed)."""
    try:
        poller = select.poll()
        poller.register(sys.stdout.fileno(), 0)         # errors and hang-ups are always reported
        return any(event & (select.POLLERR | select.POLLHUP) for _, event in poller.poll(0))
    except (AttributeError, OSError, ValueError):       # no file descriptor behind sys.stdout
        return False


def _joined(message: str, note: str) -> str:
    """``message`` followed by ``note`` (which starts with '; '), as one sentence."""
    return f"{message.rstrip('.')}{note}" if note else message


def _written_note(plan: OutputPlan) -> str:
    """'; N file(s) had been written and are kept: a, b (rerun with …)' naming each file written
    once ('' when none); the rerun hint is the job's --resume where that continues the run (it
    left a checkpoint), else --overwrite."""
    written = plan.written_once()
    if not written:
        return ""
    if plan.can_resume():
        hint = f"rerun with {plan.resume_flag} to continue where it stopped"
    else:
        hint = "rerun with --overwrite to replace them"
    return f"; {len(written)} file(s) had been written and are kept: {', '.join(map(str, written))} ({hint})."


def _discard_written(plan: OutputPlan) -> str:
    """Remove the files written by a run that failed; ' (removed …)' saying which."""
    removed = plan.discard_written()
    if not removed:
        return "; nothing was written."
    return f"; nothing is kept (removed {', '.join(map(str, removed))})."


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: Any = None, line: str | None = None) -> None:
    """Show a Python warning as ``warning: MESSAGE.`` on stderr: its own words (first line),
    without its class, file or line."""
    from unerode_cli.run.unexpected import without_class_names

    lines = [text.strip() for text in str(message).splitlines() if text.strip()]
    text = without_class_names(lines[0] if lines else "").rstrip(".")
    if text:
        print(f"warning: {text}.", file=file or sys.stderr)


def _say(message: str, verbosity: int) -> None:
    """Print ``message`` as one sentence (one line, a full stop at its end, no class name) on
    stderr, after the traceback with ``-v``."""
    from unerode_cli.run.unexpected import without_class_names

    if verbosity > 0:
        traceback.print_exc(file=sys.stderr)
    text = without_class_names(" ".join(message.split()))
    if not text.endswith((".", "?", "!")):
        text += "."
    print(text, file=sys.stderr)
