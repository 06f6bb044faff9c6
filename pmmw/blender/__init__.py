"""Blender, both ways: the add-on (`pmmw.blender.pmmw_blender`, which runs inside Blender and
imports nothing of pmmw) and pmmw's side of it: a ``.blend`` read as a scenario by running the
add-on's exporter headless, with Blender's ``bpy`` package, in a subprocess, into a folder pmmw owns
in the temporary folder (`scenario_of_blend`),
and the add-on's zip for Blender's preferences (`addon_zip`).

The exporter runs in its own process, not imported here: ``bpy`` is a whole Blender (about 1 GB,
its own OpenImageIO and numpy builds, a Python of one version), and a Python that has it need not
be the one pmmw runs in (``PMMW_BLENDER_PYTHON``).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

from pmmw import __version__
from pmmw.errors import EnvironmentProblem, UserError, UserErrors, warn

ADDON = Path(__file__).resolve().parent / "pmmw_blender"
HEADLESS = ADDON / "headless.py"
PYTHON_VARIABLE = "PMMW_BLENDER_PYTHON"
INSTALL_HINT = (
    "reading a .blend needs Blender's bpy package: install pmmw's blender extra "
    "(pip install 'pmmw[blender]', with Python 3.11), or set PMMW_BLENDER_PYTHON to a Python that "
    "has bpy; or export the scene from Blender with the pmmw add-on (docs/blender.md)"
)

KEEP_DAYS = 7  # exports of .blend files unused this long are removed when another is made
#: The names of what pmmw makes in `export_root`: finished exports and unfinished ones
EXPORT_NAME = re.compile(r"[0-9a-f]{20}|\.export-[A-Za-z0-9_]+")


def blender_python() -> str:
    """The Python that runs the exporter: ``PMMW_BLENDER_PYTHON``, else this one if it has ``bpy``.

    Raises
    ------
    EnvironmentProblem
        Neither: the message names the extra to install.
    """
    chosen = os.environ.get(PYTHON_VARIABLE)
    if chosen:
        if shutil.which(chosen) is None:
            raise EnvironmentProblem(f"{PYTHON_VARIABLE}={chosen}: no such program")
        return chosen
    if importlib.util.find_spec("bpy") is not None:
        return sys.executable
    raise EnvironmentProblem(INSTALL_HINT)


def scenario_of_blend(path) -> Path:
    """The pmmw scenario of a ``.blend``, exported by the add-on's exporter into a folder that pmmw
    owns in the temporary folder, named after the file's content (and the exporter's code and the
    Python with ``bpy`` that runs it): every process that reads the same file reads the same
    scenario at the same paths (the same scenario hash: shards and ``--resume`` of a .blend work),
    and Blender runs once per version of the file.

    Parameters
    ----------
    path : str or Path
        The .blend file.

    Returns
    -------
    Path
        The scenario YAML, its meshes beside it.

    Raises
    ------
    EnvironmentProblem
        No ``bpy`` (`blender_python`); Blender failed in a way the scene does not explain.
    UserError or UserErrors
        The file cannot be opened by Blender, or its scene cannot be exported (no camera, a material
        that is not a database id, ...): each named by the .blend and what it is on.
    """
    path = Path(path).resolve()
    python = blender_python()
    # the file, the exporter's code and the Blender that runs it make the export
    digest = hashlib.sha256(f"{__version__}\0{python}\0".encode())
    for source in sorted(ADDON.glob("*.py")):
        digest.update(source.read_bytes())
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    root = export_root()
    final = root / f"{digest.hexdigest()[:20]}"
    out = final / f"{path.stem}.yaml"
    root.mkdir(mode=0o700, parents=True, exist_ok=True)
    check_root(root)
    if out.is_file():
        os.utime(final)
        return out
    _prune(root)
    work = Path(tempfile.mkdtemp(prefix=".export-", dir=root))
    try:
        _export(python, path, work / out.name)
        try:
            os.rename(work, final)  # whole, or not at all; another process's identical export may be first
        except OSError:
            if not out.is_file():
                raise
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return out


def export_root() -> Path:
    """Where pmmw keeps the scenarios of .blend files: ``pmmw-blend-<user id>`` in the temporary
    folder."""
    return Path(tempfile.gettempdir()) / f"pmmw-blend-{os.getuid() if hasattr(os, 'getuid') else 0}"


def _export(python: str, path: Path, out: Path) -> None:
    try:
        run = subprocess.run(
            [python, str(HEADLESS), str(path), str(out)],
            capture_output=True,
            text=True,
            errors="replace",
            stdin=subprocess.DEVNULL,
        )
    except OSError as e:
        raise EnvironmentProblem(f"cannot run {python} ({e.strerror})") from None
    lines = (run.stderr + run.stdout).splitlines()
    errors = [
        UserError(msg, file=path, key=key or None)
        for key, msg in (line.split("\t", 2)[1:] for line in lines if line.startswith("pmmw-error\t"))
    ]
    if run.returncode == 2 and errors:
        raise errors[0] if len(errors) == 1 else UserErrors(errors)
    for line in lines:
        if line.startswith("pmmw-note\t"):
            warn(f"{path.name}: {line.split(chr(9), 1)[1]}")
    if run.returncode != 0 or not out.is_file():
        tail = " | ".join(line.strip() for line in lines[-3:] if line.strip())
        raise EnvironmentProblem(f"Blender's export of {path.name} failed (exit {run.returncode}): {tail}", file=path)


def check_root(root: Path) -> None:
    """Refuse an export folder that is a link or not this user's own (the temporary folder is
    shared: another user could have made it, pointing anywhere): pmmw neither reads a scenario
    from it nor removes anything in it."""
    st = root.lstat()
    if root.is_symlink() or not root.is_dir() or (hasattr(os, "getuid") and st.st_uid != os.getuid()):
        raise EnvironmentProblem(
            f"{root} is a link, not a folder, or another user's: pmmw keeps .blend exports only in a folder "
            "of its own there; remove it (or set TMPDIR elsewhere)",
            file=root,
        )


def _prune(root: Path) -> None:
    """Remove the exports unused for `KEEP_DAYS`: only pmmw's own folders (`EXPORT_NAME`, not
    links) in a folder `check_root` accepts; anything else there is left alone."""
    try:
        check_root(root)
    except (EnvironmentProblem, OSError):
        return
    old = time.time() - KEEP_DAYS * 86400
    for d in root.iterdir():
        if not EXPORT_NAME.fullmatch(d.name):
            continue
        try:
            if d.is_dir() and not d.is_symlink() and d.stat().st_mtime < old:
                shutil.rmtree(d, ignore_errors=True)
        except OSError:
            pass


def addon_zip(dest) -> Path:
    """Write the add-on as a zip that Blender's preferences install (Add-ons > Install from Disk):
    one folder ``pmmw_blender/`` with its ``__init__.py`` (``bl_info``, Blender before 4.2) and
    ``blender_manifest.toml`` (an extension, Blender 4.2+).

    Parameters
    ----------
    dest : str or Path
        The zip file to write (its folder is made).
    """
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    files = sorted(p for p in ADDON.iterdir() if p.is_file() and p.suffix in (".py", ".toml"))
    tmp = dest.with_name(dest.name + ".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for p in files:
            info = zipfile.ZipInfo(f"pmmw_blender/{p.name}", date_time=(2020, 1, 1, 0, 0, 0))
            info.external_attr = 0o644 << 16
            z.writestr(info, p.read_bytes(), zipfile.ZIP_DEFLATED)
    os.replace(tmp, dest)
    return dest
