"""One writer per output folder: the lock that `pmmw render`, `pmmw sweep` and `pmmw po` hold.

A run that writes into a folder first creates ``<folder>/.pmmw-lock`` (``O_CREAT | O_EXCL``: of
two runs starting together exactly one succeeds) holding who it is: host, process id, the
process's start time, the command and a random token. A second writer finds it and is refused at
once with one line naming the holder. A lock is taken over only when its holder is certainly
gone: on this host, its process id is dead or belongs to a process started at another time (the
id was reused); on another host (a cluster sharing the folder), the holder has not refreshed the
lock's modification time (every `HEARTBEAT_S` seconds) for `REMOTE_STALE_S` seconds. The
takeover renames the stale lock away and checks that what it renamed is the one it judged stale
(two runs taking over together: the second one would have renamed the first one's fresh lock,
which it puts back), then creates its own.

The shards of one render (``pmmw render --shard I/N``) run together on purpose: each takes a
*shared* hold instead, a file ``.pmmw-lock.shard-<host>-<pid>-<token>`` of its own. A shard is
refused while a writer holds the folder, and a writer while a live shard does (each publishes its
own file first, then looks for the other kind, so two starting at once cannot both go on).

A holder checks that the lock is still its own before it commits outputs (`FolderLock.check`):
a run stopped (``Ctrl-Z``) for longer than `REMOTE_STALE_S` on a shared folder may have lost it.
"""

from __future__ import annotations

import json
import os
import re
import secrets
import socket
import sys
import threading
import time
from pathlib import Path

from pmmw import procfs
from pmmw.errors import EnvironmentProblem, UserError

LOCK_NAME = ".pmmw-lock"
SHARD_PREFIX = f"{LOCK_NAME}.shard-"
HEARTBEAT_S = 30.0  # [s] how often a holder refreshes its lock's modification time
REMOTE_STALE_S = 600.0  # [s] a lock of another host not refreshed for this long: its holder is gone
UNREADABLE_GRACE_S = 30.0  # [s] a lock still being written (empty) by its new holder counts as held
MAX_LOCK_BYTES = 65536  # a lock file is a few hundred bytes; more is not one of ours
_SHARD_RE = re.compile(re.escape(SHARD_PREFIX) + r"[^/]+-\d+-[0-9a-f]{16}$")


def process_start(pid: int) -> int | None:
    """The start time of process ``pid`` in clock ticks since boot (Linux ``/proc``), or None."""
    fields = procfs.stat_fields(pid)
    try:
        return int(fields[procfs.STARTTIME]) if fields else None
    except (ValueError, IndexError):
        return None


def _alive(pid: int, start: int | None) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # another user's process: alive
    now = process_start(pid)
    return start is None or now is None or now == start


def _holder_record(mode: str, command: str) -> dict:
    return {
        "kind": "pmmw lock",
        "mode": mode,
        "host": socket.gethostname(),
        "pid": os.getpid(),
        "start": process_start(os.getpid()),
        "command": command[:300],
        "since": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
        "token": secrets.token_hex(8),
    }


def _read(path: Path) -> tuple[dict | None, float | None]:
    """(record, modification time) of a lock file; (None, mtime) when unreadable; (None, None)
    when it is gone."""
    try:
        st = os.lstat(path)
        if st.st_size > MAX_LOCK_BYTES:
            return None, st.st_mtime
        with open(path, "rb") as f:
            rec = json.loads(f.read(MAX_LOCK_BYTES))
        return (rec if isinstance(rec, dict) else None), st.st_mtime
    except FileNotFoundError:
        return None, None
    except (OSError, ValueError):
        try:
            return None, os.lstat(path).st_mtime
        except OSError:
            return None, None


def holder_alive(rec: dict | None, mtime: float | None) -> bool:
    """Is the run behind a lock record still there (see the module docstring)?"""
    if mtime is None:
        return False
    if rec is None:  # being written right now, or garbage
        return time.time() - mtime < UNREADABLE_GRACE_S
    try:
        host, pid = str(rec["host"]), int(rec["pid"])
        start = rec.get("start")
        start = None if start is None else int(start)
    except (KeyError, TypeError, ValueError):
        return time.time() - mtime < UNREADABLE_GRACE_S
    if host == socket.gethostname():
        return _alive(pid, start)
    return time.time() - mtime < REMOTE_STALE_S


def describe(rec: dict | None) -> str:
    """``pmmw render (pid 1234 on host h, since ...: `pmmw render a.yaml`)`` for a message."""
    if not rec:
        return "another pmmw run (its lock file is unreadable)"
    what = "a shard of a render" if rec.get("mode") == "shard" else "another pmmw run"
    return (
        f"{what} (pid {rec.get('pid')} on host {rec.get('host')}, since {rec.get('since')}: "
        f"`{str(rec.get('command', '?'))[:120]}`)"
    )


def _create(path: Path, rec: dict) -> bool:
    """Create ``path`` holding ``rec`` if it does not exist; False if it does."""
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o644)
    except FileExistsError:
        return False
    with os.fdopen(fd, "w") as f:
        json.dump(rec, f)
        f.flush()
        os.fsync(f.fileno())
    return True


def _take_over(path: Path, seen: dict | None, seen_mtime: float) -> None:
    """Remove the stale lock ``path`` if it still is the one judged stale (record ``seen``)."""
    aside = path.with_name(f"{path.name}.stale-{os.getpid()}-{secrets.token_hex(4)}")
    try:
        os.rename(path, aside)
    except FileNotFoundError:
        return  # someone else took it over first
    rec, mtime = _read(aside)
    if rec == seen and (seen is not None or mtime == seen_mtime):
        os.unlink(aside)
        return
    try:  # a fresh lock of a run that took over just before us: put it back
        os.link(aside, path)
    except OSError:
        pass
    os.unlink(aside)


class FolderLock:
    """Hold ``folder`` for one run: ``with FolderLock(out_dir, mode="write"): ...``.

    Parameters
    ----------
    folder : Path
        The output folder (it must exist).
    mode : {"write", "shard"}
        ``write``: the only run writing there; ``shard``: one of the shards of a render, which
        share the folder with each other but not with a writer.
    command : str, optional
        What the holder is, for the message a refused run prints (default: this command line).
    what : str
        The argument or key that named the folder, for that message (``--out``, ``output.dir``).

    Raises
    ------
    UserError
        The folder is held by a live run (exit status 2: choose another folder or wait).
    """

    def __init__(
        self, folder: str | os.PathLike[str], *, mode: str = "write", command: str | None = None, what: str = "--out"
    ) -> None:
        if mode not in ("write", "shard"):
            raise ValueError(f"mode {mode!r}")
        self.folder = Path(folder)
        self.mode = mode
        self.what = what
        self.record = _holder_record(mode, command or " ".join(["pmmw", *sys.argv[1:]]))
        name = (
            LOCK_NAME
            if mode == "write"
            else f"{SHARD_PREFIX}{self.record['host']}-{self.record['pid']}-{self.record['token']}"
        )
        self.path = self.folder / name
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._pid = os.getpid()

    # -- taking and giving back -----------------------------------------------------------------
    def acquire(self) -> FolderLock:
        try:
            if self.mode == "write":
                self._acquire_write()
            else:
                self._acquire_shard()
        except OSError as e:
            from pmmw.io.rundir import os_problem

            raise os_problem(e, self.folder, "lock the output folder") from None
        self._thread = threading.Thread(target=self._heartbeat, name="pmmw-lock-heartbeat", daemon=True)
        self._thread.start()
        return self

    def _refuse(self, rec: dict | None) -> UserError:
        return UserError(
            f"the folder is in use by {describe(rec)}; wait for it to finish or choose another output folder",
            self.folder,
            self.what,
        )

    def _acquire_write(self) -> None:
        for _ in range(3):
            if _create(self.path, self.record):
                holder = self._live_shard()
                if holder is not None:
                    self._unlink_own()
                    raise self._refuse(holder)
                return
            rec, mtime = _read(self.path)
            if mtime is None:
                continue  # released between our two looks
            if holder_alive(rec, mtime):
                raise self._refuse(rec)
            _take_over(self.path, rec, mtime)
        raise self._refuse(_read(self.path)[0])

    def _acquire_shard(self) -> None:
        if not _create(self.path, self.record):  # our own unique name: cannot exist
            raise EnvironmentProblem("a lock file of this process exists already", self.path)
        for _ in range(3):
            rec, mtime = _read(self.folder / LOCK_NAME)
            if mtime is None or not holder_alive(rec, mtime):
                if mtime is not None:
                    _take_over(self.folder / LOCK_NAME, rec, mtime)
                    continue
                return
            self._unlink_own()
            raise self._refuse(rec)
        self._unlink_own()
        raise self._refuse(_read(self.folder / LOCK_NAME)[0])

    def _live_shard(self) -> dict | None:
        """The record of a live shard holding the folder, if any; dead shards' files are removed."""
        for p in self.folder.iterdir():
            if not _SHARD_RE.match(p.name) or p == self.path:
                continue
            rec, mtime = _read(p)
            if holder_alive(rec, mtime):
                return rec or {}
            if mtime is not None and not p.is_symlink():
                p.unlink(missing_ok=True)
        return None

    def _unlink_own(self) -> None:
        rec, _ = _read(self.path)
        if rec is not None and rec.get("token") == self.record["token"]:
            self.path.unlink(missing_ok=True)

    def release(self) -> None:
        if os.getpid() != self._pid:  # a forked child unwinding: the lock is its parent's
            return
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        try:
            self._unlink_own()
        except OSError:
            pass

    def held(self) -> bool:
        """Is the lock file still this run's?"""
        rec, _ = _read(self.path)
        return rec is not None and rec.get("token") == self.record["token"]

    def check(self) -> None:
        """Raise `EnvironmentProblem` when another run took the lock over (this run was stopped
        longer than the lock's staleness limit): its outputs must not be committed."""
        if not self.held():
            raise EnvironmentProblem(
                "another pmmw run took over the lock of this output folder while this "
                "one was stopped; nothing more is written",
                self.folder,
            )

    def _heartbeat(self) -> None:
        while not self._stop.wait(HEARTBEAT_S):
            try:
                if self.held():
                    os.utime(self.path)
            except OSError:
                pass

    def __enter__(self) -> FolderLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


def output_lock(folder: str | os.PathLike[str], what: str = "--out", mode: str = "write") -> FolderLock:
    """`FolderLock` of ``folder``, which is created first (an `OSError` becomes one line)."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        from pmmw.io.rundir import os_problem

        raise os_problem(e, folder, "create the output folder") from None
    return FolderLock(folder, mode=mode, what=what)
