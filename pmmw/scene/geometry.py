"""Scene geometry: mesh files -> one triangle soup with a material and an object per face.

Each scenario ``scene`` entry names a mesh file (glTF/GLB, OBJ, PLY, STL) and either one material
id for every face (``material``) or a map from the mesh's own material names to database ids
(``materials``). `load_entry_mesh` reads a file into (mesh material name, mesh) parts in the world
frame (Z up); `build_geometry` applies each entry's transform, assigns materials, checks the
meshes and concatenates everything into a `SceneGeometry`.

Frames. The world frame is Z up, right-handed. glTF is Y up by its specification, so a glTF
asset is turned +90 deg about X on load: ``(x, y, z)_gltf -> (x, -z, y)_world``, unless the file
says otherwise in ``asset.extras.up_axis`` ("Y" or "Z": what pmmw's own exporter writes,
`scene.export.export_glb`). A glTF that trimesh wrote without that mark is read as Y up with a
warning whatever its shape: trimesh keeps its own (Z-up) coordinates on export; any other with a
warning when it or its ground stands on its edge once turned (`_warn_if_z_up`). OBJ, PLY and STL
carry no convention and are taken as Z up. A scene entry's ``up_axis: y|z`` overrides all of these.

Orientation. Face normals point outward by counter-clockwise winding (trimesh's convention); the
tracer relies on it to tell entering a medium from leaving it (Murakowski 2014 sec. 2.2.9), so every
entry is checked: closed (watertight) or not, and a closed entry with negative volume (inside
out) is turned right side out with a warning.

Broken files. A mesh that is empty, truncated, corrupt, unreadable, names an external file that is
missing, or has non-finite vertices is a `UserError` saying what is wrong, never a traceback or a
numpy warning: light checks (STL length, GLB header, glTF JSON and the files it names) run before
trimesh, and whatever trimesh still trips on is reported with its exception.

Reading. trimesh reads every format; a render builds its scene (`build_geometry`) from the usual
GLB without it (`pmmw.scene.glb`: the same parts to the bit, and trimesh's closedness and volume by
its own operations), since importing trimesh takes about 0.4 s of a render's start.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import struct
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any
from urllib.parse import unquote

import numpy as np

from pmmw.constants import DEGENERATE_REL
from pmmw.errors import UserError, UserErrors, warn
from pmmw.io.inputs import format_suffix, no_extension
from pmmw.memory import check_fits, release_freed_memory
from pmmw.scene import glb

if TYPE_CHECKING:
    import trimesh


def _trimesh():
    """trimesh, imported when a mesh is first read: with the SciPy modules it imports (spatial,
    optimize, special, ndimage) about 0.4 s on 2 cores, which `import pmmw.pipeline` and a
    scenario's validation without its meshes need not pay."""
    import trimesh

    return trimesh


if TYPE_CHECKING:
    from pmmw.config.schema import SceneEntry, Transform

MESH_FORMATS = {".glb": "gltf", ".gltf": "gltf", ".obj": "obj", ".ply": "ply", ".stl": "stl"}
_FORMAT_NAMES = {"gltf": "glTF", "obj": "OBJ", "ply": "PLY", "stl": "STL"}

# glTF (Y up) -> world (Z up): +90 deg about X, (x, y, z) -> (x, -z, y).
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
MAX_COORDINATE = 1e7  # [m] 10,000 km: farther is a wrong unit or scale (and would lose the mm of coatings)

_OBJ_NAMES_MTL = "__pmmw_material_names__.mtl"

# Reader exceptions are quoted in the message up to this length (some repeat a whole buffer).
_EXCEPTION_CHARS = 200

#: [bytes] of memory at the peak of reading a mesh, per byte of the file (and of the glTF buffers
#: and images it names): trimesh's parse, then this module's arrays, checked against the memory
#: available before the file is read. Measured on 1e6-triangle grids: OBJ 15 (trimesh's export),
#: 21 (short numbers), 29 (quads); binary STL 16; binary PLY 31; GLB 33. The factors leave room
#: for files more compact than those (ASCII STL and PLY take 3-5 times less than their bound).
LOAD_BYTES_PER_FILE_BYTE = {"obj": 40, "stl": 25, "ply": 60, "gltf": 60}

#: [bytes] of an OBJ's material library (``mtllib``): a text file of some 100-300 bytes per
#: material, read for the texture files it names. A larger one is refused before it is read
#: (a 3 GB file took 6.4 GB to read whole).
MAX_MTL_BYTES = 8 << 20

# Freed memory is handed back after reading a mesh file of at least this many bytes, or building
# a scene of at least `_RELEASE_TRIANGLES` (smaller ones leave little; the collection takes ~0.1 s).
_RELEASE_BYTES = 1 << 24
_RELEASE_TRIANGLES = 100_000

# Statements are looked for in blocks of this many bytes of a text file; a line longer than
# `_MAX_LINE` names no file (the rest of it is skipped), so a scan's memory is bounded.
_BLOCK = 1 << 20
_MAX_LINE = 1 << 16

# MTL statements that name a texture file (the file name is the statement's last word).
_MTL_MAPS = {
    "map_ka",
    "map_kd",
    "map_ks",
    "map_ke",
    "map_ns",
    "map_d",
    "map_bump",
    "bump",
    "disp",
    "decal",
    "refl",
    "norm",
    "map_pr",
    "map_pm",
    "map_ps",
    "map_rma",
    "map_orm",
}


@dataclass
class SceneGeometry:
    """Every scene entry's triangles in one soup, in the world frame.

    Attributes
    ----------
    vertices : ndarray, shape (V, 3), float64
        Vertex positions [m], world frame, Z up.
    faces : ndarray, shape (F, 3), int64
        Vertex indices; counter-clockwise seen from outside. No degenerate (zero-area) faces.
    face_normals : ndarray, shape (F, 3), float64
        Unit outward normals.
    face_material : ndarray, shape (F,), int32
        Index of each face's material into `material_ids`.
    material_ids : list of str
        Database ids of the materials used, in order of first use.
    face_object : ndarray, shape (F,), int32
        Index of each face's scene entry into `objects`.
    objects : list of str
        One label per scene entry, ``"scene[i]:<name or file name>"``.
    object_watertight : list of bool
        Whether each entry's mesh is closed (every edge shared by exactly two faces, vertices
        merged by position).
    bounds : ndarray, shape (2, 3), float64
        Lower and upper corners of the faces' vertices [m] (zeros for an empty scene).
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_normals: np.ndarray
    face_material: np.ndarray
    material_ids: list
    face_object: np.ndarray
    objects: list
    object_watertight: list
    bounds: np.ndarray


# -- loading ----------------------------------------------------------------------------------


def load_entry_mesh(path: str | os.PathLike[str], up_axis: str | None = None) -> list[tuple[str, trimesh.Trimesh]]:
    """Read a mesh file into (mesh material name, mesh) parts, in the world frame (Z up).

    A glTF/GLB scene is flattened with its node transforms; each part's name is its glTF
    material's name (the mesh's name when the primitive has none). An OBJ gives one part per
    ``usemtl`` name, whether or not its ``.mtl`` file is present (faces before any ``usemtl``:
    name ``""``). PLY and STL give one part named ``""``.

    Parameters
    ----------
    path : str or Path
        The mesh file.
    up_axis : {"y", "z"} or None
        The file's up axis; None takes the format's convention (glTF: y; OBJ, PLY, STL: z).

    Returns
    -------
    list of (str, trimesh.Trimesh)
        Parts in a deterministic order (by scene node name), vertices float64 [m], faces int64.

    Raises
    ------
    UserError
        With ``file=path``: unknown format; an empty, unreadable, truncated or corrupt file; a
        glTF buffer or image file that is missing or shorter than its ``byteLength``; faces that
        name missing vertices; non-finite vertex coordinates; no triangles.
    """
    path = Path(path)
    fmt = _mesh_format(path)
    if up_axis not in (None, "y", "z"):
        raise UserError(f"up_axis must be 'y' or 'z', got {up_axis!r}", file=path)
    _check_file(path, fmt)
    size = _check_load_memory(path, fmt)
    try:
        with _quiet():
            # the type from the name given: a link's target may have none
            file_type = format_suffix(path)[1:]
            scene = _read_obj(path) if fmt == "obj" else _load_scene(str(path), file_type=file_type, process=False)
    except UserError:
        raise
    except Exception as e:  # whatever the reader trips on, the file is the user's to fix
        why = _describe(e)
        if isinstance(e, IndexError):  # e.g. an OBJ face naming a vertex past the last one
            why = f"an index past the end of its data, a truncated file? {why}"
        raise UserError(f"not a valid {_FORMAT_NAMES[fmt]} file ({why})", file=path) from e
    try:
        return _parts(path, fmt, scene, up_axis)
    finally:
        del scene
        if size >= _RELEASE_BYTES:
            release_freed_memory()  # the reader's text and lists: ~400 B a triangle of an OBJ, else resident


class _Part:
    """A part read without trimesh (`glb.read_glb`): what `_build_entry` and `_warn_if_z_up` use of
    a ``trimesh.Trimesh``: vertices (V, 3) float64 [m], faces (F, 3) int64, and each face's unit
    normal (zero where degenerate) and area [m^2] from the cross product of its edges, as trimesh's."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.vertices, self.faces = vertices, faces

    @property
    def area_faces(self) -> np.ndarray:
        return np.linalg.norm(self._crosses(), axis=1) / 2.0

    @property
    def face_normals(self) -> np.ndarray:
        c = self._crosses()
        n = np.linalg.norm(c, axis=1)
        return np.divide(c, n[:, None], out=np.zeros_like(c), where=n[:, None] > 0.0)

    def _crosses(self) -> np.ndarray:
        vectors = np.diff(self.vertices[self.faces], axis=1)
        return np.cross(vectors[:, 0], vectors[:, 1])


def _entry_parts(path: str | os.PathLike[str], up_axis: str | None = None) -> list[tuple[str, Any]]:
    """`load_entry_mesh`'s parts, read without trimesh where `glb.read_glb` reads the file (the
    same names, vertices and faces to the bit), by `load_entry_mesh` otherwise. Each part has
    ``vertices``, ``faces``, ``face_normals`` and ``area_faces``; the same checks and errors."""
    path = Path(path)
    fmt = _mesh_format(path)
    if fmt != "gltf" or up_axis not in (None, "y", "z"):
        return load_entry_mesh(path, up_axis)
    _check_file(path, fmt)
    _check_load_memory(path, fmt)
    try:
        read = glb.read_glb(path.read_bytes()) if format_suffix(path) == ".glb" else None
    except OSError:
        read = None
    if not read:  # trimesh reads it, or says what is wrong with it
        return load_entry_mesh(path, up_axis)
    rotate = Y_UP_TO_Z_UP if file_up_axis(path, up_axis, fmt) == "y" else None
    parts = []
    for _, material, vertices, faces, matrix in read:
        with _quiet():
            vertices, faces = glb.place(vertices, faces, matrix)
            if rotate is not None:
                vertices = vertices @ rotate.T
        parts.append((material, _Part(vertices, faces)))
    n_not_finite = sum(int((~np.isfinite(m.vertices)).any(axis=1).sum()) for _, m in parts)
    if n_not_finite:
        what = "1 vertex is" if n_not_finite == 1 else f"{n_not_finite} vertices are"
        raise UserError(f"{what} not finite (NaN or infinite coordinates)", file=path)
    if up_axis is None:
        _warn_if_z_up(path, parts)
    return parts


def _parts(path: Path, fmt: str, scene: trimesh.Scene, up_axis: str | None) -> list[tuple[str, trimesh.Trimesh]]:
    """`load_entry_mesh`'s parts of a scene trimesh has read."""
    rotate = Y_UP_TO_Z_UP if file_up_axis(path, up_axis, fmt) == "y" else None
    parts = []
    n_not_finite = 0
    for node in sorted(scene.graph.nodes_geometry):
        transform, geom_name = scene.graph[node]
        geom = scene.geometry[geom_name]
        if not isinstance(geom, _trimesh().Trimesh) or len(geom.faces) == 0:
            continue  # points, lines and empty primitives carry no surface
        vertices = np.asarray(geom.vertices, dtype=np.float64)
        faces = np.asarray(geom.faces, dtype=np.int64)
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise UserError(
                f"faces name vertices past the mesh's {len(vertices)} vertices (a truncated file?)", file=path
            )
        with _quiet():  # a NaN vertex is reported below, not as numpy's warning
            mesh = _trimesh().Trimesh(vertices=vertices, faces=faces, process=False)
            mesh.apply_transform(transform)  # flips the winding itself for mirroring transforms
            if rotate is not None:
                mesh.vertices = mesh.vertices @ rotate.T
        n_not_finite += int((~np.isfinite(mesh.vertices)).any(axis=1).sum())
        parts.append((_material_name(geom, geom_name, fmt), mesh))
    if n_not_finite:
        what = "1 vertex is" if n_not_finite == 1 else f"{n_not_finite} vertices are"
        raise UserError(f"{what} not finite (NaN or infinite coordinates)", file=path)
    if not parts:
        raise UserError("the mesh has no triangles", file=path)
    if fmt == "gltf" and up_axis is None:
        _warn_if_z_up(path, parts)
    return parts


FLAT_RATIO = 5.0  # a scene this many times wider than tall lies flat on its ground
# a ground: flat faces at one end of the scene along an axis, their normals within GROUND_TILT of
# it, covering at least GROUND_COVER of the scene's extent across it and GROUND_MARGIN times the
# area of such faces across the other horizontal axis (the shipped Y-up scenes, read both ways:
# 2.7 to 8e4 times in favour of the right axis)
GROUND_TILT = np.radians(1.0)  # [rad]
GROUND_COVER = 0.5  # [-]
GROUND_MARGIN = 2.0  # [-]


def _end_flat_area(
    parts: Sequence[tuple[str, trimesh.Trimesh | _Part]], axis: int, lo: np.ndarray, hi: np.ndarray
) -> float:
    """The larger of the areas of flat faces lying at the lowest and at the highest coordinate
    along ``axis`` (within 1e-4 of the scene's size) with their normals along it [m^2]."""
    tol = 1e-4 * float((hi - lo).max())
    area = {"lo": 0.0, "hi": 0.0}
    for _, m in parts:
        with _quiet():
            flat = np.abs(np.asarray(m.face_normals)[:, axis]) >= np.cos(GROUND_TILT)
        along = np.asarray(m.vertices)[np.asarray(m.faces)][:, :, axis]  # (F, 3) the corners' coordinates
        for side, at in (("lo", lo[axis]), ("hi", hi[axis])):
            on = flat & (np.abs(along - at) <= tol).all(axis=1)
            area[side] += float(np.asarray(m.area_faces)[on].sum())
    return max(area.values())


def _warn_if_z_up(path: Path, parts: Sequence[tuple[str, trimesh.Trimesh | _Part]]) -> None:
    """glTF is Y-up by specification, but exporters that write their own Z-up coordinates as they
    are (trimesh among them) make an upright object lie down and a flat scene stand on its edge.
    A file that states its up axis (``asset.extras.up_axis``) is read so, without a warning; one
    written by trimesh without it is warned about whatever its shape; any other is warned about
    when it lies on its edge (after the Y-up -> Z-up turn a ground-like scene is wide in x and y
    and thin in z; thin in y instead means the file was Z-up) or when its ground does: the flat
    faces at one end of y, facing along y, cover at least half the scene's x-z extent
    (`GROUND_COVER`) and twice the area of those at its bottom or top (`GROUND_MARGIN`). A Z-up
    model's ground turns so, whatever stands on it; a lone box has flat ends both ways and says
    nothing."""
    if _stated_up_axis(path) is not None:
        return
    v = np.concatenate([np.asarray(m.vertices) for _, m in parts])
    ext = np.ptp(v, axis=0)
    try:
        generator = str(_gltf_json(path).get("asset", {}).get("generator", ""))
    except UserError:
        generator = ""
    flat_on_edge = ext[1] * FLAT_RATIO < min(ext[0], ext[2])
    if "trimesh" in generator.lower():
        shape = (
            f"it lies on its edge, {ext[1]:.3g} m thick along y"
            if flat_on_edge
            else f"it now spans {ext[0]:.3g} x {ext[1]:.3g} m and stands {ext[2]:.3g} m tall"
        )
        warn(
            f"{path.name}: written by trimesh, which keeps its own (Z-up) coordinates in a glTF, yet read as "
            f"glTF's Y-up: {shape}. If it was modelled Z-up, set `up_axis: z` on its scene entry; if it was "
            "turned to Y-up before export, set `up_axis: y` there (or write asset.extras.up_axis in the file) "
            "to say so"
        )
        return
    by = f" (written by {generator.split()[0]!r})" if generator else ""
    if flat_on_edge:
        warn(
            f"{path.name}: the glTF is taken as Y-up (its specification) but lies on its edge, {ext[1]:.3g} m "
            f"thick along y against {ext[0]:.3g} x {ext[2]:.3g} m{by}: if it is Z-up, set `up_axis: z` on its "
            "scene entry"
        )
        return
    lo, hi = v.min(axis=0), v.max(axis=0)
    on_edge, lying = _end_flat_area(parts, 1, lo, hi), _end_flat_area(parts, 2, lo, hi)
    if on_edge >= GROUND_COVER * ext[0] * ext[2] and on_edge > GROUND_MARGIN * lying:
        warn(
            f"{path.name}: the glTF is taken as Y-up (its specification) but its ground stands on its edge: "
            f"its largest flat end, {on_edge:.3g} m^2 across its {ext[0]:.3g} x {ext[2]:.3g} m extent, faces "
            f"along y, against {lying:.3g} m^2 lying flat at its bottom or top{by}. If it was modelled Z-up, "
            "set `up_axis: z` on its scene entry; if it is Y-up, `up_axis: y` there says so"
        )


def asset_files(mesh_path: str | os.PathLike[str]) -> list[Path]:
    """The mesh file and every external file it names, for hashing what a render was made from.

    glTF/GLB: ``buffers[].uri`` and ``images[].uri`` that are not ``data:`` URIs, URL-decoded
    and resolved next to the mesh file. OBJ: its ``mtllib`` files and the texture maps they
    name (``map_Kd`` and the like), relative to the OBJ and to each ``.mtl``. PLY and STL name
    no other files.

    A glTF's buffers and images must exist (`load_entry_mesh` needs them), so a missing one
    raises; an OBJ is read without its ``.mtl`` (only the ``usemtl`` names matter), so a missing
    library or texture is left out of the list instead.

    Parameters
    ----------
    mesh_path : str or Path
        The mesh file.

    Returns
    -------
    list of Path
        The mesh file first, then the files it names, in the order named, each once.

    Raises
    ------
    UserError
        With ``file=mesh_path``: unknown format, the mesh file missing, or a glTF whose JSON is
        malformed or that names a missing file.
    """
    path = Path(mesh_path)
    fmt = _mesh_format(path)
    if not path.is_file():
        raise UserError("mesh file not found", file=path)
    files = [path]
    if fmt == "gltf":
        files += [p for _, _, p, _ in _gltf_external_files(path, _gltf_json(path))]
    elif fmt == "obj":
        files += _obj_external_files(path)
    return list(dict.fromkeys(files))


def file_up_axis(path: str | os.PathLike[str], up_axis: str | None = None, fmt: str | None = None) -> str:
    """The up axis a mesh file is read with: the entry's ``up_axis``; else, for glTF, what the
    file states (``asset.extras.up_axis``) or Y (its specification); Z for every other format."""
    if up_axis:
        return up_axis
    if (fmt or _mesh_format(Path(path))) != "gltf":
        return "z"
    return _stated_up_axis(Path(path)) or "y"


def _stated_up_axis(path: Path) -> str | None:
    """The up axis a glTF file states in ``asset.extras.up_axis`` ("Y" or "Z", any case), or None."""
    try:
        extras = _gltf_json(path).get("asset", {}).get("extras")
    except (UserError, OSError, ValueError):
        return None
    value = str(extras.get("up_axis", "")).strip().lower() if isinstance(extras, dict) else ""
    return value if value in ("y", "z") else None


def _mesh_format(path: Path) -> str:
    suffix = format_suffix(path)  # a symbolic link's own name first (content-addressed stores)
    if not suffix:
        raise UserError(no_extension(path, "mesh", sorted(MESH_FORMATS)), file=path)
    fmt = MESH_FORMATS.get(suffix)
    if fmt is None:
        raise UserError(f"unsupported mesh format {suffix!r}; supported: {', '.join(sorted(MESH_FORMATS))}", file=path)
    return fmt


@contextlib.contextmanager
def _quiet():
    """No numpy floating-point warnings while a possibly broken mesh is read (what is wrong with
    it is reported as a `UserError` instead)."""
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        yield


def _describe(e: Exception) -> str:
    """``"ExceptionClass: message"`` on one line, at most `_EXCEPTION_CHARS` long."""
    text = " ".join(str(e).split())
    text = f"{type(e).__name__}: {text}" if text else type(e).__name__
    return text if len(text) <= _EXCEPTION_CHARS else text[: _EXCEPTION_CHARS - 3] + "..."


# -- light checks before trimesh reads a file -------------------------------------------------


def _check_file(path: Path, fmt: str) -> None:
    """Raise a `UserError` for an unreadable or empty file and for what the format's own light
    checks find (STL length, GLB header, glTF JSON and the files it names)."""
    try:
        size = path.stat().st_size
        with path.open("rb"):
            pass
    except OSError as e:
        raise UserError(f"cannot read the mesh file: {e.strerror or _describe(e)}", file=path) from None
    if size == 0:
        raise UserError("the mesh file is empty (0 bytes)", file=path)
    if fmt == "stl":
        _check_stl(path, size)
    elif fmt == "gltf":
        tree = _gltf_json(path)
        for kind, uri, file, byte_length in _gltf_external_files(path, tree):
            have = file.stat().st_size
            if byte_length is not None and have < byte_length:
                raise UserError(
                    f"glTF {kind} {uri!r} named by {path.name} is truncated: {have} bytes, its byteLength is "
                    f"{byte_length}",
                    file=path,
                )


def _check_load_memory(path: Path, fmt: str) -> int:
    """Refuse a mesh whose reading would need more memory than is available, from the size of its
    file and of the files a glTF names (`LOAD_BYTES_PER_FILE_BYTE`), before it is read; returns
    that size [bytes]."""
    size = path.stat().st_size
    if fmt == "gltf" and format_suffix(path) != ".glb":
        size += sum(file.stat().st_size for _, _, file, _ in _gltf_external_files(path, _gltf_json(path)))
    check_fits(
        LOAD_BYTES_PER_FILE_BYTE[fmt] * size,
        f"reading this {size / 1e6:.4g} MB {_FORMAT_NAMES[fmt]} mesh",
        file=path,
        remedy="simplify the mesh (fewer triangles) or free memory",
    )
    return size


def _check_mtl(mtl: Path, path: Path) -> None:
    """Refuse a material library larger than `MAX_MTL_BYTES` (named by the OBJ ``path``)."""
    size = mtl.stat().st_size
    if size > MAX_MTL_BYTES:
        raise UserError(
            f"material library {mtl.name!r} named by {path.name} is {size / 1e6:.4g} MB; an MTL is a "
            f"small text file, at most {MAX_MTL_BYTES >> 20} MiB: check its `mtllib` line",
            file=path,
        )


def _check_stl(path: Path, size: int) -> None:
    """A binary STL is an 84-byte header (80 free bytes, uint32 triangle count N) and 50 bytes
    per triangle; anything else must be ASCII STL text (``solid ...``)."""
    with path.open("rb") as f:
        head = f.read(84)
    n = struct.unpack("<I", head[80:84])[0] if len(head) == 84 else None
    if n is not None and size == 84 + 50 * n:
        return
    if head.lstrip()[:5].lower() == b"solid":
        data = path.read_bytes()
        try:
            data.decode("utf-8")
        except UnicodeDecodeError:
            pass  # a binary STL whose header starts with "solid": report it as binary
        else:
            if not re.search(rb"(?i)endsolid", data):
                raise UserError("not a valid STL file (ASCII STL truncated: no 'endsolid' line)", file=path)
            return
    if n is None:
        why = f"binary STL truncated: an 84-byte header expected, the file has {size} bytes"
    else:
        why = (
            f"binary STL truncated or corrupt: 84 + 50 x N = {84 + 50 * n} bytes expected for its "
            f"N = {n} triangles, the file has {size}"
        )
    raise UserError(f"not a valid STL file ({why}; not ASCII STL either)", file=path)


def _gltf_json(path: Path) -> dict:
    """The JSON of a ``.gltf`` file or of a GLB's first chunk, checked to be a JSON object.

    GLB layout (glTF 2.0 specification, "GLB File Format Specification"): a 12-byte header
    (magic ``glTF``, version 2, total length), then chunks of (uint32 length, uint32 type, data);
    the first is the JSON.
    """
    if format_suffix(path) != ".glb":
        data = path.read_bytes()
    else:
        size = path.stat().st_size
        with path.open("rb") as f:
            head = f.read(20)
            if len(head) < 12 or head[:4] != b"glTF":
                raise UserError("not a valid GLB file (it does not start with the 'glTF' magic)", file=path)
            version, length = struct.unpack("<II", head[4:12])
            if version != 2:
                raise UserError(f"GLB version {version}; only glTF 2 is supported", file=path)
            if size < length:
                raise UserError(f"GLB truncated: its header says {length} bytes, the file has {size}", file=path)
            if len(head) < 20:
                raise UserError("GLB truncated: no JSON chunk", file=path)
            chunk_length, chunk_type = struct.unpack("<II", head[12:20])
            if chunk_type != 0x4E4F534A:  # b"JSON" read as little-endian uint32
                raise UserError("not a valid GLB file (the first chunk is not JSON)", file=path)
            if size < 20 + chunk_length:
                raise UserError(
                    f"GLB truncated: the JSON chunk needs {chunk_length} bytes, {size - 20} are left", file=path
                )
            data = f.read(chunk_length)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise UserError(f"glTF JSON is not UTF-8 text (byte {e.start})", file=path) from None
    try:
        tree = json.loads(text)
    except json.JSONDecodeError as e:
        raise UserError(f"glTF JSON is malformed at line {e.lineno}, column {e.colno}: {e.msg}", file=path) from None
    if not isinstance(tree, dict):
        raise UserError(f"glTF JSON is a {type(tree).__name__}, not an object", file=path)
    return tree


def _gltf_external_files(path: Path, tree: dict) -> list[tuple[str, str, Path, int | None]]:
    """(kind, uri, file, byteLength or None) of every buffer and image a glTF names by a
    non-``data:`` URI; raises a `UserError` for one that does not exist."""
    out = []
    for kind, items in (("buffer", tree.get("buffers")), ("image", tree.get("images"))):
        for item in items if isinstance(items, list) else []:
            uri = item.get("uri") if isinstance(item, dict) else None
            if not isinstance(uri, str) or uri.startswith("data:"):
                continue
            file = path.parent / unquote(uri)
            if not file.is_file():
                raise UserError(f"glTF {kind} {uri!r} named by {path.name} not found", file=path)
            byte_length = item.get("byteLength") if kind == "buffer" else None
            out.append((kind, uri, file, byte_length if isinstance(byte_length, int) else None))
    return out


def _obj_external_files(path: Path) -> list[Path]:
    """The existing ``mtllib`` files of an OBJ and the existing texture maps they name; a library
    larger than `MAX_MTL_BYTES` is refused before it is read."""
    files = []
    for mtl in _named_files(path, {"mtllib"}, whole_words=True):
        _check_mtl(mtl, path)
        files.append(mtl)
        files += _named_files(mtl, _MTL_MAPS, whole_words=False)
    return files


def _named_files(path: Path, keywords: set, whole_words: bool) -> list[Path]:
    """Existing files named by the lines of text file `path` that start with one of `keywords`,
    relative to its folder (`_named_in`); the file is scanned in blocks (`_statements`)."""
    return _named_in(path.parent, _statements(path, keywords), whole_words)


def _named_in(folder: Path, lines: Iterable[str], whole_words: bool) -> list[Path]:
    """Existing files in ``folder`` named by statements ``lines`` (``keyword rest...``). A
    statement's rest of line is one file name if such a file exists (names with spaces);
    otherwise each word (``whole_words``: ``mtllib a.mtl b.mtl``) or the last word (texture
    maps, after their options) is."""
    files = []
    for line in lines:
        words = line.split()
        if len(words) < 2:
            continue
        rest = line.strip()[len(words[0]) :].strip()
        candidates = [rest] if (folder / rest).is_file() else (words[1:] if whole_words else words[-1:])
        files += [folder / c for c in candidates if (folder / c).is_file()]
    return files


def _statements(path: Path, keywords: set) -> list[str]:
    """The lines of text file ``path`` whose first word is one of ``keywords`` (any case), found
    block by block (`_BLOCK` bytes): the memory does not grow with the file (a 400 MB OBJ was
    read whole and split into some 15 million strings to find its ``mtllib`` line)."""
    first = rb"^[ \t]*(?:" + b"|".join(re.escape(k.encode()) for k in sorted(keywords)) + rb")[ \t]+\S[^\r\n]*"
    pattern = re.compile(first, re.IGNORECASE | re.MULTILINE)
    found, tail, skipping = [], b"", False
    with path.open("rb") as f:
        for block in iter(lambda: f.read(_BLOCK), b""):
            if skipping:  # the rest of an overlong line
                end = block.find(b"\n")
                if end < 0:
                    continue
                block, skipping = block[end + 1 :], False
            block = tail + block
            cut = block.rfind(b"\n") + 1
            block, tail = block[:cut], block[cut:]
            if len(tail) > _MAX_LINE:
                tail, skipping = b"", True
            found += [m.group().decode(errors="replace") for m in pattern.finditer(block)]
    found += [m.group().decode(errors="replace") for m in pattern.finditer(tail)]
    return found


def _read_obj(path: Path) -> trimesh.Scene:
    """trimesh's OBJ reader, given a material library naming every ``usemtl``.

    trimesh drops a ``usemtl`` name whose ``.mtl`` entry is missing, and the material map needs
    the names only (appearance is irrelevant here), so the real library is replaced by one that
    just declares them.
    """
    data = path.read_bytes()
    if b"\0" in data:
        raise UserError("not a valid OBJ file (binary data, not OBJ text)", file=path)
    text = data.decode(errors="replace")
    libraries = re.findall(r"(?im)^[ \t]*mtllib[ \t]+\S.*$", text)
    for mtl in _named_in(path.parent, libraries, whole_words=True):  # not read here, but by the render's hash
        _check_mtl(mtl, path)
    names = list(dict.fromkeys(re.findall(r"^[ \t]*usemtl[ \t]+(.+?)[ \t]*$", text, flags=re.MULTILINE)))
    text = re.sub(r"^[ \t]*mtllib\b.*$", "", text, flags=re.MULTILINE)
    resolver = None
    if names:
        text = f"mtllib {_OBJ_NAMES_MTL}\n" + text
        library = "".join(f"newmtl {n}\n" for n in names).encode()
        resolver = _trimesh().resolvers.ZipResolver({_OBJ_NAMES_MTL: io.BytesIO(library)})
    return _load_scene(
        io.BytesIO(text.encode()), file_type="obj", resolver=resolver, process=False, group_material=True
    )


def _load_scene(file_obj: str | Path | IO[bytes], **kwargs: Any) -> trimesh.Scene:
    """`trimesh.load_scene` (trimesh >= 4.5), or ``trimesh.load(force="scene")`` before it."""
    trimesh = _trimesh()
    if hasattr(trimesh, "load_scene"):
        return trimesh.load_scene(file_obj, **kwargs)
    scene = trimesh.load(file_obj, force="scene", **kwargs)
    assert isinstance(scene, trimesh.Scene)  # what force="scene" returns
    return scene


def _material_name(geom: trimesh.Trimesh, geom_name: object, fmt: str) -> str:
    material = getattr(geom.visual, "material", None)
    name = getattr(material, "name", None)
    if name:
        return str(name)
    return str(geom_name) if fmt == "gltf" else ""


# -- building ---------------------------------------------------------------------------------


def entry_transform(transform: Transform | None) -> tuple[np.ndarray, np.ndarray]:
    """The affine map of a scene entry's ``transform``: x_world = A @ x + t.

    Order: scale, then rotate (``rotate_deg``: XYZ extrinsic, i.e. about the world X axis first,
    then Y, then Z), then translate. None (or a missing attribute) is the identity.

    Returns
    -------
    A : ndarray, shape (3, 3), float64
    t : ndarray, shape (3,), float64 [m]
    """
    scale = getattr(transform, "scale", None)
    rotate = getattr(transform, "rotate_deg", None)
    translate = getattr(transform, "translate", None)
    s = np.broadcast_to(np.asarray(1.0 if scale is None else scale, dtype=np.float64), (3,))
    rx, ry, rz = np.radians(np.zeros(3) if rotate is None else np.asarray(rotate, dtype=np.float64))
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    r_x = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    r_y = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    r_z = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    a = r_z @ r_y @ r_x @ np.diag(s)
    t = np.zeros(3) if translate is None else np.asarray(translate, dtype=np.float64).reshape(3)
    return a, t


def _face_normals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (F, 3) and a mask of non-degenerate faces (same test as the intersector)."""
    tri = vertices[faces]
    e1, e2, e3 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0], tri[:, 2] - tri[:, 1]
    cross = np.cross(e1, e2)
    area2 = np.linalg.norm(cross, axis=1)
    longest2 = np.max(np.stack([np.einsum("ij,ij->i", e, e) for e in (e1, e2, e3)]), axis=0)
    ok = area2 > DEGENERATE_REL * longest2
    normals = np.zeros_like(cross)
    normals[ok] = cross[ok] / area2[ok, None]
    return normals, ok


def _closed_and_volume(vertices: np.ndarray, faces: np.ndarray) -> tuple[bool, float]:
    """Watertightness after merging vertices by position, and the signed volume [m^3]: trimesh's,
    without importing it (`glb.closed_and_volume`)."""
    return glb.closed_and_volume(vertices, faces)


def build_geometry(entries: Iterable[SceneEntry], scenario_file: str | Path | None = None) -> SceneGeometry:
    """Load, transform and check every scene entry; concatenate into one `SceneGeometry`.

    Parameters
    ----------
    entries : sequence of scene entries
        Objects with ``mesh`` (Path), ``material`` (str or None), ``materials`` (dict mesh
        material name -> id, or None), ``transform`` (``translate`` (3,) [m], ``rotate_deg`` (3,)
        [deg], ``scale`` float or (3,); or None), ``up_axis`` ("y", "z" or None), ``name``
        (str or None) and ``key`` (e.g. ``"scene[0]"``).
    scenario_file : str or Path, optional
        Where the entries come from, for error messages.

    Raises
    ------
    UserErrors
        Every entry's problems together: unreadable or empty meshes, a mesh material name the
        ``materials`` map lacks, a missing or doubled material choice, a singular transform.
    """
    errors: list[UserError] = []
    material_ids: list[str] = []
    objects: list[str] = []
    watertight: list[bool] = []
    verts: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    mats: list[np.ndarray] = []
    objs: list[np.ndarray] = []
    n_verts = 0
    for i, entry in enumerate(entries):
        key = getattr(entry, "key", None) or f"scene[{i}]"
        try:
            v, f, part, names = _build_entry(entry, key, scenario_file)
        except UserError as e:
            errors.extend(e.errors if isinstance(e, UserErrors) else [e])
            continue
        label = f"{key}:{getattr(entry, 'name', None) or Path(entry.mesh).name}"
        reach = float(np.abs(v).max()) if len(v) else 0.0
        if not reach <= MAX_COORDINATE:
            errors.append(
                UserError(
                    f"{entry.mesh}: a vertex lies {reach:.3g} m from the origin (after the transform); "
                    f"pmmw scenes lie within {MAX_COORDINATE:g} m of it (is a unit or scale wrong?)",
                    scenario_file,
                    f"{key}.mesh",
                )
            )
            continue
        closed, volume = _closed_and_volume(v, f)
        if closed and volume < 0.0:
            f = np.ascontiguousarray(f[:, ::-1])
            warn(f"{label}: the mesh is inside out (negative volume); its faces were turned outward")
        material = getattr(entry, "material", None)
        if material is not None:
            ids = [material] * len(names)
        else:
            assert entry.materials is not None  # _build_entry refuses an entry with neither
            ids = [entry.materials[n] for n in names]
        index = []
        for mid in ids:
            if mid not in material_ids:
                material_ids.append(mid)
            index.append(material_ids.index(mid))
        verts.append(v)
        faces.append(f + n_verts)
        mats.append(np.asarray(index, dtype=np.int32)[part])
        objs.append(np.full(len(f), len(objects), dtype=np.int32))
        n_verts += len(v)
        objects.append(label)
        watertight.append(closed)
    if errors:
        raise UserErrors(errors)

    vertices = np.concatenate(verts) if verts else np.zeros((0, 3))
    all_faces = np.concatenate(faces) if faces else np.zeros((0, 3), dtype=np.int64)
    del verts, faces
    normals, _ = _face_normals(vertices, all_faces)
    used = vertices[all_faces].reshape(-1, 3)
    bounds = np.array([used.min(axis=0), used.max(axis=0)]) if len(used) else np.zeros((2, 3))
    del used
    if len(all_faces) >= _RELEASE_TRIANGLES:
        release_freed_memory()  # the checks' temporaries (watertightness, normals): ~400 B a triangle, else resident
    return SceneGeometry(
        vertices=vertices,
        faces=all_faces,
        face_normals=normals,
        face_material=np.concatenate(mats) if mats else np.zeros(0, dtype=np.int32),
        material_ids=material_ids,
        face_object=np.concatenate(objs) if objs else np.zeros(0, dtype=np.int32),
        objects=objects,
        object_watertight=watertight,
        bounds=bounds,
    )


def _build_entry(
    entry: SceneEntry, key: str, scenario_file: str | Path | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """One entry's vertices (V, 3) [m] in the world frame, faces (F, 3), the index of each face's
    mesh part (F,) and the parts' mesh material names."""
    mesh_path = Path(entry.mesh)
    material = getattr(entry, "material", None)
    materials = getattr(entry, "materials", None)
    if material is None and not materials:
        raise UserError(
            "no material: give `material` (one database id for every face) or `materials` "
            "(mesh material name -> database id)",
            file=scenario_file,
            key=key,
        )
    if material is not None and materials:
        raise UserError("give either `material` or `materials`, not both", file=scenario_file, key=key)
    if not mesh_path.is_file():
        raise UserError(f"mesh file not found: {mesh_path}", file=scenario_file, key=f"{key}.mesh")

    try:
        parts = _entry_parts(mesh_path, getattr(entry, "up_axis", None))
    except UserError as e:
        raise UserError(f"{e.file or mesh_path}: {e.message}", file=scenario_file, key=f"{key}.mesh") from None
    names = [name for name, _ in parts]
    if materials:
        have = list(dict.fromkeys(names))
        missing = [n for n in have if n not in materials]
        if missing:
            raise UserError(_unmapped_names(mesh_path, have, missing), file=scenario_file, key=f"{key}.materials")
        unused = [n for n in materials if n not in have]
        if unused:
            warn(f"{key}.materials: {_quoted(unused)} not used by {mesh_path.name}, which has {_quoted(have)}")

    a, t = entry_transform(getattr(entry, "transform", None))
    det = float(np.linalg.det(a))
    if not np.isfinite(det) or abs(det) < 1e-300:
        raise UserError("the transform is singular (a zero scale?)", file=scenario_file, key=f"{key}.transform")
    verts, faces, part_of = [], [], []
    off = 0
    for i, (_, mesh) in enumerate(parts):
        verts.append(np.asarray(mesh.vertices, dtype=np.float64))
        faces.append(np.asarray(mesh.faces, dtype=np.int64) + off)
        part_of.append(np.full(len(mesh.faces), i))
        off += len(mesh.vertices)
    v = np.concatenate(verts) @ a.T + t
    f = np.concatenate(faces)
    if det < 0.0:  # a mirroring transform would turn the winding inward
        f = f[:, ::-1]
    part = np.concatenate(part_of)

    _, ok = _face_normals(v, f)
    if not ok.all():
        warn(f"{key}: dropped {int((~ok).sum())} degenerate (zero-area) faces of {len(f)} in {mesh_path.name}")
        f, part = f[ok], part[ok]
    if len(f) == 0:
        raise UserError(
            f"{mesh_path}: the mesh has no triangles of non-zero area", file=scenario_file, key=f"{key}.mesh"
        )
    return v, np.ascontiguousarray(f), part, names


def _unmapped_names(mesh_path: Path, have: list[str], missing: list[str]) -> str:
    """What to do when a mesh's material names are not all in its entry's ``materials`` map; the
    rules per format are in docs/scenes.md ("Material names")."""
    fmt = _mesh_format(mesh_path)
    whole = "give `material: ID` instead of `materials:` (one database id for the whole mesh)"
    if have == [""]:
        how = {
            "obj": f"{mesh_path.name} has no `usemtl` line, so its faces carry no material name: {whole}, or "
            "put `usemtl NAME` lines before its faces and map each NAME in `materials:`",
            "gltf": f"{mesh_path.name}'s primitives have no material or mesh name: {whole}, or name its "
            "materials in the exporter",
        }.get(
            fmt,
            f"{mesh_path.name} is {fmt.upper()}, which carries no material names: {whole}, or split it into one file per "
            "material, or export it as glTF or OBJ with material names",
        )
        return f'{how} (see docs/scenes.md, "Material names")'
    named = [n for n in missing if n]
    text = (
        f"mesh material name(s) {_quoted(named)} of {mesh_path.name} are not in the map; "
        if named
        else f"{mesh_path.name} has faces without a material name; "
    )
    text += f"the mesh has {_quoted([n for n in have if n])}"
    if "" in missing:
        text += (
            " and faces before its first `usemtl` line, which have no name: put a `usemtl NAME` before them"
            if fmt == "obj"
            else " and unnamed faces"
        ) + " or map the empty name ('': ID)"
    return text + ' (see docs/scenes.md, "Material names")'


def _quoted(names: Iterable[str]) -> str:
    return ", ".join(repr(n) for n in names)
