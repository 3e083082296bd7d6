"""One sentence for an exception no check foresaw, without Python or GDAL class names: what the
command line, a pipeline step and an ensemble member say of it; and whether an exception was a
Ctrl-C in disguise."""

from __future__ import annotations

import re

from unerode_cli.io.paths import os_error_reason

#: A Python exception class name as exception texts quote it (``ValueError: ``,
#: ``numba.core.errors.TypingError``, ``rasterio.errors.RasterioIOError``), and GDAL's error
#: classes (``CPLE_OpenFailedError``), never part of a message.
_CLASS_NAME = re.compile(r"\b(?:[A-Za-z_]\w*\.)*"
                         r"(?:[A-Z]\w*(?:Error|Exception|Exit|Interrupt|Warning)|CPLE_\w+)\b"
                         r"(?:\(\))?:?\s*")



def unexpected(exc: BaseException) -> str:
    """One sentence for an exception no check foresaw: what failed and the exception's own
    words (first line, without class names); an OSError says what the system said of which
    file."""
    if isinstance(exc, OSError):
        detail = os_error_reason(exc)
    else:
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        detail = lines[0] if lines else ""
    detail = without_class_names(detail).rstrip(".")
    return f"the run failed unexpectedly: {detail}" if detail else "the run failed unexpectedly"


def without_class_names(text: str) -> str:
    """``text`` with every Python exception class name (and GDAL error class) taken out."""
    return re.sub(r"\s{2,}", " ", _CLASS_NAME.sub("", text)).strip()


def interrupt_cause(exc: BaseException) -> bool:
    """Whether ``exc`` or an exception in its chain of causes and contexts is a
    ``KeyboardInterrupt``: Python raises it at the next bytecode after SIGINT, and when that
    bytecode is inside numba's dispatcher (typing a kernel's arguments, loading a kernel) numba
    reports a ``SystemError`` caused by it instead."""
    seen: set[int] = set()
    current: BaseException | None = exc
    while current is not None and id(current) not in seen:
        if isinstance(current, KeyboardInterrupt):
            return True
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return False
