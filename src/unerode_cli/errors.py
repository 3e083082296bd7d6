"""Exceptions that the command line turns into exit codes.

``InputError`` is bad usage, bad input or a bad spec (exit code 2); its message is one
sentence meant for the user. ``RunFailure`` is a run that started but could not finish (it
diverged, say): one sentence too, exit code 1. Anything else that escapes is a runtime failure
(exit code 1, with the exception's type).
"""


class InputError(Exception):
    """Bad usage, input file, parameter or spec: reported in one sentence, exit code 2."""


class RunFailure(Exception):
    """A run that could not finish (e.g. its elevations diverged): one sentence, exit code 1."""
