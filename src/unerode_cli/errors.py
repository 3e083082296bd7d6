"""Exceptions that the command line turns into exit codes.

``InputError`` is bad usage, bad input or a bad spec (exit code 2); its message is one
sentence meant for the user. Anything else that escapes is a runtime failure (exit code 1).
"""


class InputError(Exception):
    """Bad usage, input file, parameter or spec: reported in one sentence, exit code 2."""
