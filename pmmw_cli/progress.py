"""How the command line shows the library's progress records (`pmmw.io.progress`): a status line
rewritten in place on a terminal; when standard error is a file (a cluster job's log), a plain line
every ``every`` seconds and always the last one; other records as lines of their own (a
command's result on standard output, notes on standard error)."""

from __future__ import annotations

import logging
import sys

from pmmw.io.progress import RESULT, STATUS, log


class StatusHandler(logging.Handler):
    """Writes to the standard error of the moment (a test runner may swap it)."""

    def __init__(self, every: float = 5.0):
        super().__init__(logging.INFO)
        self.every = every  # [s]
        self.last = -float("inf")
        self.open = False  # a status line drawn on a terminal and not ended yet

    def emit(self, record: logging.LogRecord) -> None:
        err = sys.stderr
        msg = record.getMessage()
        status = getattr(record, STATUS, None)
        tty = err.isatty()
        if status is None:
            if self.open:
                err.write("\n")
                self.open = False
            print(msg, file=sys.stdout if getattr(record, RESULT, False) else err, flush=True)
            return
        elapsed, final = status
        if elapsed < self.last:  # a new job's clock
            self.last = -float("inf")
        if tty:
            err.write("\r" + msg + " " + ("\n" if final else ""))
            err.flush()
            self.open = not final
        elif elapsed - self.last >= self.every or final:
            print(msg, file=err, flush=True)
            self.last = elapsed


def install() -> None:
    """Show the library's progress on standard error (once per process)."""
    if not any(isinstance(h, StatusHandler) for h in log.handlers):
        log.addHandler(StatusHandler())
    log.setLevel(logging.INFO)
    log.propagate = False
