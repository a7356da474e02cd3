"""Errors a user can fix, and the wording helpers their messages share.

Every problem with a file, field, row or option is raised as `InputError` with one line that names the file,
the field or row, and what was expected; the command line prints it and exits with status 2.
"""
from __future__ import annotations

import difflib

MAX_MESSAGE = 600          # characters of an error message (a quoted value is shortened, never the meaning)


class InputError(ValueError):
    """Bad user input: the message is one line naming the file, the field or row, and what was expected.

    The line is guaranteed: line breaks in the message (from a key or value of the file) are shown as '\\n'
    and a message longer than MAX_MESSAGE is shortened in the middle."""

    def __str__(self):
        text = super().__str__().replace("\r", "\\r").replace("\n", "\\n")
        if len(text) > MAX_MESSAGE:
            half = MAX_MESSAGE // 2
            text = text[:half] + " … " + text[-half:]
        return text


class RunError(RuntimeError):
    """A run that could not finish through no fault of the input (a cluster's scheduler lost): one line,
    saying what is kept; the command line prints it and exits with status 1."""


def suggest(word: str, options) -> str:
    """' (did you mean 'x'?)' for the option nearest to a misspelt word, or ''."""
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def shorten(text, n: int = 60) -> str:
    """A value as quoted in a message: at most n characters."""
    text = str(text)
    return text if len(text) <= n else text[: n - 1] + "…"
