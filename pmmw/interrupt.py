"""SIGINT and SIGTERM end ``pmmw`` cleanly, at any moment.

`main`, the console entry point, installs the handlers before the command line (typer) is even
imported. The first SIGINT or SIGTERM raises `Interrupted` in the main thread wherever it is
(importing, resolving, starting workers, rendering, writing), so that the ``finally`` blocks on
the way out run: the render pool kills and reaps its workers, an atomic write removes its
temporary file. The CLI then prints one line and exits with status 128 + N: 130 for SIGINT, 143
for SIGTERM. Later signals are ignored, so that this clean-up is not cut short. The line says what
the command leaves behind (`outcome`: a render's finished tiles, ``pmmw po``'s "nothing written").
A compiled call holds the interpreter and delays the exception to its end: long computations are
cut into calls of a fraction of a second (`pmmw.physical_optics.solver.call_slices`).

An exception raised at an arbitrary point can be lost: an extension module being imported turns
it into an ImportError, a ``__del__`` can only print it. So `main` treats any exception that
follows a signal as the signal, a lost one ends the process at once (`sys.unraisablehook`), and
a watchdog ends it `GRACE_S` after the signal whatever the main thread is doing.

Render workers (`pmmw.trace.pool`) ignore SIGINT, which a terminal sends to the whole process
group: the parent alone reacts, and ends them. They die silently of SIGTERM (its default action).
"""

from __future__ import annotations

import importlib
import os
import signal
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

from pmmw import procfs

SIGNALS = (signal.SIGINT, signal.SIGTERM)

#: From a signal to the forced exit when the orderly one has not happened [s].
GRACE_S = 3.0

_received: int | None = None  # the first signal, once one came
_reported = False  # its line has been printed


class Interrupted(BaseException):
    """SIGINT or SIGTERM arrived.

    A BaseException, as KeyboardInterrupt is, so that ``except Exception`` does not swallow it;
    not a KeyboardInterrupt, which click would turn into "Aborted!" and status 1.
    """

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = int(signum)

    @property
    def status(self) -> int:
        """The shell's exit status for death by this signal."""
        return 128 + self.signum

    @property
    def message(self) -> str:
        word = "interrupted" if self.signum == signal.SIGINT else "terminated"
        return f"{word}: {_outcome}"


#: What the line says of a stopped render; other commands say what they leave (`outcome`).
RENDER_OUTCOME = "finished tiles are kept; run again with --resume to continue"
#: Commands with a line of their own from their start (`main` looks the command up before it imports
#: anything, so a signal during the imports already gets it).
COMMAND_OUTCOMES = {"po": "nothing written"}
_outcome = RENDER_OUTCOME


class _Restore:
    """Puts the outcome back as it was when left (`outcome` used as ``with``)."""

    def __init__(self, previous: str):
        self.previous = previous

    def __enter__(self) -> _Restore:
        return self

    def __exit__(self, *exc: object) -> None:
        global _outcome
        _outcome = self.previous


def outcome(text: str) -> _Restore:
    """Set what the line after ``interrupted:`` says of the command's outputs (e.g. ``pmmw po``:
    ``nothing written``), as the command goes. As ``with outcome(text):`` the line goes back to
    what it was after the block, so that a command run in the same process later (a notebook, a
    test) does not inherit it."""
    global _outcome
    previous, _outcome = _outcome, text
    return _Restore(previous)


def report(stop: Interrupted) -> None:
    """Print the one line that says how the run ended."""
    global _reported
    _reported = True
    print(stop.message, file=sys.stderr, flush=True)


def _handle(signum, frame):
    global _received
    if _received is not None:
        return
    _received = signum
    threading.Thread(target=_watchdog, daemon=True).start()
    raise Interrupted(signum)


def install() -> None:
    """Make the first SIGINT or SIGTERM raise `Interrupted` (in the main thread)."""
    for s in SIGNALS:
        signal.signal(s, _handle)


@contextmanager
def deferred():
    """Hold SIGINT and SIGTERM back during the block; one that came is handled at its end.

    For forking a worker (the child must not run the parent's handler before it installs its
    own, `as_worker`) and for ending workers (a clean-up cut in half would leave some running).
    """
    old = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def as_worker() -> None:
    """In a worker forked inside `deferred`: ignore SIGINT, die of SIGTERM, then let signals in."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, SIGNALS)


def _children() -> list[int]:
    """Process ids whose parent is this process (Linux /proc; none found elsewhere)."""
    me, pids = os.getpid(), []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        fields = procfs.stat_fields(stat.parent.name)  # None: it ended meanwhile
        try:
            if fields and int(fields[procfs.PPID]) == me:
                pids.append(int(stat.parent.name))
        except (ValueError, IndexError):
            continue
    return pids


def _exit_now() -> None:
    """Kill and reap the child processes, print the line (once), and end the process."""
    pids = _children()
    for pid in pids:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass
    for pid in pids:
        try:
            os.waitpid(pid, 0)
        except OSError:  # reaped by the main thread meanwhile
            pass
    stop = Interrupted(_received)
    if not _reported:
        report(stop)
    os._exit(stop.status)


def _watchdog():
    time.sleep(GRACE_S)
    _exit_now()


def _unraisable(hook_args, default=sys.unraisablehook):
    if isinstance(hook_args.exc_value, Interrupted):  # raised in a __del__ or callback: lost
        _exit_now()
    default(hook_args)


#: Compiled modules whose initialization must not be cut by a signal's exception: OpenImageIO's
#: nanobind aborts the process (SIGABRT, a "Critical nanobind error") when an exception lands
#: while it creates its enums; numpy turns it into an ImportError.
NATIVE_MODULES = ("numpy", "OpenImageIO")


def run(command) -> None:
    """Run ``command()`` (the typer app) as the process's main work: signal handlers installed, the
    native modules imported with signals held back, and a signal's `Interrupted` (or what it broke)
    ended with its one line and exit status; any other exception propagates."""
    install()
    sys.unraisablehook = _unraisable
    outcome(COMMAND_OUTCOMES.get(sys.argv[1] if len(sys.argv) > 1 else "", RENDER_OUTCOME))
    try:
        try:
            import_native()
            command()
        finally:  # the outcome is decided: a signal now would only garble the exit
            for s in SIGNALS:
                signal.signal(s, signal.SIG_IGN)
    except SystemExit:
        raise
    except BaseException:
        if _received is None:
            raise
        # raised by the signal, or by what it broke (an extension module's import turns it into
        # an ImportError): the finally blocks on the way here have cleaned up
        stop = Interrupted(_received)
        if not _reported:
            report(stop)
        sys.exit(stop.status)


def import_native() -> None:
    """Import `NATIVE_MODULES` with SIGINT and SIGTERM held back (`deferred`): a signal that comes
    meanwhile is raised as `Interrupted` right after, at a safe point."""
    with deferred():
        for name in NATIVE_MODULES:
            importlib.import_module(name)
