"""Wall-clock phases of a command, measured from the start of its process (``pmmw render --timings``).

The library records and never prints: `mark` notes the moment a step is reached, `phase` the
seconds a step takes; the command line prints `lines` at the end. Recording is always on and
costs a clock read per step (a few per render), so the figures are the same with or without
``--timings``.
"""

from __future__ import annotations

import contextlib
import os
import time

from pmmw import procfs

__all__ = ["AFTER_TRACE", "add", "clear", "lines", "mark", "phase", "process_start", "recorded"]

#: The phases of a render after its trace: what the image costs beyond its rays.
AFTER_TRACE = (
    "imager model",
    "region statistics",
    "EXR",
    "previews",
    "channel statistics",
    "report",
    "outputs flushed to disk",
    "outputs moved into place",
    "tiles removed",
)

_MARKS: list[tuple[str, float]] = []  # (step, seconds since the process started)
_PHASES: dict[str, float] = {}  # step -> seconds, summed over repeats (one per frequency)


def _started_ago() -> float | None:
    """Seconds since this process started (Linux: its start in clock ticks after boot, from
    ``/proc``, against the boot-time clock: to a tick, 10 ms); None where that cannot be read."""
    fields = procfs.stat_fields(os.getpid())
    if fields is None:
        return None
    try:
        ticks = int(fields[procfs.STARTTIME])  # start time after boot [ticks]
        return time.clock_gettime(time.CLOCK_BOOTTIME) - ticks / os.sysconf("SC_CLK_TCK")
    except (ValueError, IndexError, AttributeError, OSError):
        return None


def process_start() -> float:
    """The wall-clock time [s since the epoch] this process started (Linux: to a clock tick;
    elsewhere the first import of this module, a lower bound on the time since the start)."""
    ago = _started_ago()
    return _IMPORTED if ago is None else time.time() - ago


_IMPORTED = time.time()


def _since_start() -> float:
    ago = _started_ago()
    return time.time() - _IMPORTED if ago is None else ago


def clear() -> None:
    """Forget what was recorded (a command's start)."""
    _MARKS.clear()
    _PHASES.clear()


def mark(step: str) -> None:
    """Note that ``step`` is reached now (the first time only: one render's first ray)."""
    if all(s != step for s, _ in _MARKS):
        _MARKS.append((step, _since_start()))


def add(step: str, seconds: float) -> None:
    """Add ``seconds`` [s] to ``step`` (a phase timed elsewhere: in a worker process)."""
    _PHASES[step] = _PHASES.get(step, 0.0) + seconds


@contextlib.contextmanager
def phase(step: str):
    """Add the seconds the ``with`` block takes to ``step``."""
    t0 = time.perf_counter()
    try:
        yield
    finally:
        add(step, time.perf_counter() - t0)


def recorded() -> tuple[list[tuple[str, float]], dict[str, float]]:
    """The marks (step, seconds since the process started) in order, and the phases {step: seconds}."""
    return list(_MARKS), dict(_PHASES)


def lines() -> list[str]:
    """The recorded marks and phases as lines for a person, e.g. ``first ray at 0.42 s``."""
    marks, phases = recorded()
    out = [f"{step + ' at':<28s}{t:7.3f} s after the process started" for step, t in marks]
    out += [f"{step:<28s}{t:7.3f} s" for step, t in phases.items()]
    after = [t for s, t in phases.items() if s in AFTER_TRACE]
    if after:
        out.append(f"{'after the trace, together':<28s}{sum(after):7.3f} s")
    return out
