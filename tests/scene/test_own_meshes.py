"""A user's own mesh files: the up axis a glTF states or its exporter implies, and what to do when a
mesh has no material names (docs/scenes.md)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

from pmmw.errors import UserError, clear_warnings, collected_warnings
from pmmw.scene.export import export_glb
from pmmw.scene.geometry import build_geometry, file_up_axis

# the box's extents are exact small numbers stored as float32 in the GLB: 1e-6 m is far below any
# difference between lying and standing (1 m)
ATOL = 1e-6


def _entry(mesh, **kw):
    return SimpleNamespace(
        mesh=Path(mesh),
        material=kw.get("material"),
        materials=kw.get("materials"),
        transform=None,
        up_axis=kw.get("up_axis"),
        name=None,
        key="scene[0]",
    )


def _upright_box() -> trimesh.Trimesh:
    """A 1 x 1 m box 2 m tall, standing on z = 0 in trimesh's (and pmmw's) Z-up frame."""
    m = trimesh.creation.box(extents=[1.0, 1.0, 2.0])
    m.apply_translation([0.0, 4.0, 1.0])
    return m


def _extent(path, **kw):
    clear_warnings()
    geom = build_geometry([_entry(path, material="metal", **kw)])
    return np.ptp(geom.vertices, axis=0), collected_warnings()


def test_a_trimesh_glb_of_an_upright_box_is_warned_about_with_the_fix(tmp_path):
    """trimesh writes its Z-up coordinates into the glTF as they are: read as glTF's Y-up the box
    lies down (2 m along y). Before, nothing was said unless the scene was wide and flat."""
    path = tmp_path / "box.glb"
    _upright_box().export(path)
    ext, warnings = _extent(path)
    assert np.allclose(ext, [1.0, 2.0, 1.0], atol=ATOL)  # lying: the glTF's z is the world's -y
    assert len(warnings) == 1 and "box.glb" in warnings[0] and "`up_axis: z`" in warnings[0], warnings
    # the fix it names stands the box up, and says nothing more
    ext, warnings = _extent(path, up_axis="z")
    assert np.allclose(ext, [1.0, 1.0, 2.0], atol=ATOL) and warnings == []
    assert file_up_axis(path, "z") == "z" and file_up_axis(path) == "y"


def test_a_glb_that_states_its_up_axis_is_read_so(tmp_path):
    """``asset.extras.up_axis`` in the file: Z is read upright without a warning; pmmw's own
    exporter states Y (its scenes turn Z-up geometry into Y-up), read upright without a warning."""
    stated = tmp_path / "stated_z.glb"
    scene = trimesh.Scene(_upright_box())

    def state_z(tree):
        tree["asset"]["extras"] = {"up_axis": "Z"}

    scene.export(stated, file_type="glb", tree_postprocessor=state_z)
    ext, warnings = _extent(stated)
    assert np.allclose(ext, [1.0, 1.0, 2.0], atol=ATOL) and warnings == []
    assert file_up_axis(stated) == "z"
    ours = tmp_path / "ours.glb"
    export_glb({"box": ("metal", _upright_box())}, ours)
    ext, warnings = _extent(ours)
    assert np.allclose(ext, [1.0, 1.0, 2.0], atol=ATOL) and warnings == []
    assert file_up_axis(ours) == "y"


def _ground_and_tower() -> trimesh.Trimesh:
    """A 10 x 10 m ground slab 0.1 m thick with a 1 x 1 x 8 m tower on it, Z-up: once turned as a
    Y-up file it is 8.1 m along y against 10 x 10 m, not flat enough to be caught as lying on its
    edge (5 times thinner), which is what the ground's check is for."""
    ground = trimesh.creation.box(extents=[10.0, 10.0, 0.1])
    ground.apply_translation([0.0, 0.0, -0.05])
    tower = trimesh.creation.box(extents=[1.0, 1.0, 8.0])
    tower.apply_translation([0.0, 0.0, 4.0])
    return trimesh.util.concatenate([ground, tower])


def _export_as(mesh: trimesh.Trimesh, path: Path, generator: str) -> Path:
    """``mesh`` in a GLB whose ``asset.generator`` names another exporter, stating no up axis."""

    def name_it(tree):
        tree["asset"]["generator"] = generator

    trimesh.Scene(mesh).export(path, file_type="glb", tree_postprocessor=name_it)
    return path


# Blender's glTF exporter with "+Y Up" unticked writes Blender's Z-up coordinates as they are
BLENDER = "Khronos glTF Blender I/O v4.2.70"


def test_a_z_up_glb_of_another_exporter_is_warned_about_by_its_ground(tmp_path):
    """A Z-up scene with a ground and a tower, from an exporter that states nothing: read as Y-up the
    ground stands on its edge and the tower lies along y. Before, nothing was said (the scene is not
    5 times thinner along y than across); now one warning names the fix, and the fix reads it upright
    without a warning."""
    path = _export_as(_ground_and_tower(), tmp_path / "yard.glb", BLENDER)
    ext, warnings = _extent(path)
    assert np.allclose(ext, [10.0, 8.1, 10.0], atol=ATOL)  # on its edge: the file's z is the world's -y
    assert len(warnings) == 1 and "yard.glb" in warnings[0] and "ground stands on its edge" in warnings[0]
    assert "`up_axis: z`" in warnings[0] and "Khronos" in warnings[0], warnings
    ext, warnings = _extent(path, up_axis="z")
    assert np.allclose(ext, [10.0, 10.0, 8.1], atol=ATOL) and warnings == []


def test_a_y_up_glb_of_another_exporter_is_read_upright_without_a_warning(tmp_path):
    """The control: the same scene turned to Y-up before export (as the exporter does by default),
    and a lone upright box (flat ends both ways: no sound signal, so no warning either way)."""
    to_y_up = trimesh.transformations.rotation_matrix(-np.pi / 2, [1.0, 0.0, 0.0])  # (x, y, z) -> (x, z, -y)
    path = _export_as(_ground_and_tower().apply_transform(to_y_up), tmp_path / "yard.glb", BLENDER)
    ext, warnings = _extent(path)
    assert np.allclose(ext, [10.0, 10.0, 8.1], atol=ATOL) and warnings == []
    box = _export_as(_upright_box(), tmp_path / "box.glb", BLENDER)
    ext, warnings = _extent(box)
    assert np.allclose(ext, [1.0, 2.0, 1.0], atol=ATOL) and warnings == []


def test_validate_prints_each_objects_bounds_and_up_axis(tmp_path):
    from pmmw.pipeline import validate

    path = tmp_path / "box.glb"
    _upright_box().export(path)
    scn = tmp_path / "s.yaml"
    scn.write_text(
        "name: s\nfrequency: 35 GHz\nimager: {position: [0, 0, 1], look_at: [0, 4, 1], fov: 20 deg, "
        "resolution: [8, 6]}\nscene:\n  - {mesh: box.glb, material: metal, up_axis: z}\n"
        "sky: {model: uniform, temperature: 40 K}\n"
    )
    obj = validate(scn)["geometry"]["objects"]["scene[0]:box.glb"]
    assert obj["file_up_axis"] == "z"
    assert np.allclose(obj["bounds_m"], [[-0.5, 3.5, 0.0], [0.5, 4.5, 2.0]], atol=1e-4)


@pytest.mark.parametrize(
    "suffix, words",
    [
        (".obj", ["no `usemtl` line", "`material: ID`", "`usemtl NAME`"]),
        (".stl", ["is STL, which carries no material names", "`material: ID`"]),
        (".ply", ["is PLY, which carries no material names", "`material: ID`"]),
    ],
)
def test_a_mesh_without_material_names_says_how_to_give_them(tmp_path, suffix, words):
    """Before: "mesh material name(s) '' of box.obj are not in the map; the mesh has ''"."""
    path = tmp_path / f"box{suffix}"
    _upright_box().export(path)
    with pytest.raises(UserError) as info:
        build_geometry([_entry(path, materials={"box": "metal"})], scenario_file="s.yaml")
    err = getattr(info.value, "errors", [info.value])[0]
    assert err.file == "s.yaml" and err.key == "scene[0].materials"
    assert all(w in err.message for w in words), err.message
    assert f"box{suffix}" in err.message and "docs/scenes.md" in err.message
    assert "''" not in err.message
    # the control: `material:` for the whole mesh is accepted
    assert build_geometry([_entry(path, material="metal")]).material_ids == ["metal"]


def test_obj_faces_before_the_first_usemtl_are_named_in_the_error(tmp_path):
    path = tmp_path / "two.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nusemtl red\nf 1 2 4\n")
    with pytest.raises(UserError) as info:
        build_geometry([_entry(path, materials={"red": "metal"})])
    err = getattr(info.value, "errors", [info.value])[0]
    assert "before its first `usemtl` line" in err.message and "'': ID" in err.message
    # mapping the empty name is the other way out
    geom = build_geometry([_entry(path, materials={"red": "metal", "": "brick"})])
    assert sorted(geom.material_ids) == ["brick", "metal"]
