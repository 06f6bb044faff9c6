"""Broken mesh files are one-line user errors naming the mesh and the scenario key, never a
traceback or a numpy warning; `asset_files` lists every file a mesh is made from."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh
from typer.testing import CliRunner

from pmmw.errors import UserError
from pmmw.scene.geometry import asset_files
from pmmw_cli.cli import app

runner = CliRunner()

LEAKS = ("Traceback", "RuntimeWarning", "charset_normalizer")


def write_scenario(tmp_path: Path, mesh_name: str) -> Path:
    path = tmp_path / "scenario.yaml"
    path.write_text(
        f"""
name: broken_mesh
frequency: 35 GHz
imager: {{position: [0, -5, 1.5], look_at: [0, 0, 0], fov: 20 deg, resolution: [8, 8]}}
scene:
  - {{mesh: {mesh_name}, material: metal}}
sky: {{model: uniform, temperature: 40 K}}
render: {{spp: 1, max_depth: 2, tile: 8}}
"""
    )
    return path


def box() -> trimesh.Trimesh:
    return trimesh.creation.box(extents=[1.0, 1.0, 1.0])


def nan_box() -> trimesh.Trimesh:
    m = box()
    v = m.vertices.copy()
    v[0] = np.nan
    v[1, 2] = np.inf
    m.vertices = v
    return m


def garbage(n: int = 300) -> bytes:
    """Bytes that are no format's (0xff is never valid UTF-8, so a text fallback fails too)."""
    return b"\xff\xfe" + np.random.default_rng(7).integers(0, 256, n, dtype=np.uint8).tobytes()


def write_gltf(folder: Path, name: str = "box.gltf", mesh: trimesh.Trimesh | None = None) -> tuple[Path, list]:
    """A .gltf with its buffers in external .bin files; returns the .gltf and the .bin paths."""
    files = (mesh if mesh is not None else box()).export(file_type="gltf")
    tree = json.loads(files["model.gltf"])
    bins = []
    for b in tree["buffers"]:
        target = folder / f"{Path(name).stem}_{b['uri']}"
        target.write_bytes(files[b["uri"]])
        b["uri"] = target.name
        bins.append(target)
    path = folder / name
    path.write_text(json.dumps(tree, indent=1))
    return path, bins


def _half(data: bytes) -> bytes:
    return data[: len(data) // 2]


# -- each case writes a broken mesh into the folder and returns its file name -----------------


def _stl_garbage(d):
    (d / "m.stl").write_bytes(garbage())
    return "m.stl"


def _stl_truncated(d):
    (d / "m.stl").write_bytes(_half(box().export(file_type="stl")))
    return "m.stl"


def _stl_ascii_truncated(d):
    (d / "m.stl").write_text(_half(box().export(file_type="stl_ascii")))
    return "m.stl"


def _stl_empty(d):
    (d / "m.stl").write_bytes(b"")
    return "m.stl"


def _obj_garbage(d):
    (d / "m.obj").write_bytes(garbage())
    return "m.obj"


def _obj_truncated(d):
    # faces kept, the vertices they name cut off
    (d / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 2 3 4\nf 3 4 5\n")
    return "m.obj"


def _obj_empty(d):
    (d / "m.obj").write_bytes(b"")
    return "m.obj"


def _ply_garbage(d):
    (d / "m.ply").write_bytes(b"ply\n" + garbage())
    return "m.ply"


def _ply_truncated(d):
    (d / "m.ply").write_bytes(_half(box().export(file_type="ply")))
    return "m.ply"


def _ply_empty(d):
    (d / "m.ply").write_bytes(b"")
    return "m.ply"


def _glb_garbage(d):
    (d / "m.glb").write_bytes(garbage())
    return "m.glb"


def _glb_truncated(d):
    (d / "m.glb").write_bytes(_half(box().export(file_type="glb")))
    return "m.glb"


def _glb_empty(d):
    (d / "m.glb").write_bytes(b"")
    return "m.glb"


def _gltf_bad_json(d):
    path, _ = write_gltf(d)
    path.write_text(path.read_text()[:60] + "\n}{,\n")
    return path.name


def _gltf_missing_bin(d):
    path, bins = write_gltf(d)
    bins[0].unlink()
    return path.name


def _gltf_truncated_bin(d):
    path, bins = write_gltf(d)
    bins[0].write_bytes(bins[0].read_bytes()[:10])
    return path.name


def _gltf_missing_image(d):
    path, _ = write_gltf(d)
    tree = json.loads(path.read_text())
    tree["images"] = [{"uri": "paint.png"}]
    path.write_text(json.dumps(tree))
    return path.name


def _nan(ext):
    def write(d):
        with np.errstate(all="ignore"):  # trimesh's STL writer computes normals of NaN triangles
            data = nan_box().export(file_type=ext)
        (d / f"m.{ext}").write_bytes(data.encode() if isinstance(data, str) else data)
        return f"m.{ext}"

    return write


def _gltf_nan(d):
    return write_gltf(d, mesh=nan_box())[0].name


CASES = {
    # case: (writer, words the message must contain)
    "stl-garbage": (_stl_garbage, "not a valid STL file"),
    "stl-truncated": (_stl_truncated, "binary STL truncated"),
    "stl-ascii-truncated": (_stl_ascii_truncated, "ASCII STL truncated"),
    "stl-empty": (_stl_empty, "empty"),
    "obj-garbage": (_obj_garbage, "not a valid OBJ file"),
    "obj-truncated": (_obj_truncated, "a truncated file?"),
    "obj-empty": (_obj_empty, "empty"),
    "ply-garbage": (_ply_garbage, "not a valid PLY file"),
    "ply-truncated": (_ply_truncated, "not a valid PLY file"),
    "ply-empty": (_ply_empty, "empty"),
    "glb-garbage": (_glb_garbage, "not a valid GLB file"),
    "glb-truncated": (_glb_truncated, "GLB truncated"),
    "glb-empty": (_glb_empty, "empty"),
    "gltf-bad-json": (_gltf_bad_json, "glTF JSON is malformed at line"),
    "gltf-missing-bin": (_gltf_missing_bin, "glTF buffer 'box_gltf_buffer_0.bin' named by box.gltf not found"),
    "gltf-truncated-bin": (_gltf_truncated_bin, "is truncated: 10 bytes"),
    "gltf-missing-image": (_gltf_missing_image, "glTF image 'paint.png' named by box.gltf not found"),
    "stl-nan": (_nan("stl"), "vertices are not finite"),
    "obj-nan": (_nan("obj"), "vertices are not finite"),
    "ply-nan": (_nan("ply"), "vertices are not finite"),
    "glb-nan": (_nan("glb"), "vertices are not finite"),
    "gltf-nan": (_gltf_nan, "vertices are not finite"),
}


def check_one_line_error(code: int, stderr: str, mesh: Path, words: str) -> None:
    assert code == 2, stderr
    lines = stderr.splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith("error: "), stderr
    assert f"scene[0].mesh: {mesh}: " in lines[0], stderr
    assert words in lines[0], stderr
    for leak in LEAKS:
        assert leak not in stderr


@pytest.mark.parametrize("case", list(CASES))
def test_broken_mesh_is_one_line_user_error(tmp_path, case):
    writer, words = CASES[case]
    mesh = tmp_path / writer(tmp_path)
    scenario = write_scenario(tmp_path, mesh.name)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = runner.invoke(app, ["validate", str(scenario)])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    check_one_line_error(result.exit_code, result.stderr, mesh, words)
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)]


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root reads any file")
def test_unreadable_mesh_is_one_line_user_error(tmp_path):
    mesh = tmp_path / "m.stl"
    mesh.write_bytes(box().export(file_type="stl"))
    mesh.chmod(0)
    result = runner.invoke(app, ["validate", str(write_scenario(tmp_path, mesh.name))])
    check_one_line_error(result.exit_code, result.stderr, mesh, "cannot read the mesh file")


@pytest.mark.parametrize("case", ["stl-garbage", "stl-nan", "gltf-bad-json"])
def test_console_script_prints_one_line_and_no_warning(tmp_path, case):
    """The installed entry point, with every Python warning shown: nothing but the error line."""
    writer, words = CASES[case]
    mesh = tmp_path / writer(tmp_path)
    exe = Path(sys.executable).parent / "pmmw"
    env = dict(os.environ, PYTHONWARNINGS="always")
    proc = subprocess.run(
        [str(exe), "validate", str(write_scenario(tmp_path, mesh.name))], capture_output=True, text=True, env=env
    )
    check_one_line_error(proc.returncode, proc.stderr, mesh, words)


# -- asset_files --------------------------------------------------------------------------------


def test_asset_files_gltf_lists_buffers_and_images(tmp_path):
    path, bins = write_gltf(tmp_path)
    spaced = tmp_path / "my box.bin"
    bins[0].rename(spaced)
    (tmp_path / "tex.png").write_bytes(b"\x89PNG not really")
    tree = json.loads(path.read_text())
    tree["buffers"][0]["uri"] = "my%20box.bin"  # URIs are URL-encoded
    tree["images"] = [{"uri": "tex.png"}, {"uri": "data:image/png;base64,iVBORw0KGgo="}]
    path.write_text(json.dumps(tree))

    assert asset_files(path) == [path, spaced, *bins[1:], tmp_path / "tex.png"]

    (tmp_path / "tex.png").unlink()
    with pytest.raises(UserError, match="glTF image 'tex.png' named by box.gltf not found") as info:
        asset_files(path)
    assert info.value.file == str(path)


def test_asset_files_glb_and_stl_are_the_file_itself(tmp_path):
    glb = tmp_path / "m.glb"
    glb.write_bytes(box().export(file_type="glb"))
    stl = tmp_path / "m.stl"
    stl.write_bytes(box().export(file_type="stl"))
    assert asset_files(glb) == [glb]
    assert asset_files(stl) == [stl]


def test_asset_files_obj_lists_mtllib_and_its_textures(tmp_path):
    (tmp_path / "tex").mkdir()
    (tmp_path / "tex" / "brick.png").write_bytes(b"png")
    (tmp_path / "bump.png").write_bytes(b"png")
    (tmp_path / "mats.mtl").write_text(
        "newmtl brick\nKd 1 0 0\nmap_Kd -s 1 1 1 tex/brick.png\nbump bump.png\nmap_Ks gone.png\n"
    )
    (tmp_path / "extra.mtl").write_text("newmtl metal\n")
    obj = tmp_path / "m.obj"
    obj.write_text("mtllib mats.mtl extra.mtl missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl brick\nf 1 2 3\n")

    assert asset_files(obj) == [
        obj,
        tmp_path / "mats.mtl",
        tmp_path / "tex" / "brick.png",
        tmp_path / "bump.png",
        tmp_path / "extra.mtl",
    ]
