"""Progress and notes of long jobs (`pmmw render`, `pmmw sweep`), as records of the ``pmmw``
logger: the library never prints.

`say` is a line of its own (the kernels being compiled, the tiles a ``--resume`` found, a render's
summary); a
`StatusLine` reports a job's progress (``tiles 12/64 ...``), its records marked with the job's
elapsed time and whether it is the last (``record.pmmw_status = (elapsed, final)``). The command
line shows both (`pmmw_cli.progress`: a status line rewritten in place on a terminal, a plain
line every few seconds in a log file); a notebook sees them only when it asks, e.g.
``logging.basicConfig(level=logging.INFO)``, as Python's `logging` leaves INFO records unshown.
"""

from __future__ import annotations

import logging

log = logging.getLogger("pmmw")
#: The attribute of a status record: (elapsed [s], final)
STATUS = "pmmw_status"
#: The attribute of a record that is the command's result (a render's summary): standard output
RESULT = "pmmw_result"


def say(msg: str, result: bool = False) -> None:
    """A line of its own, at once; ``result`` for the line that states what a command made (the
    command line writes it on standard output, the notes on standard error)."""
    log.info(msg, extra={RESULT: True} if result else None)


class StatusLine:
    """The progress of one job, as `logging` records the command line draws as one line."""

    def say(self, msg: str) -> None:
        """A line of its own, at once (on a terminal it does not overwrite the status line)."""
        say(msg)

    def show(self, msg: str, elapsed: float, final: bool) -> None:
        """Show ``msg`` at ``elapsed`` seconds into the job; ``final`` for the last update."""
        log.info(msg, extra={STATUS: (float(elapsed), bool(final))})
