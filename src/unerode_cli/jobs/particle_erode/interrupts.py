"""Ctrl-C during particle-erode's numba kernels, turned into a clean ``KeyboardInterrupt``.

Python raises ``KeyboardInterrupt`` at the next bytecode it runs after SIGINT. When that bytecode
is inside numba's dispatcher (typing the arguments of a kernel call, loading or compiling a
kernel), the dispatcher's C code swallows the exception and numba reports a ``SystemError``
("returned a result with an exception set") or a broken library instead: the command would say
that the run failed unexpectedly (exit code 1) rather than that it was interrupted (130).

:func:`deferred_interrupt` replaces the SIGINT handler while the particles run with one that
only records the signal; the run asks :func:`Deferred.check` between batches of kernels, which
raises ``KeyboardInterrupt`` there, in plain Python code. A second Ctrl-C raises at once (the
user insists). An exception caused by a Ctrl-C that still escapes (a second Ctrl-C, or a SIGINT
outside the deferred part) is raised as the interrupt it is by the executor
(:func:`unerode_cli.run.unexpected.interrupt_cause`).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field

from unerode_cli.run.unexpected import interrupt_cause

__all__ = ["Deferred", "deferred_interrupt", "interrupt_cause"]


@dataclass
class Deferred:
    """The SIGINTs received while deferred (``signals``, a count)."""

    signals: int = field(default=0)

    def check(self) -> None:
        """Raise ``KeyboardInterrupt`` when a SIGINT was received."""
        if self.signals:
            raise KeyboardInterrupt

    def _handler(self, signum: int, frame: object) -> None:
        self.signals += 1
        if self.signals > 1:
            raise KeyboardInterrupt


@contextlib.contextmanager
def deferred_interrupt() -> Iterator[Deferred]:
    """Record SIGINT instead of raising at once, for the duration of the block (see the module
    docstring); the previous handler is put back on leaving. Outside the main thread, or when
    SIGINT does not raise ``KeyboardInterrupt`` (a pipeline or ensemble that handles signals
    itself), the handler is left alone and :meth:`Deferred.check` never raises."""
    deferred = Deferred()
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield deferred
        return
    previous = signal.signal(signal.SIGINT, deferred._handler)
    try:
        yield deferred
    finally:
        signal.signal(signal.SIGINT, previous)
