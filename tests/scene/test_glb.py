"""The GLB read without trimesh (`pmmw.scene.glb`) against trimesh itself (the reference, an
independent reader): the same parts to the bit, the same closedness and volume, and trimesh
taking over every file outside what it reads."""

import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from pmmw.scene import geometry, glb

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "scenes").rglob("*.glb"))


def _same(got, ref) -> bool:
    """Parts equal to the bit: names in order, vertices and faces."""
    return [n for n, _ in got] == [n for n, _ in ref] and all(
        np.array_equal(np.asarray(a.vertices), np.asarray(b.vertices))
        and np.array_equal(np.asarray(a.faces), np.asarray(b.faces))
        for (_, a), (_, b) in zip(got, ref)
    )


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_every_shipped_scene_reads_as_trimesh_reads_it(path):
    assert len(SHIPPED) >= 13
    for up_axis in (None, "y", "z"):
        got = geometry._entry_parts(path, up_axis)
        assert all(isinstance(m, geometry._Part) for _, m in got)  # read without trimesh
        assert _same(got, geometry.load_entry_mesh(path, up_axis)), (path.name, up_axis)


def _glb(nodes: list[dict], materials=("paint", None), extra: dict | None = None, tweak=None) -> bytes:
    """A GLB of ``nodes``: each {name, mesh (its name), vertices (V, 3), faces (F, 3) or None
    (unindexed), dtype of the indices, matrix (16 numbers) or absent, material index or absent,
    primitives (how many copies of the primitive), any other node keys under ``node``}."""
    blob, views, accessors, meshes, out_nodes = b"", [], [], [], []

    def add(array: np.ndarray, kind: str, component: int) -> int:
        nonlocal blob
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": array.nbytes})
        blob += array.tobytes() + b"\0" * (-array.nbytes % 4)
        accessors.append({"bufferView": len(views) - 1, "componentType": component, "count": len(array), "type": kind})
        return len(accessors) - 1

    for n in nodes:
        v = np.asarray(n["vertices"], np.float32)
        prim = {"attributes": {"POSITION": add(v, "VEC3", 5126)}}
        if n.get("faces") is not None:
            dtype = n.get("dtype", np.uint32)
            component = {np.uint8: 5121, np.uint16: 5123, np.uint32: 5125}[dtype]
            prim["indices"] = add(np.asarray(n["faces"], dtype).ravel(), "SCALAR", component)
        if "material" in n:
            prim["material"] = n["material"]
        meshes.append({"name": n["mesh"], "primitives": [prim] * n.get("primitives", 1)})
        node = {"name": n["name"], "mesh": len(meshes) - 1, **n.get("node", {})}
        if "matrix" in n:
            node["matrix"] = list(n["matrix"])
        out_nodes.append(node)
    tree = {
        "asset": {"version": "2.0", "extras": {"up_axis": "Y"}},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(out_nodes)))}],
        "nodes": out_nodes,
        "meshes": meshes,
        "materials": [{"name": m} if m is not None else {} for m in materials],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob)}],
        **(extra or {}),
    }
    if tweak is not None:  # a change to the tree that the node list cannot say
        tweak(tree)
    text = json.dumps(tree).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blob), 0x004E4942) + blob
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


_BOX = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
_TET_V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
_TET_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
# a rotation of 30 deg about z, a translation, and a mirror in x (column-major, as glTF stores them)
_C, _S = np.cos(np.pi / 6), np.sin(np.pi / 6)
_TURNED = [_C, _S, 0, 0, -_S, _C, 0, 0, 0, 0, 1, 0, 5.0, -2.0, 0.25, 1]
_MIRRORED = [-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]

# files inside what `read_glb` reads: each differs from the shipped ones in one way
READ = {
    "turned, mirrored, 8- and 16-bit indices": [
        {"name": "b", "mesh": "B", "vertices": _BOX.vertices, "faces": _BOX.faces, "matrix": _TURNED, "material": 0},
        {"name": "a", "mesh": "A", "vertices": _TET_V, "faces": _TET_F, "matrix": _MIRRORED, "dtype": np.uint8},
        {"name": "c", "mesh": "C", "vertices": _TET_V + 3.0, "faces": _TET_F, "dtype": np.uint16, "material": 1},
    ],
    "unindexed, nearly the identity": [
        {"name": "u", "mesh": "U", "vertices": _TET_V[_TET_F].reshape(-1, 3), "faces": None, "material": 0},
        {"name": "v", "mesh": "V", "vertices": _TET_V, "faces": _TET_F, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1e-9, 0, 0, 1]},
    ],
}  # fmt: skip
# files outside it: trimesh reads them (several primitives, a hierarchy, TRS, an unnamed node, a
# node named like trimesh's root, a compressed mesh)
_T = {"name": "t", "mesh": "T", "vertices": _TET_V, "faces": _TET_F}
NOT_READ = {
    "two primitives": [dict(_T, primitives=2)],
    "a child": [dict(_T, node={"children": []})],
    "translation": [dict(_T, node={"translation": [1.0, 2.0, 3.0]})],
    "named world": [dict(_T, name="world")],
    "extension required": [dict(_T)],
}


def _set(where: str, key: str, value):
    def tweak(tree):
        tree[where][0][key] = value

    return tweak


# trees the reader must refuse (then trimesh reads them or says what is wrong): the accessor and
# view forms it does not read, each on the first accessor (POSITION) or view of a plain file
REFUSED = {
    "an interleaved view (byteStride)": _set("bufferViews", "byteStride", 16),
    "a normalized accessor": _set("accessors", "normalized", True),
    "a sparse accessor": _set("accessors", "sparse", {"count": 1}),
    "quantized positions (16-bit)": _set("accessors", "componentType", 5123),
    "an accessor without a view": lambda tree: tree["accessors"][0].pop("bufferView"),
    "a buffer outside the file": _set("buffers", "uri", "data.bin"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_the_forms_the_reader_does_not_read_are_refused(case):
    assert glb.read_glb(_glb([_T], tweak=REFUSED[case])) is None
    assert glb.read_glb(_glb([_T])) is not None  # the control: the same file untouched is read


def test_an_unindexed_mesh_of_a_count_not_a_multiple_of_three_is_refused():
    four = dict(_T, vertices=_TET_V, faces=None)  # 4 vertices: no whole triangle list
    assert glb.read_glb(_glb([four])) is None
    assert glb.read_glb(_glb([dict(four, vertices=_TET_V[:3])])) is not None  # the control: 3 are one triangle


@pytest.mark.parametrize("case", sorted(READ))
def test_files_made_to_differ_read_as_trimesh_reads_them(tmp_path, case):
    path = tmp_path / "m.glb"
    path.write_bytes(_glb(READ[case]))
    assert glb.read_glb(path.read_bytes()) is not None
    for up_axis in (None, "z"):
        got = geometry._entry_parts(path, up_axis)
        assert all(isinstance(m, geometry._Part) for _, m in got)
        assert _same(got, geometry.load_entry_mesh(path, up_axis)), up_axis


@pytest.mark.parametrize("case", sorted(NOT_READ))
def test_trimesh_reads_every_other_file(tmp_path, case):
    path = tmp_path / "m.glb"
    extra = {"extensionsRequired": ["KHR_draco_mesh_compression"]} if case == "extension required" else None
    path.write_bytes(_glb(NOT_READ[case], extra=extra))
    assert glb.read_glb(path.read_bytes()) is None
    got = geometry._entry_parts(path)
    assert all(isinstance(m, trimesh.Trimesh) for _, m in got)


def _trimesh_closed_and_volume(vertices, faces):
    merged = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    merged.merge_vertices()
    closed = bool(merged.is_watertight)
    return closed, float(merged.volume) if closed else float("nan")


def _split_corner(offset: float):
    """The box with its first corner as two vertices ``offset`` [m] apart, each used by some faces."""
    v = np.vstack([_BOX.vertices, _BOX.vertices[:1] + offset])
    f = _BOX.faces.copy()
    first = np.nonzero((f == 0).any(axis=1))[0][0]
    f[first][f[first] == 0] = len(v) - 1
    return v, f


CLOSED_CASES = {
    "box": (_BOX.vertices, _BOX.faces),
    "inside out": (_BOX.vertices, _BOX.faces[:, ::-1]),
    "a face missing": (_BOX.vertices, _BOX.faces[1:]),
    "a corner split by 1e-9 m (merged)": _split_corner(1e-9),
    "a corner split by 1e-6 m (open)": _split_corner(1e-6),
    "tetrahedron far out": (_TET_V * 0.37 + 1e4, _TET_F),
}


@pytest.mark.parametrize("case", sorted(CLOSED_CASES))
def test_closed_and_volume_are_trimeshs(case):
    # equality to the bit: the same operations on the same numbers; the cases span both answers
    v, f = CLOSED_CASES[case]
    got, ref = glb.closed_and_volume(v, f), _trimesh_closed_and_volume(v, f)
    assert got[0] == ref[0] and (np.isnan(ref[1]) and np.isnan(got[1]) or got[1] == ref[1]), (got, ref)


def test_closed_and_volume_of_the_shipped_parts():
    # every shipped part is closed (the open cases are above); up to 40 parts a file, and each
    # file's parts together, as `build_geometry` checks a scene entry
    for path in SHIPPED:
        parts = geometry.load_entry_mesh(path)
        meshes = [(np.asarray(m.vertices), np.asarray(m.faces)) for _, m in parts[:40]]
        meshes.append((np.concatenate([v for v, _ in meshes]), np.concatenate(_offset([f for _, f in meshes], meshes))))
        for v, f in meshes:
            got, ref = glb.closed_and_volume(v, f), _trimesh_closed_and_volume(v, f)
            assert got[0] == ref[0] and (not ref[0] or got[1] == ref[1]), path.name


def _offset(faces, meshes):
    starts = np.cumsum([0] + [len(v) for v, _ in meshes[:-1]])
    return [f + s for f, s in zip(faces, starts)]


def test_a_glb_scene_resolves_without_importing_trimesh(tmp_path):
    # the landing (GLB) resolves without trimesh; the control, an OBJ scene, imports it
    from tests.scenes import tiny_scenario

    code = "import sys\nfrom pmmw.pipeline import resolve\nresolve(sys.argv[1])\nprint('trimesh' in sys.modules)\n"
    tiny = tiny_scenario(tmp_path)  # OBJ meshes
    runs = [
        subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True, cwd=ROOT)
        for p in (ROOT / "configs" / "landing_95ghz.yaml", tiny)
    ]
    assert [r.stdout.split() for r in runs] == [["False"], ["True"]], [r.stderr[-500:] for r in runs]
