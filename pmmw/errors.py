"""User-facing errors and warnings.

A `UserError` is a problem with the user's input (scenario, asset, material, command line). The
CLI prints it as one paragraph, ``error: FILE: KEY.PATH: message``, and exits with status 2; it
never shows a traceback. An `EnvironmentProblem` (the machine stopped the job) prints the same
way with status 1. Everything else is a bug and may show one.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path


class UserError(Exception):
    """An error in the user's input, located by file and dotted key path.

    Parameters
    ----------
    message : str
        What is wrong and what was expected.
    file : str or Path, optional
        The file the problem is in (scenario, mesh, material database, texture).
    key : str, optional
        Dotted key path inside that file, e.g. ``materials.runway.eps`` or ``scene[2].mesh``.
    """

    exit_status = 2
    MAX_MESSAGE = 600  # characters: a huge value quoted in a message is cut, not printed whole

    def __init__(self, message: str, file: str | Path | None = None, key: str | None = None):
        message = _one_line(str(message))
        if len(message) > self.MAX_MESSAGE:
            message = f"{message[: self.MAX_MESSAGE]}... ({len(message):,} characters in all)"
        super().__init__(message)
        self.message = message
        self.file = _one_line(str(file)) if file is not None else None
        self.key = _one_line(str(key)) if key is not None else None

    def __str__(self) -> str:
        parts = [p for p in (self.file, self.key) if p]
        return ": ".join(parts + [self.message])


def _one_line(text: str) -> str:
    """``text`` as one printable line: line breaks and other control characters (a user's file
    name, key or value can hold any) written as escapes (``\\n``, ``\\x1b``)."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


class UserErrors(UserError):
    """Several user errors collected at once (parse everything, then report everything)."""

    def __init__(self, errors: list[UserError]):
        self.errors = list(errors)
        super().__init__("; ".join(str(e) for e in self.errors))

    def __str__(self) -> str:
        if len(self.errors) == 1:
            return str(self.errors[0])
        return f"{len(self.errors)} problems:\n" + "\n".join(f"  - {e}" for e in self.errors)


class EnvironmentProblem(UserError):
    """The machine, not the input, stopped the job: an output folder that cannot be written, a
    full or read-only disk, a worker killed for memory. Printed like a `UserError` (one line naming
    the path or the tile and the cause) but with exit status 1."""

    exit_status = 1


class PmmwWarning(UserWarning):
    """A result to read with care (a material outside its stated range, a region too noisy to
    compare, a mesh that is not watertight): issued with `warnings.warn`, so a notebook can filter
    it or make it an error (``warnings.simplefilter("error", pmmw.PmmwWarning)``); the command line
    prints it as one ``warning: ...`` line (`show_warnings_as_lines`)."""


_WARNINGS: list[str] = []


def warn(message: str) -> None:
    """Record a warning for the report (`collected_warnings`) and issue it once as a `PmmwWarning`."""
    if message not in _WARNINGS:
        _WARNINGS.append(message)
        warnings.warn(message, PmmwWarning, stacklevel=2)


def show_warnings_as_lines() -> None:
    """For the command line: every distinct `PmmwWarning` as one ``warning: MESSAGE`` line on
    stderr (Python's own format names a file and line of pmmw's code); other warnings as before."""
    default = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, PmmwWarning):
            print(f"warning: {message}", file=sys.stderr)
        else:
            default(message, category, filename, lineno, file, line)

    warnings.showwarning = show
    warnings.simplefilter("always", PmmwWarning)  # `warn` already gives each message once


def collected_warnings() -> list[str]:
    """Warnings recorded so far in this process, in order."""
    return list(_WARNINGS)


def clear_warnings() -> None:
    _WARNINGS.clear()


def exception_text(e: BaseException, limit: int = 1500) -> str:
    """The end of ``e``'s traceback as text, at most ``limit`` characters: what a Dask task returns
    instead of raising (an exception object whose traceback does not pickle hangs the client)."""
    import traceback

    return "".join(traceback.format_exception(e)[-4:])[-limit:].strip()
