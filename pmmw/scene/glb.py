"""A glTF binary (GLB) read with numpy alone, giving exactly what trimesh gives for the files it covers.

Importing trimesh takes about 0.4 s of a render's start on 2 cores (with the SciPy modules it
imports: spatial, optimize, special, ndimage), more than the rest of the scene's loading. The
usual GLB of a static scene (what pmmw's exporter, `scene.export.export_glb`, and trimesh write,
and Blender for a scene of plain meshes) is simple: every node at the scene's root, with a matrix
or no transform, each mesh one triangle primitive, everything named, no extensions. `read_glb`
reads such a file into the parts trimesh's reader gives (`geometry.load_entry_mesh`: the nodes in
the order of their names, each with its material's name, vertices and faces); for any other file
it returns None and trimesh reads it, with its own checks and messages. `place` applies a node's
matrix as trimesh's ``Trimesh.apply_transform`` does and `closed_and_volume` is trimesh's
watertightness and volume after merging vertices, each by the same numpy operations, so the
results are the same to the bit (tests/scene/test_glb.py compares them on every shipped scene and
on files made to differ).
"""

from __future__ import annotations

import json
import struct

import numpy as np

__all__ = ["closed_and_volume", "place", "read_glb"]

_MAGIC = b"glTF"
_JSON, _BIN = 0x4E4F534A, 0x004E4942  # chunk types
_INDICES = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32}  # accessor componentType -> dtype
_FLOAT = 5126
_TRIANGLES = 4
_TRS = ("translation", "rotation", "scale")
_BASE_FRAME = "world"  # trimesh's name for the scene's root, which a node of that name would be renamed from
_MERGE_DIGITS = 8  # trimesh's tol.merge = 1e-8 as decimal digits: vertices closer are merged


def read_glb(data: bytes) -> list[tuple[str, str, np.ndarray, np.ndarray, np.ndarray]] | None:
    """The parts of a GLB file as trimesh reads them, or None where the file is not of the simple
    kind this reads (module docstring) or anything in it is out of place.

    Parameters
    ----------
    data : bytes
        The whole file.

    Returns
    -------
    list of (node, material, vertices, faces, matrix), or None
        One per node with a mesh, sorted by node name: the node's name, its primitive's material
        name (the mesh's name where the material has none), vertices (V, 3) float64 [m] as stored
        (the file's frame), faces (F, 3) int64, and the node's matrix (4, 4) float64 (parent from
        child, column vectors).
    """
    try:
        tree, blob = _chunks(data)
        return _parts(tree, blob)
    except (ValueError, KeyError, IndexError, TypeError, AttributeError, struct.error, json.JSONDecodeError):
        return None  # whatever is odd, trimesh reads it and says what is wrong


def _chunks(data: bytes) -> tuple[dict, memoryview | None]:
    """The JSON tree and a view of the binary chunk (slices of a view share the file's bytes: a
    large scene is not copied before its arrays are made)."""
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != _MAGIC or version != 2 or length > len(data):
        raise ValueError("not a GLB 2.0 file")
    size, kind = struct.unpack_from("<II", data, 12)
    if kind != _JSON:
        raise ValueError("no JSON chunk first")
    tree = json.loads(data[20 : 20 + size])
    blob = None
    at = 20 + size
    if at + 8 <= length:
        size, kind = struct.unpack_from("<II", data, at)
        if kind == _BIN:
            blob = memoryview(data)[at + 8 : at + 8 + size]
            if len(blob) != size:
                raise ValueError("a truncated binary chunk")
    return tree, blob


def _accessor(tree: dict, blob: memoryview, index: int, kind: str, dtypes: dict) -> np.ndarray:
    """An accessor's values, (count, 3) for VEC3 and (count,) for SCALAR, read only if plain:
    tightly packed in a view of the file's own binary chunk, no sparse values, no extension."""
    a = tree["accessors"][index]
    if a["type"] != kind or "sparse" in a or "extensions" in a or a.get("normalized", False):
        raise ValueError("not a plain accessor")
    dtype = np.dtype(dtypes[a["componentType"]])
    view = tree["bufferViews"][a["bufferView"]]
    per_item = 3 if kind == "VEC3" else 1
    if "extensions" in view or view.get("byteStride", dtype.itemsize * per_item) != dtype.itemsize * per_item:
        raise ValueError("an interleaved or compressed view")
    buffer = tree["buffers"][view["buffer"]]
    if view["buffer"] != 0 or "uri" in buffer or blob is None:
        raise ValueError("a buffer outside the file")
    start = view.get("byteOffset", 0)
    data = blob[start : start + view["byteLength"]]
    if len(data) != view["byteLength"]:
        raise ValueError("a view past the binary chunk")
    offset, count = a.get("byteOffset", 0), a["count"]
    length = dtype.itemsize * count * per_item
    if offset + length > len(data):
        raise ValueError("an accessor past its view")
    values = np.frombuffer(data[offset : offset + length], dtype=dtype)
    return values.reshape((count, 3)) if kind == "VEC3" else values


def _parts(tree: dict, blob: memoryview | None):
    if tree.get("extensionsRequired") or "scenes" not in tree:
        raise ValueError("extensions required, or no scene")
    nodes = tree.get("nodes", [])
    names = [n["name"] for n in nodes]  # a node without a name: KeyError (trimesh numbers it)
    if len(set(names)) != len(names) or _BASE_FRAME in names or not all(isinstance(s, str) and s for s in names):
        raise ValueError("node names trimesh would change")
    meshes = tree.get("meshes", [])
    mesh_names = [m["name"] for m in meshes]
    if len(set(mesh_names)) != len(mesh_names) or not all(isinstance(s, str) and s for s in mesh_names):
        raise ValueError("mesh names trimesh would change")
    materials = tree.get("materials", [])
    out = []
    for i in dict.fromkeys(tree["scenes"][tree.get("scene", 0)].get("nodes", [])):
        node = nodes[i]
        if "children" in node or "camera" in node or "extensions" in node or any(k in node for k in _TRS):
            raise ValueError("a node trimesh places otherwise")
        matrix = np.eye(4)
        if "matrix" in node:
            matrix = np.array(np.array(node["matrix"], dtype=np.float64).reshape((4, 4)).T, dtype=np.float64)
        if "mesh" not in node:
            continue
        mesh = meshes[node["mesh"]]
        if len(mesh["primitives"]) != 1 or "extensions" in mesh:
            raise ValueError("several primitives (trimesh names them at random) or an extension")
        (p,) = mesh["primitives"]
        if p.get("mode", _TRIANGLES) != _TRIANGLES or "extensions" in p or "targets" in p:
            raise ValueError("not plain triangles")
        vertices = _accessor(tree, blob, p["attributes"]["POSITION"], "VEC3", {_FLOAT: np.float32})
        if "indices" in p:
            flat = _accessor(tree, blob, p["indices"], "SCALAR", _INDICES)
            faces = flat.reshape((-1, 3)).astype(np.int64)
        else:
            faces = np.arange(len(vertices), dtype=np.int64).reshape((-1, 3))
        if len(faces) == 0 or faces.max() >= len(vertices):
            raise ValueError("no triangles, or faces past the vertices")
        material = materials[p["material"]].get("name") if "material" in p else None
        if material is not None and not isinstance(material, str):
            raise ValueError("a material name that is not text")
        out.append((names[i], material or mesh["name"], vertices.astype(np.float64), faces, matrix))
    return sorted(out, key=lambda part: part[0])


def _close(a: np.ndarray, b: np.ndarray, atol: float) -> bool:
    """trimesh's ``util.allclose``: the spread of the differences under ``atol``."""
    return bool(float(np.ptp(a - b)) < atol)


def place(vertices: np.ndarray, faces: np.ndarray, matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``vertices`` (V, 3) and ``faces`` (F, 3) moved by the homogeneous ``matrix`` (4, 4) as
    trimesh's ``Trimesh.apply_transform`` moves them: the same products, and the faces' winding
    turned where the matrix mirrors. Returns (vertices, faces)."""
    matrix = np.asanyarray(matrix, order="C", dtype=np.float64)
    if _close(matrix, np.eye(4), 1e-8):
        return vertices, faces
    if len(vertices) and np.abs(matrix - np.eye(4)).max() >= 1e-8:
        stack = np.column_stack((vertices, np.ones(len(vertices))))
        vertices = np.dot(matrix, stack.T).T[:, :3]
    if not _close(matrix[:3, :3], np.eye(3), 1e-6) and np.linalg.det(matrix[:3, :3]) < 0.0:
        faces = np.ascontiguousarray(np.fliplr(faces))
    return vertices, faces


def closed_and_volume(vertices: np.ndarray, faces: np.ndarray) -> tuple[bool, float]:
    """Whether the mesh is closed once vertices closer than 1e-8 m are merged (every edge shared by
    exactly two faces), and its signed volume [m^3] (NaN when open): trimesh's ``merge_vertices``,
    ``is_watertight`` and ``volume`` (Eberly's polyhedral integral), by the same operations.

    Parameters
    ----------
    vertices : ndarray, shape (V, 3), float64 [m]
    faces : ndarray, shape (F, 3), int64
    """
    if len(faces) == 0:
        return False, float("nan")
    referenced = np.zeros(len(vertices), dtype=bool)
    referenced[faces] = True
    keys = (vertices * (10**_MERGE_DIGITS)).round().astype(np.int64)
    ref = np.nonzero(referenced)[0]
    _, first, inverse = np.unique(keys[ref], axis=0, return_index=True, return_inverse=True)
    rep = np.zeros(len(vertices), dtype=np.int64)
    rep[ref] = ref[first[inverse.reshape(-1)]]  # each vertex's first equal one, as trimesh keeps
    merged = rep[faces]
    edges = np.sort(merged[:, [0, 1, 1, 2, 2, 0]].reshape((-1, 2)), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    if not (counts == 2).all():
        return False, float("nan")
    triangles = vertices[merged]
    vectors = np.diff(triangles, axis=1)
    crosses = np.cross(vectors[:, 0], vectors[:, 1])
    f1 = triangles[:, 0, :] + triangles[:, 1, :] + triangles[:, 2, :]
    return True, float((crosses[:, 0] * f1[:, 0]).sum() / 6.0)
