"""Memory an input will take, checked before it is taken.

Every input that drives an allocation is sized from what costs nothing to read (an image's
header, a file's size, a sweep's axis specs, a mesh's facet count and the frequency) and refused
before the allocation when it exceeds a stated limit or the memory the machine has available
(Linux ``MemAvailable``: what the system can give without swapping). The refusal is a
`UserError` (exit status 2) naming the input, by file and key or by option, and the limit. The
whole render is estimated by `pipeline.estimate_resources` and refused there by
`pipeline.check_memory` (a `UserError` too).

The per-item costs of each estimate are measured peaks with a margin, stated where they are
defined (`pmmw.io.exr`, `pmmw.scene.geometry`, `pmmw.physical_optics.command`).
"""

from __future__ import annotations

import contextlib
import contextvars
import ctypes
import gc

from pmmw.errors import UserError

GB = 1e9

# a command's option that lets its user go past the memory checks (render's --force), and
# whether it was given: set by the command around its work (`overridable`)
_OVERRIDE: contextvars.ContextVar = contextvars.ContextVar("pmmw_memory_override", default=(None, False))


def available_memory() -> float | None:
    """Memory the system can give without swapping [bytes] (Linux MemAvailable), or None."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    return None


@contextlib.contextmanager
def overridable(option: str, force: bool):
    """Within: `check_fits` names ``option`` as the way past a refusal and, when ``force``,
    lets the allocation go ahead (``pmmw render --force`` reading a large mesh or sky texture)."""
    token = _OVERRIDE.set((option, bool(force)))
    try:
        yield
    finally:
        _OVERRIDE.reset(token)


def check_fits(
    need: float, what: str, *, file=None, key=None, remedy: str = "", force: bool = False, option: str | None = None
) -> None:
    """Refuse (`UserError`) an allocation of about ``need`` bytes beyond the available memory.

    Parameters
    ----------
    need : float
        Estimated peak memory of the step [bytes], an upper bound.
    what : str
        The step, for the message, e.g. ``"reading this 16000 x 8000 image"``.
    file, key : optional
        Where the input is named (the `UserError`'s location).
    remedy : str
        What to do instead, e.g. ``"use a smaller texture"``.
    force, option : optional
        The command's own way past the check (``pmmw po --force``); otherwise that of the
        enclosing `overridable`, if any.
    """
    free = available_memory()
    if option is None:
        option, force = _OVERRIDE.get()
    if free is None or need <= free or force:
        return
    past = f" (or pass {option} to try anyway)" if option else ""
    raise UserError(
        f"{what} needs about {gigabytes(need)} GB of memory and {gigabytes(free)} GB are available"
        + (f": {remedy}" if remedy else "")
        + past,
        file=file,
        key=key,
    )


def gigabytes(nbytes: float) -> str:
    """``nbytes`` in GB for a message: 3 significant digits, whole numbers from 1000 GB on."""
    return f"{nbytes / GB:.3g}" if nbytes < 1e3 * GB else f"{nbytes / GB:,.0f}"


def release_freed_memory() -> None:
    """Hand back to the system what a large read left freed in this process (collect the reader's
    cycles, then glibc's ``malloc_trim``): a mesh reader's text and lists, some 400 B per
    triangle of an OBJ, stayed resident otherwise through the whole render (and were inherited by
    every worker). Nothing beyond the collection where the C library has no ``malloc_trim``."""
    gc.collect()
    try:
        ctypes.CDLL(None).malloc_trim(ctypes.c_size_t(0))
    except (AttributeError, OSError):  # pragma: no cover - not glibc
        pass
