"""Exceptions that the command line turns into exit codes.

``InputError`` is bad usage, bad input or a bad spec (exit code 2); its message is one
sentence meant for the user. ``RunFailure`` is a run that started but could not finish (it
diverged, say): one sentence too, exit code 1; ``WriteFailure`` is the RunFailure of an output
that could not be written (a full disk, a lost permission), after which the files already
written are kept and listed. Anything else that escapes is a runtime failure (exit code 1, its
own words without the exception's type).
"""


class InputError(Exception):
    """Bad usage, input file, parameter or spec: reported in one sentence, exit code 2."""


class RunFailure(Exception):
    """A run that could not finish (e.g. its elevations diverged): one sentence, exit code 1."""


class WriteFailure(RunFailure):
    """An output that could not be written (the file system is full, a permission was lost):
    one sentence, exit code 1; the complete files written before it are kept and listed."""
