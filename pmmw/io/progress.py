"""One progress line for `pmmw render` and `pmmw sweep`, for a person or a log file."""

from __future__ import annotations

import sys


class StatusLine:
    """Rewritten in place on a terminal; when standard error is a file (a cluster job's log), a
    plain line every ``every`` seconds and always the last one."""

    def __init__(self, every: float = 5.0):
        self.every = every  # [s]
        self.tty = sys.stderr.isatty()
        self.last = -float("inf")

    def say(self, msg: str) -> None:
        """A line of its own, at once (on a terminal it does not overwrite the status line)."""
        print(msg, file=sys.stderr, flush=True)

    def show(self, msg: str, elapsed: float, final: bool) -> None:
        """Show ``msg`` at ``elapsed`` seconds into the job; ``final`` for the last update."""
        if self.tty:
            sys.stderr.write("\r" + msg + " " + ("\n" if final else ""))
            sys.stderr.flush()
        elif elapsed - self.last >= self.every or final:
            print(msg, file=sys.stderr, flush=True)
            self.last = elapsed
