"""Input file names as the user gave them: their length, their format, how a message shows them.

* A path whose component is longer than the file system's name limit (255 bytes on Linux file
  systems) or whose whole is longer than its path limit (4096 bytes) cannot even be looked up:
  the system call fails with ENAMETOOLONG. `check_input_path` says so first, as a `UserError`
  naming the file; `name_too_long` turns the OSError of a look-up elsewhere into the same.
* A message shows a long path shortened, its head and tail kept (`shown`).
* A file's format is the extension of the name the user gave, which for a symbolic link is the
  link's own name (content-addressed stores link ``scene/mesh.glb -> ../store/ab12cd...``); the
  target's extension only when the link's name has none (`format_suffix`).
"""

from __future__ import annotations

import errno
import os
from collections.abc import Iterable
from pathlib import Path

from pmmw.errors import UserError

NAME_MAX = 255  # [bytes] of one path component (ext4, XFS, btrfs, tmpfs, APFS, NTFS in UTF-16 units)
PATH_MAX = 4096  # [bytes] of a whole path (Linux)
SHOWN = 120  # [characters] of a path in a message: more is cut in the middle


def shown(path: object, limit: int = SHOWN) -> str:
    """``path`` as text, its middle cut to ``... (N characters) ...`` when longer than ``limit``."""
    text = os.fspath(path) if isinstance(path, (str, os.PathLike)) else str(path)
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    if len(text) <= limit:
        return text
    keep = (limit - 30) // 2
    return f"{text[:keep]}...({len(text):,} characters)...{text[-keep:]}"


def path_problem(path: str | os.PathLike[str]) -> str | None:
    """Why ``path`` is too long for any file system to look up, or None."""
    text = os.fspath(path)
    whole = len(os.fsencode(text))
    if whole > PATH_MAX:
        return f"the path is {whole:,} bytes long; file systems take at most {PATH_MAX}: shorten it"
    for part in Path(text).parts:
        n = len(os.fsencode(part))
        if n > NAME_MAX:
            return f"a name in the path is {n:,} bytes long; file systems take at most {NAME_MAX} per name: shorten it"
    return None


def check_input_path(path: str | os.PathLike[str], *, key: str | None = None) -> None:
    """Raise a `UserError` naming ``path`` (shortened) when it is too long to look up."""
    why = path_problem(path)
    if why:
        raise UserError(why, file=shown(path), key=key)


def name_too_long(e: BaseException, path: str | os.PathLike[str] | None = None) -> UserError | None:
    """The `UserError` for an OSError of a name too long (ENAMETOOLONG), else None."""
    if not isinstance(e, OSError) or e.errno != errno.ENAMETOOLONG:
        return None
    name = e.filename if e.filename is not None else path
    why = path_problem(name) if name is not None else None
    return UserError(
        why or "the path is too long for the file system: shorten it", file=shown(name) if name is not None else None
    )


def format_suffix(path: str | os.PathLike[str]) -> str:
    """The lower-case extension that tells ``path``'s format: its own name's, else (a symbolic
    link with an extension-less name) its target's; ``""`` when neither has one."""
    p = Path(path)
    if p.suffix:
        return p.suffix.lower()
    try:
        return Path(os.path.realpath(p)).suffix.lower() if p.is_symlink() else ""
    except OSError:
        return ""


def no_extension(path: str | os.PathLike[str], what: str, known: Iterable[str]) -> str:
    """The message for a file whose name (and link target) has no extension."""
    p = Path(path)
    target = ""
    try:
        if p.is_symlink():
            target = f" (nor has the file it links to, {shown(os.path.realpath(p), 60)})"
    except OSError:
        pass
    return (
        f"{p.name!r} has no extension to tell its {what} format{target}; give the file or link a name "
        f"ending in one of {', '.join(known)}"
    )
