"""The resumable tiles of a render: ``<out>/.pmmw-tiles/<label>-<hash>/``, and what may delete them.

A tile folder holds ``tile_NNNNNN.npz`` files (`trace.pool` writes and checks them) and
``manifest.json``, which marks the folder as pmmw's: its ``kind``, the folder's own name, the
scenario's ``name``, the ``hash`` of everything that changes the traced tiles and the settings
(compared when a resume is refused). pmmw writes into, resumes from and deletes only folders
that carry such a manifest (or that it creates itself), and deletes in them only the files it
writes there, by name; anything else found in one keeps the folder. It never deletes through a
link: when ``.pmmw-tiles`` (or a tile folder) is a symbolic link, or lies outside the real output
folder, tiles are written and resumed there but kept, and the run says where.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from pmmw.errors import UserError
from pmmw.io.atomic import write_text_atomic

TILE_ROOT = ".pmmw-tiles"
MANIFEST = "manifest.json"
MANIFEST_KIND = "pmmw tiles"
MAX_MANIFEST_BYTES = 4 << 20  # a manifest is a few kB (the resolved scenario); more is not one of ours
# the only names pmmw writes in a tile folder: tiles, the manifest, and their temporary files
# (`io.atomic.temp_path_for`: ".<stem>.tmp-<pid>-<8 hex><suffix>")
OWN_FILE = re.compile(
    r"(tile_\d{6}\.npz|manifest\.json|\.tile_\d{6}\.tmp-\d+-[0-9a-f]{8}\.npz"
    r"|\.manifest\.tmp-\d+-[0-9a-f]{8}\.json)"
)


def read_manifest(folder: Path) -> dict | None:
    """The manifest of a pmmw tile folder ``folder``, or None when ``folder`` is not one (no
    manifest, unreadable, another kind, another folder's, a link)."""
    path = folder / MANIFEST
    try:
        if path.is_symlink() or path.stat().st_size > MAX_MANIFEST_BYTES:
            return None
        rec = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    if not isinstance(rec, dict) or not isinstance(rec.get("hash"), str):
        return None
    if not folder.name.endswith(f"-{rec['hash']}"):
        return None
    if rec.get("kind") == MANIFEST_KIND and rec.get("folder") == folder.name:
        return rec
    if "kind" not in rec and isinstance(rec.get("scenario"), dict) and "version" in rec:
        return {**rec, "name": rec["scenario"].get("name")}  # written before manifests named their kind
    return None


def under_real_folder(path: Path, out_dir: Path) -> bool:
    """Is ``path`` inside the real ``out_dir`` with no link on the way (deletion is allowed)?"""
    try:
        real_out = out_dir.resolve()
        rel = path.relative_to(out_dir)
    except (OSError, ValueError):
        return False
    p = real_out
    for part in rel.parts:
        p = p / part
        if p.is_symlink():
            return False
    return path.resolve().is_relative_to(real_out)


def claim(folder: Path, manifest: dict, what: str) -> None:
    """Make ``folder`` this run's tile folder: create it with ``manifest``, or check that the
    folder found there is pmmw's with the same hash.

    Raises
    ------
    UserError
        ``folder`` is a link, a file, or a folder pmmw did not make (pmmw neither writes into
        nor deletes such a folder).
    """
    root = folder.parent
    if not root.is_symlink() and root.exists() and not root.is_dir():
        raise UserError(f"{root.name} is a file where pmmw keeps its tile folders: move it away", root.parent, what)
    if folder.is_symlink():
        raise UserError(
            f"{folder} is a symbolic link; pmmw keeps tiles only in folders it makes itself: remove the link",
            folder.parent,
            what,
        )
    if folder.exists() and not folder.is_dir():
        raise UserError(
            f"{folder.name} is a file where pmmw keeps this render's tiles: move it away", folder.parent, what
        )
    if folder.is_dir():
        rec = read_manifest(folder)
        if rec is not None and rec.get("hash") == manifest["hash"]:
            return
        foreign = [p.name for p in folder.iterdir() if not OWN_FILE.fullmatch(p.name)]
        if rec is not None or foreign or any(p.name == MANIFEST for p in folder.iterdir()):
            raise UserError(
                f"{folder.name} is not a tile folder of this render (no pmmw manifest of its settings"
                f"{': it holds ' + ', '.join(sorted(foreign)[:3]) if foreign else ''}); pmmw neither "
                "writes into nor deletes it: move it away",
                folder.parent,
                what,
            )
        # an empty folder, or one a shard of this render is creating right now: adopt it
    folder.mkdir(parents=True, exist_ok=True)
    write_text_atomic(
        folder / MANIFEST, json.dumps({**manifest, "kind": MANIFEST_KIND, "folder": folder.name}, indent=1, default=str)
    )


def own_folders(tile_root: Path) -> list[tuple[Path, dict]]:
    """(folder, manifest) of every pmmw tile folder directly under ``tile_root``."""
    try:
        entries = sorted(tile_root.iterdir()) if tile_root.is_dir() else []
    except OSError:
        return []
    found = []
    for d in entries:
        if d.is_dir() and not d.is_symlink():
            rec = read_manifest(d)
            if rec is not None:
                found.append((d, rec))
    return found


def remove_folder(folder: Path, out_dir: Path) -> bool:
    """Delete the pmmw tile folder ``folder`` if it is inside the real ``out_dir`` with no link on
    the way and holds only files pmmw writes there; delete only those files, by name. Returns
    whether the folder is gone."""
    if not under_real_folder(folder, out_dir) or folder.is_symlink() or read_manifest(folder) is None:
        return False
    try:
        entries = list(folder.iterdir())
        others = [p for p in entries if not OWN_FILE.fullmatch(p.name) or p.is_dir() and not p.is_symlink()]
        for p in entries:
            if p not in others and p.name != MANIFEST:
                p.unlink(missing_ok=True)
        if others:
            return False
        (folder / MANIFEST).unlink(missing_ok=True)
        folder.rmdir()
    except OSError:
        return False
    return True


def remove_root_if_empty(tile_root: Path, out_dir: Path) -> None:
    """Remove ``.pmmw-tiles`` when nothing is left in it (and it is a real folder of ``out_dir``)."""
    try:
        if under_real_folder(tile_root, out_dir) and tile_root.is_dir() and not any(tile_root.iterdir()):
            tile_root.rmdir()
    except OSError:
        pass


def deletable(tile_root: Path, out_dir: Path) -> bool:
    """May pmmw delete tile folders under ``tile_root`` (no link out of ``out_dir`` on the way)?"""
    return under_real_folder(tile_root, out_dir)
