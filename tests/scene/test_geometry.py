"""Mesh loading, frames, transforms, material assignment and mesh checks (scene/geometry.py)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh
from trimesh.visual import TextureVisuals
from trimesh.visual.material import PBRMaterial

from pmmw.errors import UserError, clear_warnings, collected_warnings
from pmmw.scene.geometry import build_geometry, entry_transform, load_entry_mesh

REPO = Path(__file__).resolve().parents[2]
CINDERBLOCKS = REPO / "scenes" / "cinderblocks" / "cinderblocks.glb"

# Vertex positions go through float64 transforms only (GLB stores float32: see GLB_ATOL).
ATOL = 1e-12
GLB_ATOL = 1e-6  # [m], float32 storage in a GLB at coordinates of order 1 m


@pytest.fixture(autouse=True)
def _fresh_warnings():
    clear_warnings()
    yield
    clear_warnings()


def entry(mesh, key="scene[0]", material=None, materials=None, transform=None, up_axis=None, name=None):
    return SimpleNamespace(
        mesh=Path(mesh),
        material=material,
        materials=materials,
        transform=transform,
        up_axis=up_axis,
        name=name,
        key=key,
    )


def tf(translate=(0.0, 0.0, 0.0), rotate_deg=(0.0, 0.0, 0.0), scale=1.0):
    return SimpleNamespace(translate=np.array(translate, float), rotate_deg=np.array(rotate_deg, float), scale=scale)


def write_obj(path, vertices, faces, materials=None):
    """OBJ text: ``materials`` is one usemtl name per face (None: no usemtl)."""
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in vertices]
    current = object()
    for i, f in enumerate(faces):
        if materials is not None and materials[i] != current:
            current = materials[i]
            lines.append(f"usemtl {current}")
        lines.append("f " + " ".join(str(k + 1) for k in f))
    path.write_text("\n".join(lines) + "\n")
    return path


def box_mesh(extents=(1.0, 2.0, 3.0), center=(0.0, 0.0, 0.0)):
    m = trimesh.creation.box(extents=extents)
    m.apply_translation(center)
    return m


def signed_volume(vertices, faces):
    tri = vertices[faces]
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0)


# -- frames -------------------------------------------------------------------------------


def test_gltf_y_up_becomes_z_up(tmp_path):
    # A triangle in glTF coordinates (Y up), under a node that moves it 5 m along glTF +x.
    tri = trimesh.Trimesh([[1.0, 2.0, 3.0], [2.0, 2.0, 3.0], [1.0, 4.0, 3.0]], [[0, 1, 2]], process=False)
    tri.visual = TextureVisuals(material=PBRMaterial(name="paint"))
    scene = trimesh.Scene()
    scene.add_geometry(
        tri, geom_name="t", node_name="t", transform=trimesh.transformations.translation_matrix([5.0, 0.0, 0.0])
    )
    path = tmp_path / "tri.glb"
    scene.export(path)

    ((name, mesh),) = load_entry_mesh(path)
    assert name == "paint"
    # (x, y, z)_gltf -> (x, -z, y)_world, after the node transform
    expected = np.array([[6.0, -3.0, 2.0], [7.0, -3.0, 2.0], [6.0, -3.0, 4.0]])
    np.testing.assert_allclose(mesh.vertices[mesh.faces[0]], expected, atol=GLB_ATOL)
    # The up axis of glTF's +y is the world +z, and the winding (normal) turns with it.
    np.testing.assert_allclose(mesh.face_normals[0], [0.0, -1.0, 0.0], atol=1e-12)

    ((_, as_is),) = load_entry_mesh(path, up_axis="z")
    np.testing.assert_allclose(
        as_is.vertices[as_is.faces[0]], [[6.0, 2.0, 3.0], [7.0, 2.0, 3.0], [6.0, 4.0, 3.0]], atol=GLB_ATOL
    )


def test_obj_is_z_up_unless_told(tmp_path):
    path = write_obj(tmp_path / "t.obj", [[0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 1.0]], [[0, 1, 2]])
    ((name, mesh),) = load_entry_mesh(path)
    assert name == ""
    np.testing.assert_allclose(
        mesh.vertices[mesh.faces[0]], [[0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 1.0]], atol=ATOL
    )
    ((_, y_up),) = load_entry_mesh(path, up_axis="y")
    np.testing.assert_allclose(
        y_up.vertices[y_up.faces[0]], [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, -1.0, 1.0]], atol=ATOL
    )


# -- materials ----------------------------------------------------------------------------

OBJ_V = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
OBJ_F = [[0, 1, 2], [0, 2, 3], [0, 1, 4]]  # two faces in z = 0, one standing up


@pytest.mark.parametrize("with_mtl", [False, True])
def test_obj_usemtl_groups_map_per_face(tmp_path, with_mtl):
    path = write_obj(tmp_path / "two.obj", OBJ_V, OBJ_F, ["red", "blue", "red"])
    if with_mtl:
        (tmp_path / "two.mtl").write_text("newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n")
        path.write_text("mtllib two.mtl\n" + path.read_text())
    parts = load_entry_mesh(path)
    assert sorted((n, len(m.faces)) for n, m in parts) == [("blue", 1), ("red", 2)]

    geom = build_geometry([entry(path, materials={"red": "brick", "blue": "metal"})], scenario_file="s.yaml")
    assert sorted(geom.material_ids) == ["brick", "metal"]
    mat = np.array(geom.material_ids)[geom.face_material]
    centroids = geom.vertices[geom.faces].mean(axis=1)
    for c, m in zip(centroids, mat):
        # face 1 (x + y > 1 side of the square, z = 0) is blue; faces 0 and 2 are red
        is_face1 = abs(c[2]) < ATOL and c[1] > c[0]
        assert m == ("metal" if is_face1 else "brick")
    assert geom.objects == ["scene[0]:two.obj"]
    assert np.all(geom.face_object == 0)


def test_single_material_for_every_face(tmp_path):
    path = write_obj(tmp_path / "two.obj", OBJ_V, OBJ_F, ["red", "blue", "red"])
    geom = build_geometry([entry(path, material="metal", name="beacon")])
    assert geom.material_ids == ["metal"]
    assert np.all(geom.face_material == 0)
    assert geom.objects == ["scene[0]:beacon"]


def test_missing_mesh_material_name_is_a_user_error(tmp_path):
    path = write_obj(tmp_path / "two.obj", OBJ_V, OBJ_F, ["red", "blue", "red"])
    good = write_obj(tmp_path / "one.obj", OBJ_V, OBJ_F)
    with pytest.raises(UserError) as info:
        build_geometry(
            [
                entry(good, key="scene[0]", material="brick"),
                entry(path, key="scene[1]", materials={"red": "brick", "green": "metal"}),
            ],
            scenario_file="scenario.yaml",
        )
    errors = getattr(info.value, "errors", [info.value])
    assert len(errors) == 1
    err = errors[0]
    assert err.key == "scene[1].materials" and err.file == "scenario.yaml"
    assert "'blue'" in err.message and "'red'" in err.message  # missing, and what the mesh has
    assert "scene[1].materials" in str(info.value)


def test_unused_map_entry_warns(tmp_path):
    path = write_obj(tmp_path / "two.obj", OBJ_V, OBJ_F, ["red", "blue", "red"])
    build_geometry([entry(path, materials={"red": "brick", "blue": "metal", "green": "glass"})])
    assert any("'green'" in w and "scene[0].materials" in w for w in collected_warnings())


def test_material_choice_errors(tmp_path):
    path = write_obj(tmp_path / "t.obj", OBJ_V, OBJ_F)
    with pytest.raises(UserError, match="no material"):
        build_geometry([entry(path)], scenario_file="s.yaml")
    with pytest.raises(UserError, match="not both"):
        build_geometry([entry(path, material="brick", materials={"": "brick"})], scenario_file="s.yaml")


# -- transforms ---------------------------------------------------------------------------


def test_transform_order_scale_rotate_translate(tmp_path):
    path = write_obj(tmp_path / "t.obj", [[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], [[0, 1, 2]])
    t = tf(translate=(10.0, 20.0, 30.0), rotate_deg=(90.0, 90.0, 0.0), scale=[1.0, 2.0, 3.0])
    geom = build_geometry([entry(path, material="brick", transform=t)])
    # (0, 1, 0) -scale-> (0, 2, 0) -about X-> (0, 0, 2) -about Y-> (2, 0, 0) -translate-> (12, 20, 30)
    # (rotating before scaling would give (11, 20, 30); about Y first, (10, 20, 32))
    moved = geom.vertices[geom.faces[0, 0]]
    np.testing.assert_allclose(moved, [12.0, 20.0, 30.0], atol=ATOL)

    a, shift = entry_transform(t)
    np.testing.assert_allclose(a @ [0.0, 1.0, 0.0] + shift, [12.0, 20.0, 30.0], atol=ATOL)
    a0, t0 = entry_transform(None)
    np.testing.assert_array_equal(a0, np.eye(3))
    np.testing.assert_array_equal(t0, np.zeros(3))


def test_up_axis_conversion_comes_before_the_transform(tmp_path):
    path = write_obj(tmp_path / "t.obj", [[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], [[0, 1, 2]])
    t = tf(translate=(0.0, 0.0, 5.0), scale=[1.0, 1.0, 2.0])
    geom = build_geometry([entry(path, material="brick", transform=t, up_axis="y")])
    # (0, 1, 0) Y-up -> (0, 0, 1) Z-up -> scale z by 2 -> (0, 0, 2) -> (0, 0, 7)
    np.testing.assert_allclose(geom.vertices[geom.faces[0, 0]], [0.0, 0.0, 7.0], atol=ATOL)


def test_mirroring_scale_keeps_normals_outward(tmp_path):
    path = tmp_path / "box.ply"
    box_mesh().export(path)
    geom = build_geometry([entry(path, material="brick", transform=tf(scale=[-1.0, 1.0, 1.0]))])
    assert signed_volume(geom.vertices, geom.faces) == pytest.approx(6.0)
    assert not any("inside out" in w for w in collected_warnings())


def test_singular_transform_is_a_user_error(tmp_path):
    path = tmp_path / "box.stl"
    box_mesh().export(path)
    with pytest.raises(UserError) as info:
        build_geometry([entry(path, material="brick", transform=tf(scale=0.0))], scenario_file="s.yaml")
    assert info.value.errors[0].key == "scene[0].transform"


# -- mesh checks --------------------------------------------------------------------------


def test_inside_out_box_is_fixed_with_a_warning(tmp_path):
    m = box_mesh(center=(1.0, 2.0, 3.0))
    m.invert()
    path = tmp_path / "inside_out.obj"
    write_obj(path, m.vertices, m.faces)
    assert signed_volume(np.asarray(m.vertices), np.asarray(m.faces)) < 0
    geom = build_geometry([entry(path, material="brick")])
    assert signed_volume(geom.vertices, geom.faces) == pytest.approx(6.0)
    centre = np.array([1.0, 2.0, 3.0])
    outward = np.einsum("ij,ij->i", geom.face_normals, geom.vertices[geom.faces].mean(axis=1) - centre)
    assert np.all(outward > 0)
    assert geom.object_watertight == [True]
    assert any("inside out" in w for w in collected_warnings())


def test_hollow_shell_is_not_turned(tmp_path):
    outer = box_mesh((2.0, 2.0, 2.0))
    inner = box_mesh((1.0, 1.0, 1.0))
    inner.invert()  # the cavity's faces point into the cavity, away from the material
    shell = trimesh.util.concatenate([outer, inner])
    path = tmp_path / "shell.ply"
    shell.export(path)
    geom = build_geometry([entry(path, material="brick")])
    assert signed_volume(geom.vertices, geom.faces) == pytest.approx(7.0)
    assert not any("inside out" in w for w in collected_warnings())


def test_watertight_flags(tmp_path):
    closed = tmp_path / "closed.stl"
    box_mesh().export(closed)
    m = box_mesh(center=(5.0, 0.0, 0.0))
    opened = tmp_path / "open.obj"
    write_obj(opened, m.vertices, m.faces[:-1])  # one triangle missing
    geom = build_geometry(
        [entry(closed, key="scene[0]", material="brick"), entry(opened, key="scene[1]", material="glass")]
    )
    # STL stores every triangle's corners separately: watertightness is judged after merging
    assert geom.object_watertight == [True, False]
    assert geom.objects == ["scene[0]:closed.stl", "scene[1]:open.obj"]
    assert np.bincount(geom.face_object).tolist() == [12, 11]
    assert geom.material_ids == ["brick", "glass"]
    np.testing.assert_allclose(geom.bounds, [[-0.5, -1.0, -1.5], [5.5, 1.0, 1.5]], atol=1e-6)


def test_degenerate_faces_are_dropped_with_a_count(tmp_path):
    v = OBJ_V + [[2.0, 0.0, 0.0]]
    path = write_obj(tmp_path / "d.obj", v, OBJ_F + [[0, 1, 5], [2, 2, 3]])
    geom = build_geometry([entry(path, material="brick")])
    assert len(geom.faces) == 3
    np.testing.assert_allclose(np.linalg.norm(geom.face_normals, axis=1), 1.0, atol=1e-15)
    assert any("dropped 2 degenerate" in w for w in collected_warnings())


def test_unreadable_and_empty_meshes_are_user_errors(tmp_path):
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"not a glb at all")
    with pytest.raises(UserError) as info:
        load_entry_mesh(bad)
    assert info.value.file == str(bad)

    empty = tmp_path / "empty.obj"
    empty.write_text("v 0 0 0\nv 1 0 0\n")
    with pytest.raises(UserError) as info:
        load_entry_mesh(empty)
    assert info.value.file == str(empty)

    with pytest.raises(UserError) as info:
        build_geometry([entry(tmp_path / "nowhere.glb", material="brick")], scenario_file="s.yaml")
    assert info.value.errors[0].key == "scene[0].mesh"

    with pytest.raises(UserError, match="unsupported mesh format"):
        load_entry_mesh(tmp_path / "x.fbx")


# -- the shipped cinderblocks scene -------------------------------------------------------


def test_shipped_cinderblocks_scene():
    parts = load_entry_mesh(CINDERBLOCKS)
    assert {name for name, _ in parts} == {"ground", "cinderblock"}
    for name, mesh in parts:
        merged = mesh.copy()
        merged.merge_vertices()
        assert merged.is_watertight, name
        assert merged.volume > 0.0, name  # outward normals
    blocks = [m for n, m in parts if n == "cinderblock"]
    assert len(blocks) == 5
    for b in blocks:
        merged = b.copy()
        merged.merge_vertices()
        assert merged.euler_number == -2  # two through-cavities: genus 2
        assert b.bounds[0][2] > 0.0  # above the ground, not touching it
    (ground,) = [m for n, m in parts if n == "ground"]
    assert ground.bounds[1][2] == pytest.approx(0.0, abs=GLB_ATOL)

    geom = build_geometry(
        [entry(CINDERBLOCKS, materials={"ground": "sand", "cinderblock": "concrete"})], scenario_file="s.yaml"
    )
    assert set(geom.material_ids) == {"sand", "concrete"}
    assert geom.object_watertight == [True]
    assert not collected_warnings()
    assert signed_volume(geom.vertices, geom.faces) > 0.0


def test_errors_of_all_entries_are_reported_together(tmp_path):
    path = write_obj(tmp_path / "t.obj", OBJ_V, OBJ_F, ["red", "red", "red"])
    with pytest.raises(UserError) as info:
        build_geometry(
            [
                entry(path, key="scene[0]"),
                entry(path, key="scene[1]", material="brick"),
                entry(path, key="scene[2]", materials={"blue": "metal"}),
            ],
            scenario_file="s.yaml",
        )
    assert [e.key for e in info.value.errors] == ["scene[0]", "scene[2].materials"]


def test_empty_scene():
    geom = build_geometry([])
    assert geom.vertices.shape == (0, 3) and geom.faces.shape == (0, 3)
    assert geom.objects == [] and geom.material_ids == []
