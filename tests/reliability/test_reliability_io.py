"""Reliability at the edges of a render: the input it accepts, the files it reads, the outputs it
writes. Each test reproduces a failure a tester found on an earlier version (a hang, a mixed image,
an overwritten input, a traceback) and checks the behaviour that replaced it."""

import errno
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh
from typer.testing import CliRunner

from pmmw import pipeline
from pmmw.config import load_scenario
from pmmw.errors import UserError
from pmmw.io.exr import write_exr
from pmmw.io.yamlio import MAX_NODES, load_yaml
from pmmw_cli.cli import app

runner = CliRunner()


def _run(*args):
    return runner.invoke(app, [str(a) for a in args])


def _one_error_line(result, *words):
    """The CLI's contract for a refused input: one `error:` line naming what is wrong."""
    # progress lines (`name: tiles 1/6 ...`, printed as plain lines when stderr is not a terminal) aside
    lines = [
        line
        for line in result.output.splitlines()
        if line.strip() and not line.startswith("warning:") and not re.match(r"^\S+: tiles \d+/\d+ ", line)
    ]
    assert len(lines) == 1 and lines[0].startswith("error:"), result.output
    assert "Traceback" not in result.output
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def _scene(tmp_path: Path, extra: str = "", mesh: str = "block.obj", name: str = "tiny") -> Path:
    ground = trimesh.creation.box(extents=[40, 40, 1])
    ground.apply_translation([0, 0, -0.5])
    ground.export(tmp_path / "ground.obj")
    if mesh == "block.obj":
        block = trimesh.creation.box(extents=[0.4, 0.2, 0.2])
        block.apply_translation([0, 4, 0.1])
        block.export(tmp_path / "block.obj")
    path = tmp_path / "tiny.yaml"
    path.write_text(f"""
name: {name}
frequency: 35 GHz
imager: {{position: [0, 0, 1.5], look_at: [0, 4, 0.1], fov: 20 deg, resolution: [24, 16]}}
scene:
  - {{mesh: ground.obj, material: concrete}}
  - {{mesh: {mesh}, material: metal}}
render: {{spp: 2, max_depth: 4, tile: 8, workers: 1}}
{extra}
""")
    return path


# -- YAML: alias bombs, duplicate keys, message length -----------------------------------------

BOMB = "\n".join(
    ["a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    + [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 9)]
)


def test_an_alias_bomb_is_refused_at_once_with_a_short_message(tmp_path):
    """595 bytes of nested aliases expand to 9^9 values: refused from the node graph before any
    value is built (an earlier version ran 116 s into a MemoryError and printed 351 MB)."""
    scn = _scene(tmp_path, extra=BOMB + "\nmaterials: {x: *a8}")
    t0 = time.perf_counter()
    res = _run("validate", scn)
    elapsed = time.perf_counter() - t0
    assert res.exit_code == 2
    line = _one_error_line(res, "tiny.yaml", "aliases")
    assert len(line) < 400
    assert elapsed < 10.0  # generous: refused after counting ~100 nodes, not building 4e8


def test_legitimate_anchors_stay_accepted():
    text = "base: &b {eps: [4, 0.1], temperature: 300 K}\nm1: *b\nm2: {<<: *b, temperature: 310 K}\n"
    data = load_yaml(text)
    assert data["m1"] == data["base"] and data["m2"]["temperature"] == "310 K"


def test_the_expansion_limit_counts_aliases_as_copies():
    width = int(np.ceil(np.sqrt(MAX_NODES))) + 10  # width^2 expanded values, 2 * width written
    text = f"row: &r [{', '.join(['1'] * width)}]\ngrid: [{', '.join(['*r'] * width)}]\n"
    with pytest.raises(UserError, match="expands"):
        load_yaml(text, "g.yaml")
    assert load_yaml(f"row: &r [1, 2]\ngrid: [{', '.join(['*r'] * 100)}]\n")["grid"][99] == [1, 2]


def test_libyaml_reads_every_shipped_file_as_the_python_parser_does():
    """`load_yaml` parses with libyaml where PyYAML has it (a tenth of the time): every YAML file
    pmmw ships gives the values of PyYAML's Python parser, exactly (equal and of the same types)."""
    import yaml

    from pmmw.io import yamlio

    root = Path(__file__).resolve().parents[2]
    files = sorted(p for d in ("materials", "configs", "scenes", "examples") for p in (root / d).rglob("*.yaml"))
    assert len(files) > 30  # the database's files and the shipped scenarios at least
    for f in files:
        text = f.read_text(encoding="utf-8")
        expected = yaml.load(text, Loader=yamlio._Loader)
        assert repr(load_yaml(text)) == repr(expected), f


def test_malformed_yaml_is_told_in_the_python_parsers_words():
    # what libyaml refuses is read again by the Python parser, for its message, line and column;
    # the control: libyaml's own words differ, so the message shows which parser spoke
    import yaml

    with pytest.raises(UserError, match="line 1, column 5: mapping values are not allowed here"):
        load_yaml("a: b: c\n")
    with pytest.raises(yaml.YAMLError, match="not allowed in this context"):
        yaml.load("a: b: c\n", Loader=yaml.CSafeLoader)


def test_deep_nesting_is_refused_without_a_recursion_traceback(tmp_path):
    scn = tmp_path / "deep.yaml"
    scn.write_text("name: " + "[" * 5000 + "]" * 5000 + "\n")
    res = _run("validate", scn)
    assert res.exit_code == 2
    _one_error_line(res, "deep.yaml", "nested")


def test_duplicate_keys_in_a_scenario_are_refused(tmp_path):
    """Last-one-wins was silent; the materials loader already refused duplicates."""
    scn = _scene(tmp_path, extra="render: {spp: 8}")
    res = _run("validate", scn)
    assert res.exit_code == 2
    _one_error_line(res, "tiny.yaml", "duplicate key 'render'", "line")
    res = _run("validate", _scene(tmp_path), "--set", "render={spp: 1, spp: 2}")
    assert res.exit_code == 2
    _one_error_line(res, "--set", "duplicate key 'spp'")


def test_a_huge_value_in_an_error_message_is_cut():
    e = UserError("got " + "x" * 100_000, "f.yaml", "k")
    assert len(str(e)) < UserError.MAX_MESSAGE + 100 and "100,004 characters" in str(e)


# -- limits and physical ranges ------------------------------------------------------------------


@pytest.mark.parametrize(
    "override, key, words",
    [
        ("imager.resolution=[100000, 100000]", "imager.resolution", "at most 16384"),
        ("imager.resolution=[16384, 16384]", "imager.resolution", "64 Mpx"),
        ("render.spp=100000000000", "render.spp", "less than or equal to 1048576"),
        ("render.seed=18446744073709551616", "render.seed", "less than or equal to"),
        ("name=" + "n" * 230, "name", "at most 100"),
        ("frequency=2000 GHz", "frequency", "outside the 1-1000 GHz"),
        ("frequency=500 MHz", "frequency", "outside the 1-1000 GHz"),
        ("imager.bandwidth=80 GHz", "imager", "reaches outside"),
        ("sky.ground_temperature=-50 K", "sky.ground_temperature", "below absolute zero"),
        ("render.default_temperature=-1 degC", None, None),  # 272.15 K: fine
        ("materials={metal: {kind: blackbody, temperature: 1e300 K}}", "materials.metal.temperature", "hotter"),
    ],
)
def test_limits_and_physical_ranges_are_checked_by_validate(tmp_path, override, key, words):
    """Each was accepted by validate and failed later (a traceback after a long render), or gave
    a silent wrong image (negative or infinite pixels)."""
    res = _run("validate", _scene(tmp_path), "--set", override)
    if key is None:
        assert res.exit_code == 0, res.output
        return
    assert res.exit_code == 2, res.output
    _one_error_line(res, f"tiny.yaml: {key}", words)


@pytest.mark.parametrize(
    "args, words",
    [
        (["sky", "--frequency", "1e30 Hz"], "outside the 1-1000 GHz"),
        (["sky", "--frequency", "2000 GHz"], "outside the 1-1000 GHz"),
        (["materials", "list", "--frequency", "0 GHz"], "outside the 1-1000 GHz"),
        (["materials", "show", "concrete", "--frequency", "1 MHz"], "outside the 1-1000 GHz"),
    ],
)
def test_frequency_options_are_range_checked(args, words):
    res = _run(*args)
    assert res.exit_code == 2
    _one_error_line(res, "--frequency", words)


def test_a_sky_texture_hotter_than_any_source_is_refused(tmp_path):
    sky = tmp_path / "sky.exr"
    tv = np.full((8, 16), 50.0, np.float32)
    tv[2, 3] = 1e30
    write_exr(sky, {"Tv": tv, "Th": np.full((8, 16), 50.0, np.float32)}, {})
    res = _run("validate", _scene(tmp_path, extra="sky: {texture: sky.exr}"))
    assert res.exit_code == 2
    _one_error_line(res, "sky.exr", "too hot", "row 2, column 3")


def test_validate_estimates_memory_disk_and_time(tmp_path):
    res = _run("validate", _scene(tmp_path), "--set", "imager.resolution=[2000, 1000]", "--set", "render.spp=64")
    assert res.exit_code == 0, res.output
    import yaml

    r = yaml.safe_load(res.output)["resources"]
    assert r["camera_paths_at_most"] == 2000 * 1000 * 64
    # the tiles (17 float64 per pixel) and the EXR (2 x 6 channels + aux, float32) of 2 Mpx
    assert r["disk_GB"] == pytest.approx(2e6 * (17 * 8 + 4 * 18) / 1e9, rel=1e-3)
    assert r["memory_GB"] > 2e6 * 17 * 8 * 3 / 1e9


def test_render_refuses_what_memory_cannot_hold_unless_forced(tmp_path, monkeypatch):
    monkeypatch.setattr(pipeline, "available_memory", lambda: 1e6)  # a 1 MB machine
    scn = _scene(tmp_path)
    res = _run("render", scn, "--out", tmp_path / "out")
    assert res.exit_code == 2  # a refusal of the input's size, as every bound (was 1)
    _one_error_line(res, "memory", "--force")
    assert not (tmp_path / "out" / "tiny.exr").exists()
    assert _run("render", scn, "--out", tmp_path / "out", "--force").exit_code == 0


# -- outputs: never over an input, names that fit, written together ---------------------------------


def test_a_render_never_overwrites_its_own_input(tmp_path):
    """`output.dir: .` with `name: sky` replaced sky.exr, the sky texture the render read."""
    write_exr(
        tmp_path / "sky.exr", {"Tv": np.full((8, 16), 50.0, np.float32), "Th": np.full((8, 16), 50.0, np.float32)}, {}
    )
    before = (tmp_path / "sky.exr").read_bytes()
    scn = _scene(tmp_path, extra=f"sky: {{texture: sky.exr}}\noutput: {{dir: '{tmp_path}'}}", name="sky")
    res = _run("render", scn)
    assert res.exit_code == 2
    _one_error_line(res, "overwrite its own input", "sky.exr")
    assert (tmp_path / "sky.exr").read_bytes() == before
    # the scenario file itself, named like a report (JSON is YAML)
    (tmp_path / "report.json").write_text(
        scn.read_text().replace("sky: {texture: sky.exr}", "").replace("name: sky", "name: x")
    )
    res = _run("render", tmp_path / "report.json")
    assert res.exit_code == 2
    _one_error_line(res, "overwrite its own input", "report.json")


def test_an_output_path_too_long_is_refused_before_rendering(tmp_path):
    """Names of 225-300 characters passed validate and failed after the full render (the name is
    now limited, `test_limits...`); an output path past the file system's limit is refused
    before anything is created."""
    deep = tmp_path.joinpath(*["d" * 200] * 21)
    res = _run("render", _scene(tmp_path), "--out", deep)
    assert res.exit_code == 2
    _one_error_line(res, "--out", "longer than the file system takes")
    assert not (tmp_path / ("d" * 200)).exists()


def test_output_folder_problems_are_one_line(tmp_path):
    scn = _scene(tmp_path)
    (tmp_path / "afile").write_text("x")
    res = _run("render", scn, "--out", tmp_path / "afile")
    assert res.exit_code == 2
    _one_error_line(res, "afile", "is a file")
    out = tmp_path / "o"
    out.mkdir()
    (out / "previews").write_text("x")
    res = _run("render", scn, "--out", out)
    assert res.exit_code == 2
    _one_error_line(res, "previews is a file")
    assert not (out / "tiny.exr").exists()


def test_a_full_disk_leaves_the_previous_outputs_whole_and_the_tiles_for_resume(tmp_path, monkeypatch):
    """Disk full while writing the previews: the earlier EXR, previews and report stay as they
    were (no new EXR beside an old report), the message is one line, exit 1, and the finished
    tiles are kept so --resume needs no tracing."""
    scn = _scene(tmp_path)
    out = tmp_path / "out"
    assert _run("render", scn, "--out", out).exit_code == 0
    old = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    import pmmw.io.preview as preview

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device", str(out / "previews" / "x.png"))

    monkeypatch.setattr(pipeline, "write_preview", full)
    res = _run("render", scn, "--out", out, "--seed", "7")
    assert res.exit_code == 1
    _one_error_line(res, "no space left on the device")
    now = {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and ".pmmw-tiles" not in p.parts}
    assert now == old
    assert not list(out.glob(".pmmw-staging-*"))
    assert list((out / ".pmmw-tiles").rglob("tile_*.npz"))
    monkeypatch.setattr(pipeline, "write_preview", preview.write_preview)
    from pmmw.trace.integrator import Integrator

    def no_tracing(self, tile):
        raise AssertionError("--resume traced a tile that was already finished")

    monkeypatch.setattr(Integrator, "render_tile", no_tracing)
    res = _run("render", scn, "--out", out, "--seed", "7", "--resume")
    assert res.exit_code == 0, res.output
    assert json.loads((out / "report.json").read_text())["scenario"]["render"]["seed"] == 7


def test_resume_covers_a_gltf_s_external_buffer(tmp_path):
    """--resume mixed geometries: after the .bin buffer of a glTF changed, half the tiles showed the
    old box and half the new one. The hash covers every file the mesh names."""
    box = trimesh.creation.box(extents=[0.4, 0.2, 0.2])
    box.apply_translation([0, 4, 0.1])

    def export(mesh):
        files = mesh.export(file_type="gltf")  # {'model.gltf': json, 'gltf_buffer_0.bin': bytes}
        for name, data in files.items():
            (tmp_path / name).write_bytes(data)
        return next(n for n in files if n.endswith(".gltf"))

    gltf = export(box)
    scn = _scene(tmp_path, mesh=gltf)
    h1 = pipeline.scenario_hash(load_scenario(scn))
    gltf_text = (tmp_path / gltf).read_bytes()
    big = trimesh.creation.box(extents=[2.0, 0.2, 1.0])
    big.apply_translation([0, 4, 0.5])
    export(big)
    assert (tmp_path / gltf).read_bytes() != b"" and gltf_text  # the .bin changed (the JSON may too)
    (tmp_path / gltf).write_bytes(gltf_text)  # keep the JSON: only the buffer differs
    assert pipeline.scenario_hash(load_scenario(scn)) != h1


def test_stale_tile_folders_are_removed(tmp_path):
    """Tile folders of earlier versions of a scenario piled up in .pmmw-tiles."""
    scn = _scene(tmp_path)
    out = tmp_path / "out"
    assert _run("render", scn, "--out", out, "--keep-tiles").exit_code == 0
    assert _run("render", scn, "--out", out, "--keep-tiles", "--set", "render.spp=4").exit_code == 0
    folders = list((out / ".pmmw-tiles").iterdir())
    assert len(folders) == 1  # the spp-2 folder could never be resumed: removed
    other = out / ".pmmw-tiles" / "another_scene-0123456789abcdef"
    other.mkdir()
    assert _run("render", scn, "--out", out).exit_code == 0
    assert [p.name for p in (out / ".pmmw-tiles").iterdir()] == [other.name]  # other scenes' kept


# -- memory flat in spp ---------------------------------------------------------------------------


def test_a_tile_is_traced_in_waves_of_bounded_size(monkeypatch):
    """spp 4096 on one 32x32 tile took 4.8 GB: a pass is now split so no wave exceeds MAX_WAVE
    camera rays, and the estimate is unchanged (same pixels, same sample numbers)."""
    from pmmw.scene.camera import Camera
    from pmmw.scene.sky import UniformSky
    from pmmw.trace import integrator
    from pmmw.trace.integrator import Integrator
    from pmmw.trace.intersect import make_intersector
    from pmmw.trace.job import RenderSettings
    from tests.scenes import box, make_job, material

    cam = Camera.look_at((0, -3, 0.5), (0, 0, 0.5), (0, 0, 1), np.radians(30), (8, 8))
    job = make_job(
        [(box((-1, -0.1, 0), (1, 0.1, 1)), material("dielectric", 4 + 0.2j, 310.0))],
        cam,
        UniformSky(40.0, 290.0),
        35e9,
        settings=RenderSettings(spp=64, max_depth=8, tile=8, seed=3),
    )
    tile = job.tiles()[0]
    sizes = []

    def run(max_wave):
        monkeypatch.setattr(integrator, "MAX_WAVE", max_wave)
        it = Integrator(job, make_intersector(job.vertices, job.faces))
        real = it._trace
        it._trace = lambda px, start, nb: (sizes.append(px.size * nb), real(px, start, nb))[1]
        return it.render_tile(tile)

    whole = run(1 << 16)
    assert sizes == [64 * 64]
    sizes.clear()
    waves = run(300)
    assert max(sizes) <= 300 and sum(sizes) == 64 * 64
    assert np.array_equal(waves.samples, whole.samples)
    # the same estimator on other random draws: agree within their Monte Carlo errors
    err = np.sqrt(whole.stderr**2 + waves.stderr**2) + 1e-9
    z = (waves.mean - whole.mean) / err
    assert np.all(np.isfinite(z)) and np.mean(np.abs(z) < 4) > 0.97


# -- the console script ---------------------------------------------------------------------------


def test_no_traceback_from_the_console_script_for_an_unwritable_output(tmp_path):
    scn = _scene(tmp_path)
    (tmp_path / "file").write_text("x")
    exe = Path(sys.executable).with_name("pmmw")
    p = subprocess.run(
        [str(exe), "render", str(scn), "--out", str(tmp_path / "file" / "sub")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode in (1, 2) and "Traceback" not in p.stderr
    assert p.stderr.strip().count("\n") == 0 and p.stderr.startswith("error:"), p.stderr
    assert os.path.exists(tmp_path / "file")


def test_a_read_only_output_folder_is_one_line_with_status_1(tmp_path, monkeypatch):
    """A read-only file system was a traceback. (The test runs as root, which writes anywhere, so
    the file system's refusal is simulated where pmmw creates the folder.)"""
    real = Path.mkdir
    target = tmp_path / "ro" / "out"

    def read_only(self, *a, **k):
        if self == target:
            raise OSError(errno.EROFS, "Read-only file system", str(self))
        return real(self, *a, **k)

    monkeypatch.setattr(Path, "mkdir", read_only)
    res = _run("render", _scene(tmp_path), "--out", target)
    assert res.exit_code == 1
    _one_error_line(res, str(target), "cannot create the output folder: the file system is read-only")
