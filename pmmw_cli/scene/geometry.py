"""Scene geometry: mesh files -> one triangle soup with a material and an object per face.

Each scenario ``scene`` entry names a mesh file (glTF/GLB, OBJ, PLY, STL) and either one material
id for every face (``material``) or a map from the mesh's own material names to database ids
(``materials``). `load_entry_mesh` reads a file into (mesh material name, mesh) parts in the world
frame (Z up); `build_geometry` applies each entry's transform, assigns materials, checks the
meshes and concatenates everything into a `SceneGeometry`.

Frames. The world frame is Z up, right-handed. glTF is Y up by its specification, so a glTF
asset is turned +90 deg about X on load: ``(x, y, z)_gltf -> (x, -z, y)_world``. OBJ, PLY and STL
carry no convention and are taken as Z up unless the entry says ``up_axis: y``.

Orientation. Face normals point outward by counter-clockwise winding (trimesh's convention); the
tracer relies on it to tell entering a medium from leaving it (Murakowski 2014 sec. 2.2.9), so every
entry is checked: closed (watertight) or not, and a closed entry with negative volume (inside
out) is turned right side out with a warning.
"""

from __future__ import annotations

import io
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from pmmw_cli.errors import UserError, UserErrors, warn
from pmmw_cli.trace.intersect import DEGENERATE_REL

MESH_FORMATS = {".glb": "gltf", ".gltf": "gltf", ".obj": "obj", ".ply": "ply", ".stl": "stl"}

# glTF (Y up) -> world (Z up): +90 deg about X, (x, y, z) -> (x, -z, y).
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])

_OBJ_NAMES_MTL = "__pmmw_material_names__.mtl"


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

def load_entry_mesh(path, up_axis: str | None = None) -> list[tuple[str, trimesh.Trimesh]]:
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
        With ``file=path``: unknown format, unreadable file, or no triangles.
    """
    path = Path(path)
    fmt = MESH_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise UserError(
            f"unsupported mesh format {path.suffix!r}; supported: {', '.join(sorted(MESH_FORMATS))}", file=path
        )
    if up_axis not in (None, "y", "z"):
        raise UserError(f"up_axis must be 'y' or 'z', got {up_axis!r}", file=path)
    try:
        scene = _read_obj(path) if fmt == "obj" else _load_scene(str(path), process=False)
    except Exception as e:  # whatever the reader trips on, the file is the user's to fix
        raise UserError(f"cannot read mesh: {type(e).__name__}: {e}", file=path) from e

    rotate = Y_UP_TO_Z_UP if (up_axis or ("y" if fmt == "gltf" else "z")) == "y" else None
    parts = []
    for node in sorted(scene.graph.nodes_geometry):
        transform, geom_name = scene.graph[node]
        geom = scene.geometry[geom_name]
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue  # points, lines and empty primitives carry no surface
        mesh = trimesh.Trimesh(
            vertices=np.asarray(geom.vertices, dtype=np.float64),
            faces=np.asarray(geom.faces, dtype=np.int64),
            process=False,
        )
        mesh.apply_transform(transform)  # flips the winding itself for mirroring transforms
        if rotate is not None:
            mesh.vertices = mesh.vertices @ rotate.T
        parts.append((_material_name(geom, geom_name, fmt), mesh))
    if not parts:
        raise UserError("the mesh has no triangles", file=path)
    return parts


def _read_obj(path: Path) -> trimesh.Scene:
    """trimesh's OBJ reader, given a material library naming every ``usemtl``.

    trimesh drops a ``usemtl`` name whose ``.mtl`` entry is missing, and the material map needs
    the names only (appearance is irrelevant here), so the real library is replaced by one that
    just declares them.
    """
    text = path.read_text(errors="replace")
    names = list(dict.fromkeys(re.findall(r"^[ \t]*usemtl[ \t]+(.+?)[ \t]*$", text, flags=re.MULTILINE)))
    text = re.sub(r"^[ \t]*mtllib\b.*$", "", text, flags=re.MULTILINE)
    resolver = None
    if names:
        text = f"mtllib {_OBJ_NAMES_MTL}\n" + text
        library = "".join(f"newmtl {n}\n" for n in names).encode()
        resolver = trimesh.resolvers.ZipResolver({_OBJ_NAMES_MTL: io.BytesIO(library)})
    return _load_scene(io.BytesIO(text.encode()), file_type="obj", resolver=resolver, process=False, group_material=True)


def _load_scene(file_obj, **kwargs) -> trimesh.Scene:
    """`trimesh.load_scene` (trimesh >= 4.5), or ``trimesh.load(force="scene")`` before it."""
    if hasattr(trimesh, "load_scene"):
        return trimesh.load_scene(file_obj, **kwargs)
    return trimesh.load(file_obj, force="scene", **kwargs)


def _material_name(geom: trimesh.Trimesh, geom_name: str, fmt: str) -> str:
    material = getattr(geom.visual, "material", None)
    name = getattr(material, "name", None)
    if name:
        return str(name)
    return str(geom_name) if fmt == "gltf" else ""


# -- building ---------------------------------------------------------------------------------

def entry_transform(transform) -> tuple[np.ndarray, np.ndarray]:
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
    """Watertightness after merging vertices by position, and the signed volume [m^3]."""
    merged = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    merged.merge_vertices()
    closed = bool(merged.is_watertight)
    return closed, float(merged.volume) if closed else float("nan")


def build_geometry(entries, scenario_file=None) -> SceneGeometry:
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
    objects, watertight = [], []
    verts, faces, mats, objs = [], [], [], []
    n_verts = 0
    for i, entry in enumerate(entries):
        key = getattr(entry, "key", None) or f"scene[{i}]"
        try:
            v, f, part, names = _build_entry(entry, key, scenario_file)
        except UserError as e:
            errors.extend(e.errors if isinstance(e, UserErrors) else [e])
            continue
        label = f"{key}:{getattr(entry, 'name', None) or Path(entry.mesh).name}"
        closed, volume = _closed_and_volume(v, f)
        if closed and volume < 0.0:
            f = np.ascontiguousarray(f[:, ::-1])
            warn(f"{label}: the mesh is inside out (negative volume); its faces were turned outward")
        material = getattr(entry, "material", None)
        ids = [material] * len(names) if material is not None else [entry.materials[n] for n in names]
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
    normals, _ = _face_normals(vertices, all_faces)
    used = vertices[all_faces].reshape(-1, 3)
    bounds = np.array([used.min(axis=0), used.max(axis=0)]) if len(used) else np.zeros((2, 3))
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


def _build_entry(entry, key: str, scenario_file):
    """One entry's vertices (V, 3) [m] in the world frame, faces (F, 3), the index of each face's
    mesh part (F,) and the parts' mesh material names."""
    mesh_path = Path(entry.mesh)
    material = getattr(entry, "material", None)
    materials = getattr(entry, "materials", None)
    if material is None and not materials:
        raise UserError(
            "no material: give `material` (one database id for every face) or `materials` "
            "(mesh material name -> database id)",
            file=scenario_file, key=key,
        )
    if material is not None and materials:
        raise UserError("give either `material` or `materials`, not both", file=scenario_file, key=key)
    if not mesh_path.is_file():
        raise UserError(f"mesh file not found: {mesh_path}", file=scenario_file, key=f"{key}.mesh")

    parts = load_entry_mesh(mesh_path, getattr(entry, "up_axis", None))
    names = [name for name, _ in parts]
    if materials:
        have = list(dict.fromkeys(names))
        missing = [n for n in have if n not in materials]
        if missing:
            raise UserError(
                f"mesh material name(s) {_quoted(missing)} of {mesh_path.name} are not in the map; "
                f"the mesh has {_quoted(have)}",
                file=scenario_file, key=f"{key}.materials",
            )
        unused = [n for n in materials if n not in have]
        if unused:
            warn(
                f"{key}.materials: {_quoted(unused)} not used by {mesh_path.name}, which has {_quoted(have)}"
            )

    a, t = entry_transform(getattr(entry, "transform", None))
    det = float(np.linalg.det(a))
    if not np.isfinite(det) or abs(det) < 1e-300:
        raise UserError("the transform is singular (a zero scale?)", file=scenario_file, key=f"{key}.transform")
    verts, faces, part = [], [], []
    off = 0
    for i, (_, mesh) in enumerate(parts):
        verts.append(np.asarray(mesh.vertices, dtype=np.float64))
        faces.append(np.asarray(mesh.faces, dtype=np.int64) + off)
        part.append(np.full(len(mesh.faces), i))
        off += len(mesh.vertices)
    v = np.concatenate(verts) @ a.T + t
    f = np.concatenate(faces)
    if det < 0.0:  # a mirroring transform would turn the winding inward
        f = f[:, ::-1]
    part = np.concatenate(part)

    _, ok = _face_normals(v, f)
    if not ok.all():
        warn(f"{key}: dropped {int((~ok).sum())} degenerate (zero-area) faces of {len(f)} in {mesh_path.name}")
        f, part = f[ok], part[ok]
    if len(f) == 0:
        raise UserError("the mesh has no triangles of non-zero area", file=mesh_path)
    return v, np.ascontiguousarray(f), part, names


def _quoted(names) -> str:
    return ", ".join(repr(n) for n in names)
