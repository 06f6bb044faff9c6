"""The output folder of a render: checked before any work, written together or not at all.

`check_outputs` runs before a single ray is traced: the folder can be created and written, no
output would replace a file the render reads or a file pmmw did not write (`made_by_pmmw`), no
destination is a folder, every destination folder is writable, every file name fits the file
system, and the disk has room. `Staging` then collects one render's files (EXR, previews,
reports) in hidden folders, one inside each destination folder (so every final move is a rename
within one file system, even when ``previews/`` is a mount or a link to another disk), and moves
them into place only when every one of them was written; the reports go last, so a report always
describes the EXR beside it. A failure before or during the moves (disk full, a destination that
became a folder, an interrupt) leaves the previous outputs as they were: a move that fails puts
back the files already replaced.

Operating-system failures become `EnvironmentProblem` (exit status 1) naming the path and the
cause in words (`os_problem`).
"""

from __future__ import annotations

import errno
import os
import secrets
import shutil
import socket
from collections.abc import Callable, Iterable
from pathlib import Path

from pmmw.errors import EnvironmentProblem, UserError

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


def os_problem(e: OSError, path: str | Path, doing: str) -> EnvironmentProblem:
    """An `OSError` as one line: ``PATH: cannot DOING: CAUSE``."""
    cause = (_CAUSES.get(e.errno) if e.errno is not None else None) or e.strerror or str(e)
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


def made_by_pmmw(path: Path) -> bool:
    """Does the existing file ``path`` look like an output of pmmw's, which a render may replace?

    An EXR with pmmw's header attributes, a report (``.json`` with pmmw's version and scenario,
    ``.md`` with its version line), a PNG whose ``Software`` text names pmmw or matplotlib (the
    previews before they named pmmw); any other file is the user's and is never overwritten.
    """
    try:
        if path.is_symlink() or not path.is_file():
            return False
        suffix = path.suffix.lower()
        if suffix == ".exr":
            import OpenImageIO as oiio

            inp = oiio.ImageInput.open(str(path))
            if inp is None:
                return False
            try:
                return inp.spec().getattribute("pmmw:version") is not None
            finally:
                inp.close()
        with open(path, "rb") as f:
            head = f.read(4096)
        if suffix == ".png":
            return head.startswith(b"\x89PNG") and (
                b"tEXtSoftware\x00pmmw" in head or b"tEXtSoftware\x00Matplotlib" in head
            )
        if suffix == ".md":
            return b"\n- pmmw version: " in head
        if suffix == ".json":
            if path.stat().st_size > 256 << 20:
                return False
            import json

            rec = json.loads(path.read_text(encoding="utf-8"))
            return isinstance(rec, dict) and "version" in rec and "scenario" in rec and "name" in rec
    except (OSError, ValueError, UnicodeDecodeError):
        return False
    return False


def _report_owner(path: Path) -> str | None:
    """The scenario name recorded in the existing report ``path`` (JSON), or None."""
    import json

    try:
        rec = json.loads(path.read_text(encoding="utf-8"))
        scn = rec.get("scenario") if isinstance(rec, dict) else None
        name = scn.get("name") if isinstance(scn, dict) else None
        return name if isinstance(name, str) else None
    except (OSError, ValueError, UnicodeDecodeError, AttributeError):
        return None


def check_outputs(
    out_dir: Path,
    outputs: Iterable[str],
    inputs: Iterable[str | os.PathLike[str]],
    *,
    key: str = "output.dir",
    disk_bytes: int = 0,
    force: bool = False,
    scenario_name: str | None = None,
) -> None:
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
    scenario_name : str, optional
        The scenario's name: an existing report (``*.json`` among ``outputs``) of another
        scenario is not replaced.

    Raises
    ------
    UserError
        An output would replace an input, a file pmmw did not write or another scenario's
        report; a destination is a folder; a name is too long; the folder is a file.
    EnvironmentProblem
        The folder (or a destination folder in it) cannot be created or written, or the disk is
        too small.
    """
    existing = next(p for p in (out_dir, *out_dir.parents) if _exists(p))
    name_max, path_max = _name_max(existing), _path_max(existing)
    for part in out_dir.parts:
        if len(part.encode("utf-8")) > name_max:
            raise UserError(
                f"a folder name of {len(part.encode('utf-8'))} bytes is longer than the file system takes ({name_max})",
                str(out_dir)[:200],
                key,
            )
    outputs = list(outputs)
    for rel in outputs:
        target = out_dir / rel
        if len(str(target).encode("utf-8")) + TEMP_NAME_EXTRA + len(STAGING_PREFIX) + 40 > path_max:
            raise UserError(
                f"the output path {str(target)[:60]!r}... is longer than the file system takes "
                f"({path_max} bytes): choose a shorter output folder or name",
                str(out_dir)[:200],
                key,
            )
    if out_dir.exists() and not out_dir.is_dir():
        raise UserError("is a file; the output folder must be a folder", out_dir, None)
    resolved_inputs = [Path(p).resolve() for p in inputs]
    for rel in outputs:
        target = out_dir / rel
        for part in Path(rel).parts:
            if len(part.encode("utf-8")) + TEMP_NAME_EXTRA > name_max:
                raise UserError(
                    f"output file name {part[:40]!r}... is {len(part.encode('utf-8'))} bytes; the file "
                    f"system takes {name_max} (with pmmw's temporary suffix): shorten `name`",
                    out_dir,
                    key,
                )
        for parent in list(Path(rel).parents)[:-1]:  # e.g. previews/: must be a folder if it exists
            p = out_dir / parent
            if p.exists() and not p.is_dir():
                raise UserError(f"{parent} is a file; the render writes its {parent}/ folder there", out_dir, key)
            if p.is_dir() and not os.access(p, os.W_OK | os.X_OK):
                raise EnvironmentProblem(f"cannot write in {parent}/: permission denied", out_dir)
        for src in resolved_inputs:
            if _same_file(target.resolve(), src):
                raise UserError(
                    f"the render would overwrite its own input {src} with {rel}; choose another output folder or name",
                    out_dir,
                    key,
                )
        if target.is_dir():
            raise UserError(
                f"{rel} is a folder where the render writes its file: move it away or choose another output folder",
                out_dir,
                key,
            )
        if os.path.lexists(target):
            if not made_by_pmmw(target):
                raise UserError(
                    f"{rel} exists and was not written by pmmw; pmmw never overwrites a file it did "
                    "not make: move it away or choose another output folder",
                    out_dir,
                    key,
                )
            owner = _report_owner(target) if target.suffix == ".json" else None
            if scenario_name is not None and owner is not None and owner != scenario_name:
                raise UserError(
                    f"{rel} is the report of scenario {owner!r}; rendering {scenario_name!r} here would "
                    "replace it: choose another output folder (--out)",
                    out_dir,
                    key,
                )
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise os_problem(e, out_dir, "create the output folder") from None
    if not os.access(out_dir, os.W_OK | os.X_OK):
        raise EnvironmentProblem("cannot write in the output folder: permission denied", out_dir)
    if disk_bytes and not force:
        free = shutil.disk_usage(out_dir).free
        if disk_bytes > free:
            raise EnvironmentProblem(
                f"the render needs about {disk_bytes / 1e9:.3g} GB on this disk and "
                f"{free / 1e9:.3g} GB are free (pass --force to try anyway)",
                out_dir,
            )


class Staging:
    """One render's output files, written in hidden folders and moved into place together.

    Usage::

        with Staging(out_dir) as st:
            write_exr(st.path("scene.exr"), ...)
            st.commit(["scene.exr", "previews/scene_I.png"], last=["report.json", "report.md"])

    Each file is staged in a hidden folder inside its own destination folder (``out_dir`` for
    ``scene.exr``, ``out_dir/previews`` for the previews), so every move is a rename within one
    file system. Without `commit` (an exception, an interrupt) the staged files are deleted and
    nothing in ``out_dir`` changes.
    """

    def __init__(self, out_dir: Path) -> None:
        self.out_dir = Path(out_dir)
        self.tag = f"{STAGING_PREFIX}{os.getpid()}-{secrets.token_hex(4)}-{socket.gethostname()}"
        self.root = self.out_dir / self.tag
        self._folders: list[Path] = []

    def _folder(self, parent: Path) -> Path:
        """The staging folder inside the destination folder ``out_dir/parent`` (made once)."""
        folder = self.out_dir / parent / self.tag
        if folder not in self._folders:
            try:
                folder.parent.mkdir(parents=True, exist_ok=True)
                folder.mkdir()
            except OSError as e:
                raise os_problem(e, folder.parent, "create a folder in the output folder") from None
            self._folders.append(folder)
        return folder

    def __enter__(self) -> "Staging":
        self._folder(Path("."))
        return self

    def path(self, rel: str | Path) -> Path:
        """Where to write the output ``rel`` now (its staging folder is created)."""
        p = Path(rel)
        return self._folder(p.parent) / p.name

    def commit(
        self,
        files: Iterable[str | Path],
        last: Iterable[str | Path] = (),
        check: Callable[[], object] | None = None,
    ) -> None:
        """Move ``files``, then ``last``, from their staging folders onto their destinations, all
        or none: the files they replace are kept aside until every move succeeded, and put back
        if one fails. ``check``, called first, may refuse the commit (`io.lock.FolderLock.check`)."""
        if check is not None:
            check()
        done: list[tuple[Path, Path | None]] = []  # (destination, the replaced file kept aside or None)
        try:
            for name in [*files, *last]:
                rel = Path(name)
                dest, staged = self.out_dir / rel, self.path(rel)
                old = None
                if os.path.lexists(dest) and not dest.is_dir():
                    old = staged.with_name(f".replaced-{rel.name}")
                    try:
                        os.link(dest, old, follow_symlinks=False)
                    except OSError:  # a file system without hard links: move it aside instead
                        os.rename(dest, old)
                os.replace(staged, dest)
                done.append((dest, old))
        except OSError as e:
            for dest, old in reversed(done):
                try:
                    if old is not None:
                        os.replace(old, dest)
                    else:
                        os.unlink(dest)
                except OSError:
                    pass
            raise os_problem(e, e.filename or self.out_dir, "write") from None

    def __exit__(self, *exc: object) -> None:
        for folder in self._folders:
            shutil.rmtree(folder, ignore_errors=True)


def remove_stale_staging(out_dir: Path) -> None:
    """Delete staging folders left by renders on this host that died (their process is gone), in
    ``out_dir`` and its real (not linked) subfolders; those of other hosts sharing the folder are
    left alone."""
    if not out_dir.is_dir():
        return
    host = socket.gethostname()
    folders = [out_dir] + [
        p for p in out_dir.iterdir() if p.is_dir() and not p.is_symlink() and not p.name.startswith(STAGING_PREFIX)
    ]
    for folder in folders:
        for p in folder.glob(f"{STAGING_PREFIX}*"):
            fields = p.name[len(STAGING_PREFIX) :].split("-", 2)
            if len(fields) != 3 or fields[2] != host or not fields[0].isdigit() or p.is_symlink() or not p.is_dir():
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
