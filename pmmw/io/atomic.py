"""Atomic file writes: write a hidden temporary file beside the target, then rename it over.

A reader (or a crash) never sees a truncated file: the destination holds either its old content
or the complete new one. The temporary file lives in the destination's directory, so the final
``os.replace`` is a rename within one file system, and keeps the destination's suffix, so writers
that choose a format by extension (OpenImageIO, ``np.savez``) still work.
"""

from __future__ import annotations

import os
import secrets
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from pmmw import timings


def _fsync_path(path: Path, *, directory: bool = False) -> None:
    """Flush a file (or a directory entry) to disk where the platform allows it."""
    flags = os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0)
    try:
        fd = os.open(path, flags)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # some file systems and platforms refuse fsync on a directory
        pass
    finally:
        os.close(fd)


_DEFERRED = threading.local()  # .paths: the files `atomic_path` wrote inside `synced_together`


@contextmanager
def synced_together() -> Iterator[None]:
    """Within the block, `atomic_path` leaves out its fsyncs and notes its files; on a normal exit
    every noted file is fsync'ed at once (one thread each: the disk's flushes overlap, a render's
    EXR and previews in a quarter of the time one after another), then each of their folders once
    (the phase ``outputs flushed to disk`` of `pmmw.timings`).

    For files that nobody reads before the block ends (a render's staged outputs, `io.rundir.
    Staging`, moved into place after it): until then a crash of the machine may leave them torn.
    A block inside another is the outer one's.
    """
    if getattr(_DEFERRED, "paths", None) is not None:
        yield
        return
    _DEFERRED.paths = []
    try:
        yield
        paths = list(_DEFERRED.paths)
    finally:
        _DEFERRED.paths = None
    if not paths:
        return
    from concurrent.futures import ThreadPoolExecutor

    with timings.phase("outputs flushed to disk"), ThreadPoolExecutor(min(len(paths), 16)) as pool:
        list(pool.map(_fsync_path, paths))
        for folder in dict.fromkeys(p.parent for p in paths):
            _fsync_path(folder, directory=True)


def temp_path_for(path: str | os.PathLike) -> Path:
    """A fresh hidden name beside ``path``: ``.<stem>.tmp-<pid>-<random><suffix>``."""
    path = Path(path)
    return path.with_name(f".{path.stem}.tmp-{os.getpid()}-{secrets.token_hex(4)}{path.suffix}")


@contextmanager
def atomic_path(path: str | os.PathLike, durable: bool = True) -> Iterator[Path]:
    """Yield a temporary path to write; on success it replaces ``path`` atomically.

    The parent directory is created. The caller writes the whole file at the yielded path (it
    does not exist yet). On normal exit the file is fsync'ed and renamed onto ``path``; if the
    block raises, the temporary file is removed, ``path`` is left as it was, and the exception
    propagates. ``durable=False`` skips the fsyncs (the rename stays atomic): for files whose
    reader checks them and redoes them when a crash of the machine left them empty or torn. Inside
    `synced_together` the fsyncs come at the end of its block, for all its files at once.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_path_for(path)
    deferred = getattr(_DEFERRED, "paths", None) if durable else None
    try:
        yield tmp
        if durable and deferred is None:
            _fsync_path(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    if deferred is not None:
        deferred.append(path)  # fsync'ed with the others at the end of `synced_together`
    elif durable:
        _fsync_path(path.parent, directory=True)


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns ``path`` as a Path."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
    return Path(path)


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8, newlines as given) to ``path`` atomically."""
    return write_bytes_atomic(path, text.encode("utf-8"))


def save_npz_atomic(path: str | os.PathLike, *, durable: bool = True, **arrays: ArrayLike) -> Path:
    """``np.savez`` (uncompressed) of the keyword arrays to ``path`` atomically.

    The file is written through an open file object, so numpy never appends ``.npz`` to the
    name: ``path`` is used exactly as given.
    """
    with atomic_path(path, durable) as tmp:
        with open(tmp, "wb") as f:
            np.savez(f, allow_pickle=True, **arrays)  # numpy's default, named: no array can take its place
    return Path(path)
