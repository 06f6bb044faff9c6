"""Blender, both ways (docs/blender.md): the add-on's mapping of a Blender scene to a scenario (pure
Python, always run), its EXR reader against OpenImageIO, the add-on's zip, and, with Blender's
``bpy`` package, the exporter itself: the camera against Blender's own projection, meshes placed
and upright as Blender has them, the shipped example .blend made by its script and rendering to
the same image as its exported scenario.

The bpy tests run Blender in a subprocess with ``PMMW_BLENDER_PYTHON`` or, where pmmw's Python has
``bpy`` (``pip install 'pmmw[blender]'``), that Python; without either they skip.
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import yaml

from pmmw.blender import ADDON, addon_zip, scenario_of_blend
from pmmw.blender.pmmw_blender import exr, mapping
from pmmw.blender.pmmw_blender.mapping import ExportError

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "scenes" / "blender" / "example.blend"
BPY_PYTHON = os.environ.get("PMMW_BLENDER_PYTHON") or (sys.executable if importlib.util.find_spec("bpy") else None)
needs_bpy = pytest.mark.skipif(
    BPY_PYTHON is None,
    reason="needs Blender's bpy package: pip install 'pmmw[blender]' "
    "(Python 3.11), or PMMW_BLENDER_PYTHON set to a Python that has it",
)


def _camera(**kw) -> dict:
    cam = {
        "name": "Camera",
        "matrix_world": np.eye(4).tolist(),
        "type": "PERSP",
        "lens": 35.0,
        "sensor_width": 36.0,
        "sensor_height": 24.0,
        "sensor_fit": "AUTO",
        "shift_x": 0.0,
        "shift_y": 0.0,
        "resolution": [40, 30],
        "percentage": 100,
        "pixel_aspect": [1.0, 1.0],
        "focus_distance": None,
        "props": {},
    }
    return {**cam, **kw}


def _object(name, *slots, **props) -> dict:
    return {
        "name": name,
        "mesh": f"m/{name}.glb",
        "props": props,
        "slots": [
            {"name": s[0], "props": s[1] if len(s) > 1 else {}, "used": s[2] if len(s) > 2 else True} for s in slots
        ],
    }


# -- the mapping, without Blender -----------------------------------------------------------------


def test_horizontal_fov_per_sensor_fit():
    # closed forms of Blender's sensor fit (its manual, Camera > Sensor Fit); double arithmetic: 1e-12
    f = mapping.horizontal_fov
    assert f(35, 36, 24, "HORIZONTAL", 40, 30) == pytest.approx(2 * math.atan(18 / 35), abs=1e-12)
    # the sensor height up the image; the width from the image's aspect
    assert f(50, 36, 24, "VERTICAL", 40, 30) == pytest.approx(2 * math.atan(12 / 50 * 40 / 30), abs=1e-12)
    # AUTO: the sensor width along the longer side, here the height of a portrait image
    assert f(35, 36, 24, "AUTO", 30, 40) == pytest.approx(2 * math.atan(18 / 35 * 30 / 40), abs=1e-12)
    assert f(35, 36, 24, "AUTO", 40, 30) == pytest.approx(2 * math.atan(18 / 35), abs=1e-12)


def test_imager_pose_resolution_and_unit_scale():
    # a camera turned +90 deg about X looks along +Y with +Z up; at (1, 2, 3) Blender units of 2 m
    m = [[1, 0, 0, 1], [0, 0, -1, 2], [0, 1, 0, 3], [0, 0, 0, 1]]
    im = mapping.imager(_camera(matrix_world=m, resolution=[1920, 1080], percentage=50, focus_distance=4.0), scale=2.0)
    assert im["position"] == [2.0, 4.0, 6.0]
    assert np.subtract(im["look_at"], im["position"]).tolist() == [0.0, 1.0, 0.0]
    assert im["up"] == [0.0, 0.0, 1.0]
    assert im["resolution"] == [960, 540]
    assert im["focus_distance"] == "8 m"
    assert im["fov"] == f"{math.degrees(2 * math.atan(18 / 35)):.7g} deg"


@pytest.mark.parametrize(
    "kw, words",
    [({"type": "ORTHO"}, "Perspective"), ({"shift_x": 0.1}, "Shift"), ({"pixel_aspect": [2.0, 1.0]}, "pixel aspect")],
)
def test_cameras_pmmw_cannot_take_are_refused(kw, words):
    with pytest.raises(ExportError, match=words):
        mapping.imager(_camera(**kw))
    mapping.imager(_camera())  # control: the same camera without it exports


def test_materials_from_names_and_custom_properties():
    data = mapping.scenario(
        {
            "camera": _camera(),
            "objects": [
                _object("Ground", ("concrete",)),
                _object("Box", ("Steel", {"pmmw_material": "metal", "pmmw_roughness": 0.1})),
                _object(
                    "Tank",
                    ("Warm water", {"pmmw_material": "water", "pmmw_temperature": 310.0}),
                    pmmw_coating="denim 0.8 mm 300 K; polyethylene 2 mm",
                ),
                _object("Two", ("brick",), ("glass",), ("unused name", {}, False)),
                _object("Whole", ("Material.001",), pmmw_material="wood", pmmw_temperature="27 degC"),
            ],
        }
    )
    scene = {e["name"]: e for e in data["scene"]}
    assert scene["Ground"] == {"name": "Ground", "mesh": "m/Ground.glb", "material": "concrete"}
    assert data["materials"][scene["Box"]["material"]] == {
        "same_as": "metal",
        "roughness": {"model": "ggx", "alpha": 0.1},
    }
    assert data["materials"][scene["Tank"]["material"]] == {
        "same_as": "water",
        "temperature": "310 K",
        "coating": [
            {"material": "denim", "thickness": "0.8 mm", "temperature": "300 K"},
            {"material": "polyethylene", "thickness": "2 mm"},
        ],
    }
    assert scene["Two"]["materials"] == {"brick": "brick", "glass": "glass"}  # the unused slot left out
    assert data["materials"][scene["Whole"]["material"]] == {"same_as": "wood", "temperature": "27 degC"}
    assert data["frequency"] == mapping.DEFAULT_FREQUENCY


def test_every_problem_of_a_scene_is_named():
    _, errors = mapping.build(
        {
            "camera": None,
            "objects": [
                _object("A", ("Material.001",)),
                _object("B"),
                _object("C", (None,)),
                _object("D", ("concrete",), pmmw_coating="denim"),
                _object("E", ("concrete",), pmmw_roughness="rough"),
                _object("F", ("ok", {"pmmw_material": "Not An Id"})),
            ],
        }
    )
    text = [str(e) for e in errors]
    assert len(text) == 7, text
    assert "no active camera" in text[0]
    assert "object 'A'" in text[1] and "pmmw_material" in text[1]
    assert "object 'B'" in text[2] and "no material" in text[2]
    assert "empty material slot" in text[3]
    assert "ID THICKNESS" in text[4]
    assert "GGX alpha" in text[5]
    assert "'Not An Id' is not a database id" in text[6]


def test_scene_properties_set_scenario_keys_and_regions():
    data = mapping.scenario(
        {
            "camera": _camera(),
            "objects": [_object("G", ("concrete",))],
            "scale": 0.5,
            "props": {"pmmw:render.spp": 4, "pmmw:frequency": "35 GHz", "other": 1},
            "regions": [{"name": "tank", "location": [1.0, 2.0, 3.0], "radius": 3}],
        }
    )
    assert data["render"] == {"spp": 4} and data["frequency"] == "35 GHz" and "other" not in data
    assert data["output"]["regions"] == {"tank": {"center": [0.5, 1.0, 1.5], "radius": 3.0}}
    assert data["scene"][0]["transform"] == {"scale": 0.5}
    with pytest.raises(ExportError, match="malformed"):
        mapping.scenario({"camera": _camera(), "objects": [_object("G", ("concrete",))], "props": {"pmmw:a..b": 1}})


def test_yaml_writer_round_trips():
    data = {
        "frequency": "95 GHz",
        "yes": "no",
        "n": [1e-05, 1.5e20, -2.0, 3, True, None, "1e3"],
        "text": 'a "quoted" \\ Müll: #x',
        "list": [{"a": 1, "b": [1.0, 2.0]}, {"c": {"d": "e"}}],
        "empty": {},
        "none": [],
        "nested": {"deep": {"deeper": [[1, 2], [3, 4]]}},
    }
    assert yaml.safe_load(mapping.to_yaml(data)) == data


def test_exported_mapping_is_a_scenario_pmmw_takes(tmp_path):
    import trimesh

    from pmmw.pipeline import validate

    (tmp_path / "m").mkdir()
    for name in ("Ground", "Tank"):
        trimesh.creation.box((1, 1, 1)).export(tmp_path / "m" / f"{name}.glb")
    data = mapping.scenario(
        {
            "camera": _camera(),
            "props": {"pmmw:atmosphere": "none"},
            "objects": [
                _object("Ground", ("concrete",)),
                _object(
                    "Tank",
                    (
                        "Warm water",
                        {
                            "pmmw_material": "water",
                            "pmmw_temperature": 310.0,
                            "pmmw_roughness": '{"model": "beckmann", "alpha": 0.2}',
                        },
                    ),
                    pmmw_coating="polyethylene 2 mm",
                ),
            ],
        }
    )
    path = tmp_path / "s.yaml"
    path.write_text(mapping.to_yaml(data))
    media = validate(path)["media"]["95 GHz"]
    tank = media[data["scene"][1]["material"]]
    assert tank["temperature_K"] == 310.0 and "Beckmann" in str(tank["roughness"]), tank
    assert tank["coating_layers"] == 1


# -- the EXR reader, against OpenImageIO ----------------------------------------------------------


@pytest.mark.parametrize("compression", ["zip", "zips", "none"])
def test_exr_reader_matches_openimageio(tmp_path, compression):
    import OpenImageIO as oiio

    rng = np.random.default_rng(3)
    # 37 rows: ZIP's chunks of 16 rows and a short last one; random values do not compress (stored
    # as they are), the smooth ramp does
    chans = {
        "I": rng.uniform(50, 300, (37, 21)),
        "ideal.I": np.tile(np.linspace(0, 1, 21), (37, 1)),
        "Ex2": np.full((37, 21), 150.0),
    }
    spec = oiio.ImageSpec(21, 37, 3, oiio.FLOAT)
    spec.channelnames = tuple(chans)
    spec.attribute("compression", compression)
    out = oiio.ImageOutput.create(str(tmp_path / "a.exr"))
    out.open(str(tmp_path / "a.exr"), spec)
    out.write_image(np.ascontiguousarray(np.stack(list(chans.values()), -1), dtype=np.float32))
    out.close()
    inp = oiio.ImageInput.open(str(tmp_path / "a.exr"))
    ref = inp.read_image(oiio.FLOAT)
    names = inp.spec().channelnames
    inp.close()
    got = exr.read(tmp_path / "a.exr")
    assert set(got) == set(names)
    for i, n in enumerate(names):  # the same float32 bits: exact
        assert np.array_equal(got[n], ref[..., i]), n
    with pytest.raises(exr.ExrError, match="not an OpenEXR"):
        exr.read(Path(__file__))


# -- the add-on's zip -----------------------------------------------------------------------------


def test_addon_zip_installs_as_an_addon_and_an_extension(tmp_path):
    import ast

    tomllib = pytest.importorskip("tomllib", reason="Python 3.11's tomllib reads the manifest")
    z = zipfile.ZipFile(addon_zip(tmp_path / "pmmw_blender.zip"))
    names = z.namelist()
    assert "pmmw_blender/__init__.py" in names and "pmmw_blender/blender_manifest.toml" in names
    assert {n.split("/")[0] for n in names} == {"pmmw_blender"}
    init = ast.parse(z.read("pmmw_blender/__init__.py"))
    bl_info = next(
        ast.literal_eval(n.value) for n in init.body if isinstance(n, ast.Assign) and n.targets[0].id == "bl_info"
    )
    manifest = tomllib.loads(z.read("pmmw_blender/blender_manifest.toml").decode())
    assert manifest["id"] == "pmmw_blender" and manifest["type"] == "add-on"
    assert manifest["version"] == ".".join(map(str, bl_info["version"]))
    assert manifest["blender_version_min"] == ".".join(map(str, bl_info["blender"]))
    assert not [n for n in names if "__pycache__" in n]


# -- without bpy ----------------------------------------------------------------------------------


def _cli(*args, env=None):
    return subprocess.run(
        [sys.executable, "-m", "pmmw_cli", *args],
        capture_output=True,
        text=True,
        cwd=REPO,
        env={**os.environ, **(env or {})},
    )


@pytest.mark.skipif(importlib.util.find_spec("bpy") is not None, reason="this Python has bpy")
def test_a_blend_without_bpy_names_the_extra(tmp_path):
    # TMPDIR: no export of the example made by another test (an export once made needs no Blender)
    env = {**{k: v for k, v in os.environ.items() if k != "PMMW_BLENDER_PYTHON"}, "TMPDIR": str(tmp_path)}
    run = subprocess.run(
        [sys.executable, "-m", "pmmw_cli", "validate", str(EXAMPLE)], capture_output=True, text=True, cwd=REPO, env=env
    )
    assert run.returncode == 1, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "pmmw[blender]" in lines[0] and "Traceback" not in run.stderr, run.stderr
    run = _cli("validate", str(EXAMPLE), env={"PMMW_BLENDER_PYTHON": "/nonexistent/python", "TMPDIR": str(tmp_path)})
    assert run.returncode == 1 and "no such program" in run.stderr, run.stderr


# -- with bpy -------------------------------------------------------------------------------------


def _bpy(code: str, tmp_path, env=None) -> dict:
    """Run ``code`` in Blender's Python (the add-on importable as ``pmmw_blender``, Blender's user
    folders in ``tmp_path``); it leaves its answer in ``result``, returned from JSON."""
    script = tmp_path / "script.py"
    script.write_text(
        f"import sys, json\nsys.path.insert(0, {str(ADDON.parent)!r})\nresult = None\n{code}\n"
        "print('RESULT ' + json.dumps(result))\n"
    )
    env = {
        **os.environ,
        **{
            f"BLENDER_USER_{k}": str(tmp_path / "blender" / k.lower())
            for k in ("RESOURCES", "CONFIG", "SCRIPTS", "EXTENSIONS", "DATAFILES")
        },
        **(env or {}),
    }
    run = subprocess.run([BPY_PYTHON, str(script)], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(next(line[7:] for line in run.stdout.splitlines() if line.startswith("RESULT ")))


@needs_bpy
def test_fov_matches_blenders_own_projection(tmp_path):
    got = _bpy(
        """
import bpy, math
from pmmw_blender import exporter, mapping
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
bpy.ops.object.camera_add()
cam = bpy.context.object
scene.camera = cam
result = []
for fit, lens, sw, sh, rx, ry, pct in [("AUTO", 35, 36, 24, 40, 30, 100), ("AUTO", 50, 36, 24, 30, 40, 100),
                                       ("HORIZONTAL", 20, 30, 20, 64, 16, 50), ("VERTICAL", 85, 36, 24, 40, 30, 100),
                                       ("VERTICAL", 24, 36, 12, 17, 90, 200)]:
    cam.data.sensor_fit, cam.data.lens, cam.data.sensor_width, cam.data.sensor_height = fit, lens, sw, sh
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = rx, ry, pct
    w, h = mapping.render_resolution(rx, ry, pct)
    p = cam.calc_matrix_camera(bpy.context.evaluated_depsgraph_get(), x=w, y=h)
    im = mapping.imager(exporter._camera(scene))
    result.append([2 * math.degrees(math.atan(1 / p[0][0])), float(im["fov"].split()[0]), im["resolution"], [w, h]])
""",
        tmp_path,
    )
    for ref, fov, res, wh in got:
        # Blender's projection matrix is float32 (7 digits) and the exported fov has 7: 1e-5 deg
        assert fov == pytest.approx(ref, abs=1e-5), got
        assert res == wh


@needs_bpy
def test_meshes_land_where_blender_has_them(tmp_path):
    """Parented, rotated, scaled and mirrored objects: pmmw's vertices from the exported GLBs (glTF
    Y-up turned to Z-up on load) are Blender's world vertices, and a mirrored box stays outward."""
    from pmmw.scene.geometry import load_entry_mesh

    blender = _bpy(
        f"""
import bpy, math
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
mat = bpy.data.materials.new("concrete")
bpy.ops.object.empty_add(location=(5, 0, 0), rotation=(0, 0, math.radians(90)))
parent = bpy.context.object
bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 0, 3), rotation=(math.radians(30), 0, 0))
child = bpy.context.object
child.name, child.scale, child.parent = "Child", (1, 2, 3), parent
bpy.ops.mesh.primitive_cone_add(location=(-2, 1, 0.5))
cone = bpy.context.object
cone.name, cone.scale = "Mirrored", (-1, 1, 1)
for o in (child, cone):
    o.data.materials.append(mat)
bpy.ops.object.camera_add(location=(0, -10, 2), rotation=(math.radians(90), 0, 0))
scene.camera = bpy.context.object
bpy.context.view_layer.update()
from pmmw_blender import exporter
exporter.export(bpy.context, {str(tmp_path / "out" / "s.yaml")!r})
result = {{o.name: [list(o.matrix_world @ v.co) for v in o.data.vertices] for o in (child, cone)}}
""",
        tmp_path,
    )
    for name, verts in blender.items():
        ((_, mesh),) = load_entry_mesh(tmp_path / "out" / "s_meshes" / f"{name}.glb")
        ref = np.unique(np.round(np.array(verts), 5), axis=0)
        got = np.unique(np.round(np.asarray(mesh.vertices), 5), axis=0)
        # float32 coordinates of a few metres (~5e-7 m), rounded to 1e-5 m on both sides
        assert got.shape == ref.shape and np.allclose(got, ref, atol=2e-5), name
        assert mesh.is_watertight and mesh.volume > 0, name  # outward, mirrored or not
    assert np.ptp(np.array(blender["Child"])[:, 2]) > 2.5  # control: the child stands tall in z (3 m high)


@needs_bpy
def test_example_blend_is_what_its_script_makes(tmp_path, monkeypatch):
    made = tmp_path / "example.blend"
    run = subprocess.run(
        [BPY_PYTHON, str(REPO / "scenes" / "blender" / "make_example.py"), str(made)], capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr[-2000:]

    def body(blend):
        return scenario_of_blend(blend).read_text().split("\n", 1)[1]  # without the header's file name

    monkeypatch.setenv("PMMW_BLENDER_PYTHON", BPY_PYTHON)
    assert body(made) == body(EXAMPLE)
    for name in ("Box", "Ground", "Tank"):
        a = (scenario_of_blend(made).parent / "example_meshes" / f"{name}.glb").read_bytes()
        b = (scenario_of_blend(EXAMPLE).parent / "example_meshes" / f"{name}.glb").read_bytes()
        assert a == b, name


@needs_bpy
def test_example_blend_renders_as_its_exported_scenario(tmp_path, monkeypatch):
    import pmmw

    monkeypatch.setenv("PMMW_BLENDER_PYTHON", BPY_PYTHON)
    exported = scenario_of_blend(EXAMPLE)
    assert (
        pmmw.validate(pmmw.Scenario.load(EXAMPLE))["scenario"]["materials"]["blender_tank_warm_water"]["temperature"]
        == "310 K"
    )
    a = pmmw.render(pmmw.Scenario.load(EXAMPLE), spp=2, workers=1, seed=3)
    b = pmmw.render(pmmw.Scenario.load(exported), spp=2, workers=1, seed=3)
    assert a["I"].shape[-2:] == (30, 40)
    for ch in ("I", "Q", "U", "V", "Ex2", "Ey2"):  # same scene, same seed: the same numbers
        assert np.array_equal(a[ch].values, b[ch].values), ch
    c = pmmw.render(pmmw.Scenario.load(exported), spp=2, workers=1, seed=4)
    assert not np.array_equal(a["I"].values, c["I"].values)  # control: another seed differs


@needs_bpy
def test_cli_reads_a_blend_and_names_its_problems(tmp_path):
    env = {"PMMW_BLENDER_PYTHON": BPY_PYTHON}
    run = _cli("validate", str(EXAMPLE), env=env)
    assert run.returncode == 0 and "blender_steel" in run.stdout, run.stderr
    bad = tmp_path / "bad.blend"
    bad.write_text("not a blend")
    run = _cli("validate", str(bad), env=env)
    assert run.returncode == 2 and "Blender cannot open it" in run.stderr and "Traceback" not in run.stderr, run.stderr
    _bpy(
        f"""
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_cube_add()
bpy.context.object.data.materials.append(bpy.data.materials.new("Material.001"))
bpy.ops.wm.save_as_mainfile(filepath={str(tmp_path / "nocam.blend")!r})
""",
        tmp_path,
    )
    run = _cli("validate", str(tmp_path / "nocam.blend"), env=env)
    assert run.returncode == 2 and "no active camera" in run.stderr and "'Material.001'" in run.stderr, run.stderr
    assert "nocam.blend" in run.stderr
    # what is left out is said: a text object (the example, control, has none)
    _bpy(
        f"""
import bpy
bpy.ops.wm.open_mainfile(filepath={str(EXAMPLE)!r})
bpy.ops.object.text_add()
bpy.ops.wm.save_as_mainfile(filepath={str(tmp_path / "text.blend")!r})
""",
        tmp_path,
    )
    run = _cli("validate", str(tmp_path / "text.blend"), env=env)
    assert run.returncode == 0 and "warning: text.blend: object 'Text' (font) is not a mesh: left out" in run.stderr, (
        run.stderr
    )
    assert "left out" not in _cli("validate", str(EXAMPLE), env=env).stderr


# Blender's two ways to install from a zip: a legacy add-on (bl_info) and, in 4.2+, an extension (the manifest)
INSTALLS = {
    "addon": (
        'bpy.ops.preferences.addon_install(filepath=ZIP)\naddon_utils.enable("pmmw_blender", default_set=True)',
        "pmmw_blender",
    ),
    "extension": (
        'bpy.ops.extensions.package_install_files(filepath=ZIP, repo="user_default", enable_on_install=True)',
        "bl_ext.user_default.pmmw_blender",
    ),
}


@needs_bpy
@pytest.mark.parametrize("how", sorted(INSTALLS))
def test_addon_installs_from_its_zip_exports_and_loads_an_exr(tmp_path, monkeypatch, how):
    from pmmw.io.exr import write_exr

    zip_path = addon_zip(tmp_path / "pmmw_blender.zip")
    rng = np.random.default_rng(1)
    channels = {n: rng.uniform(50, 300, (5, 7)) for n in ("I", "Q", "U", "V", "Ex2", "Ey2", "ideal.I")}
    (tmp_path / "out").mkdir()
    write_exr(tmp_path / "out" / "r.exr", channels)
    got = _bpy(
        f"""
import bpy, addon_utils, sys, numpy as np
sys.path.remove({str(ADDON.parent)!r})  # the add-on as Blender installs it, not from the source tree
ZIP = {str(zip_path)!r}
{INSTALLS[how][0]}
bpy.ops.wm.open_mainfile(filepath={str(EXAMPLE)!r})
done = bpy.ops.export_scene.pmmw(filepath={str(tmp_path / "op" / "example.yaml")!r})
operators = sys.modules[{INSTALLS[how][1] + ".operators"!r}]
images = operators.load_result(bpy.context, __import__("pathlib").Path({str(tmp_path / "out" / "r.exr")!r}))
result = {{"done": list(done), "where": sys.modules[{INSTALLS[how][1]!r}].__file__,
          "images": {{im.name: np.array(im.pixels[:]).reshape(im.size[1], im.size[0], 4)[::-1, :, 0].tolist()
                     for im in images}}}}
""",
        tmp_path,
    )
    assert got["done"] == ["FINISHED"] and str(tmp_path) in got["where"]
    exported = (tmp_path / "op" / "example.yaml").read_text().split("\n", 1)[1]
    monkeypatch.setenv("PMMW_BLENDER_PYTHON", BPY_PYTHON)
    assert exported == scenario_of_blend(EXAMPLE).read_text().split("\n", 1)[1]
    assert sorted(got["images"]) == sorted(f"r {n} [K]" for n in ("I", "Q", "U", "V", "Ex2", "Ey2"))
    for n in ("I", "Ex2"):  # float32 kelvin in Blender's float image: exact
        assert np.array_equal(np.float32(got["images"][f"r {n} [K]"]), channels[n].astype(np.float32)), n


@needs_bpy
def test_render_with_pmmw_from_blender(tmp_path):
    """The add-on's Render with pmmw, as a script runs it (no window: it waits for pmmw): the
    scene exported beside the saved .blend, rendered by this pmmw, its channels loaded in kelvin."""
    zip_path = addon_zip(tmp_path / "pmmw_blender.zip")
    got = _bpy(
        f"""
import bpy, addon_utils, sys, numpy as np
sys.path.remove({str(ADDON.parent)!r})
bpy.ops.preferences.addon_install(filepath={str(zip_path)!r})
addon_utils.enable("pmmw_blender", default_set=True)
prefs = bpy.context.preferences.addons["pmmw_blender"].preferences
prefs.command, prefs.extra = {f"{sys.executable} -m pmmw_cli"!r}, "--spp 1 --workers 1 --seed 5"
bpy.ops.wm.open_mainfile(filepath={str(EXAMPLE)!r})
bpy.ops.wm.save_as_mainfile(filepath={str(tmp_path / "example.blend")!r})
done = bpy.ops.render.pmmw()
im = bpy.data.images["example I [K]"]
result = {{"done": list(done), "I": np.array(im.pixels[:]).reshape(im.size[1], im.size[0], 4)[::-1, :, 0].tolist()}}
""",
        tmp_path,
        env={"PYTHONPATH": str(REPO)},
    )
    assert got["done"] == ["FINISHED"]
    out = tmp_path / "example_pmmw"
    assert (out / "example.yaml").is_file() and (out / "example_meshes" / "Box.glb").is_file()
    ref = exr.read(out / "out" / "example.exr")["I"]
    assert np.array_equal(np.float32(got["I"]), ref)  # the image Blender shows is pmmw's, in kelvin
    assert ref.shape == (30, 40) and 100.0 < ref.min() and ref.max() < 700.0  # I = Ex2 + Ey2 of 60..310 K scenes


@needs_bpy
def test_every_process_reads_a_blend_as_the_same_scenario(tmp_path):
    """Shards and --resume compare the scenario hash across processes: two processes that export
    the .blend each (Blender run twice, the exports' folder emptied between) hash alike."""
    code = (
        "from pmmw.blender import scenario_of_blend; from pmmw.config import load_scenario; "
        "from pmmw.pipeline import scenario_hash; import sys; p = sys.argv[1]; "
        "print(scenario_of_blend(p), scenario_hash(load_scenario(p)))"
    )
    env = {**os.environ, "PMMW_BLENDER_PYTHON": BPY_PYTHON, "TMPDIR": str(tmp_path)}
    got = []
    for _ in range(2):
        run = subprocess.run(
            [sys.executable, "-c", code, str(EXAMPLE)], capture_output=True, text=True, cwd=REPO, env=env
        )
        assert run.returncode == 0, run.stderr[-2000:]
        got.append(run.stdout.split())
        folder = Path(got[-1][0]).parent
        assert folder.parent == tmp_path / f"pmmw-blend-{os.getuid()}"
        shutil.rmtree(folder)
    assert got[0] == got[1]


def test_old_exports_are_pruned_and_nothing_else(tmp_path):
    """`_prune` removes pmmw's own export folders unused for KEEP_DAYS and nothing else in the
    folder: a user's old folder and a link are kept. The control: the same old export, fresh, is
    kept too, and the old one is gone."""
    import time

    from pmmw.blender import KEEP_DAYS, _prune

    root = tmp_path / "pmmw-blend-x"
    root.mkdir()
    old = time.time() - (KEEP_DAYS + 1) * 86400
    made = {name: root / name for name in ("0123456789abcdef0123", "fedcba9876543210fedc", ".export-ab_12", "notes")}
    for d in made.values():
        d.mkdir()
        (d / "f.txt").write_text("x")
    elsewhere = tmp_path / "user"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_text("mine")
    (root / "0011223344556677aabb").symlink_to(elsewhere)
    for name in ("0123456789abcdef0123", ".export-ab_12", "notes"):
        os.utime(made[name], (old, old))
    os.utime(elsewhere, (old, old))
    _prune(root)
    assert sorted(p.name for p in root.iterdir()) == ["0011223344556677aabb", "fedcba9876543210fedc", "notes"]
    assert (elsewhere / "keep.txt").read_text() == "mine" and (made["notes"] / "f.txt").is_file()


def test_an_export_folder_that_is_a_link_is_refused_and_its_target_untouched(tmp_path):
    """The temporary folder is shared: a `pmmw-blend-UID` made by someone else as a link is
    neither read from nor pruned (its old folders would be another user's); the control: a real
    folder of one's own passes."""
    import time

    from pmmw.blender import KEEP_DAYS, _prune, check_root
    from pmmw.errors import EnvironmentProblem

    target = tmp_path / "victim"
    (target / "0123456789abcdef0123").mkdir(parents=True)
    old = time.time() - (KEEP_DAYS + 1) * 86400
    os.utime(target / "0123456789abcdef0123", (old, old))
    link = tmp_path / "pmmw-blend-x"
    link.symlink_to(target)
    with pytest.raises(EnvironmentProblem, match="link"):
        check_root(link)
    _prune(link)
    assert (target / "0123456789abcdef0123").is_dir()
    own = tmp_path / "own"
    own.mkdir()
    check_root(own)
