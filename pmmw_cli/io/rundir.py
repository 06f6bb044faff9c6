"""The output folder of a render: checked before any work, written together or not at all.

`check_outputs` runs before a single ray is traced: the folder can be created and written, no
output would replace a file the render reads, every file name fits the file system, and the disk
has room. `Staging` then collects one render's files (EXR, previews, reports) in a hidden folder
beside their destinations and moves them into place only when every one of them was written; the
reports go last, so a report always describes the EXR beside it. A failure (disk full, a
``previews`` path that is a file, an interrupt) leaves the previous outputs as they were.

Operating-system failures become `EnvironmentProblem` (exit status 1) naming the path and the
cause in words (`os_problem`).
"""

from __future__ import annotations

import errno
import os
import secrets
import shutil
import socket
from pathlib import Path

from pmmw_cli.errors import EnvironmentProblem, UserError

_CAUSES = {
    errno.ENOSPC: "no space left on the device",
    errno.EDQUOT: "disk quota exceeded",
    errno.EROFS: "the file system is read-only",
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.ENOTDIR: "a part of the path is a file, not a folder",
    errno.EISDIR: "is a folder",
    errno.EEXIST: "already exists",
    errno.ENAMETOOLONG: "the name is too long for the file system",
    errno.EIO: "input/output error (a failing disk or network file system)",
}


def os_problem(e: OSError, path, doing: str) -> EnvironmentProblem:
    """An `OSError` as one line: ``PATH: cannot DOING: CAUSE``."""
    cause = _CAUSES.get(e.errno) or e.strerror or str(e)
    return EnvironmentProblem(f"cannot {doing}: {cause}", file=e.filename or path)


def _name_max(folder: Path) -> int:
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        return 255


def _path_max(folder: Path) -> int:
    try:
        return os.pathconf(folder, "PC_PATH_MAX")
    except (OSError, ValueError, AttributeError):
        return 4096


def _exists(p: Path) -> bool:
    try:
        return p.exists()
    except OSError:  # e.g. a name too long to look up
        return False


def _same_file(a: Path, b: Path) -> bool:
    if a == b:
        return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


STAGING_PREFIX = ".pmmw-staging-"
TEMP_NAME_EXTRA = 32  # characters `atomic.temp_path_for` adds to a name (".", ".tmp-<pid>-<hex>")


def check_outputs(out_dir: Path, outputs, inputs, *, key: str = "output.dir", disk_bytes: int = 0,
                  force: bool = False) -> None:
    """Refuse, before rendering, what would fail or do harm after it.

    Parameters
    ----------
    out_dir : Path
        The output folder (created here).
    outputs : iterable of str
        File names relative to ``out_dir`` that the render will write.
    inputs : iterable of Path
        Every file the render reads.
    disk_bytes : int
        Room the render needs on the output disk (tiles and images); refused beyond the free
        space unless ``force``.

    Raises
    ------
    UserError
        An output would replace an input, a name is too long, or the folder is a file.
    EnvironmentProblem
        The folder cannot be created or written, or the disk is too small.
    """
    existing = next(p for p in (out_dir, *out_dir.parents) if _exists(p))
    name_max, path_max = _name_max(existing), _path_max(existing)
    for part in out_dir.parts:
        if len(part.encode("utf-8")) > name_max:
            raise UserError(f"a folder name of {len(part.encode('utf-8'))} bytes is longer than the file system "
                            f"takes ({name_max})", out_dir, key)
    outputs = list(outputs)
    for rel in outputs:
        target = out_dir / rel
        if len(str(target).encode("utf-8")) + TEMP_NAME_EXTRA > path_max:
            raise UserError(f"the output path {str(target)[:60]!r}... is longer than the file system takes "
                            f"({path_max} bytes): choose a shorter output folder or name", out_dir, key)
    if out_dir.exists() and not out_dir.is_dir():
        raise UserError("is a file; the output folder must be a folder", out_dir, None)
    resolved_inputs = [Path(p).resolve() for p in inputs]
    for rel in outputs:
        target = out_dir / rel
        for part in Path(rel).parts:
            if len(part.encode("utf-8")) + TEMP_NAME_EXTRA > name_max:
                raise UserError(f"output file name {part[:40]!r}... is {len(part.encode('utf-8'))} bytes; the file "
                                f"system takes {name_max} (with pmmw's temporary suffix): shorten `name`",
                                out_dir, key)
        for parent in list(Path(rel).parents)[:-1]:  # e.g. previews/: must be a folder if it exists
            p = out_dir / parent
            if p.exists() and not p.is_dir():
                raise UserError(f"{parent} is a file; the render writes its {parent}/ folder there", out_dir, key)
        for src in resolved_inputs:
            if _same_file(target.resolve(), src):
                raise UserError(f"the render would overwrite its own input {src} with {rel}; choose another "
                                "output folder or name", out_dir, key)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise os_problem(e, out_dir, "create the output folder") from None
    if not os.access(out_dir, os.W_OK | os.X_OK):
        raise EnvironmentProblem("cannot write in the output folder: permission denied", out_dir)
    if disk_bytes and not force:
        free = shutil.disk_usage(out_dir).free
        if disk_bytes > free:
            raise EnvironmentProblem(f"the render needs about {disk_bytes / 1e9:.3g} GB on this disk and "
                                     f"{free / 1e9:.3g} GB are free (pass --force to try anyway)", out_dir)


class Staging:
    """One render's output files, written in a hidden folder and moved into place together.

    Usage::

        with Staging(out_dir) as st:
            write_exr(st.path("scene.exr"), ...)
            st.commit(["scene.exr", "previews/scene_I.png"], last=["report.json", "report.md"])

    Without `commit` (an exception, an interrupt) the staged files are deleted and nothing in
    ``out_dir`` changes.
    """

    def __init__(self, out_dir: Path):
        self.out_dir = Path(out_dir)
        self.root = self.out_dir / f"{STAGING_PREFIX}{os.getpid()}-{secrets.token_hex(4)}-{socket.gethostname()}"

    def __enter__(self) -> "Staging":
        try:
            self.root.mkdir(parents=True)
        except OSError as e:
            raise os_problem(e, self.root, "create a folder in the output folder") from None
        return self

    def path(self, rel: str) -> Path:
        """Where to write the output ``rel`` now (its folder is created)."""
        p = self.root / rel
        try:
            p.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise os_problem(e, p.parent, "create a folder") from None
        return p

    def commit(self, files, last=()) -> None:
        """Move ``files``, then ``last``, from the staging folder onto their destinations."""
        for rel in [*files, *last]:
            dest = self.out_dir / rel
            try:
                dest.parent.mkdir(parents=True, exist_ok=True)
                os.replace(self.root / rel, dest)
            except OSError as e:
                raise os_problem(e, dest, "write") from None

    def __exit__(self, *exc) -> None:
        shutil.rmtree(self.root, ignore_errors=True)


def remove_stale_staging(out_dir: Path) -> None:
    """Delete staging folders left by renders on this host that died (their process is gone);
    those of other hosts sharing the folder are left alone."""
    if not out_dir.is_dir():
        return
    host = socket.gethostname()
    for p in out_dir.glob(f"{STAGING_PREFIX}*"):
        fields = p.name[len(STAGING_PREFIX):].split("-", 2)
        if len(fields) != 3 or fields[2] != host or not fields[0].isdigit():
            continue
        if not _alive(int(fields[0])):
            shutil.rmtree(p, ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
