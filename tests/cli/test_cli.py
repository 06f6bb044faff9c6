"""End to end, as a user runs it: `pmmw render`, `pmmw validate`, `pmmw materials`, and errors."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from typer.testing import CliRunner

from pmmw.io.exr import read_exr
from pmmw_cli.cli import app
from tests.scenes import tiny_scenario as _scene

runner = CliRunner()


def _run(*args):
    return runner.invoke(app, [str(a) for a in args])


def test_render_writes_exr_report_and_previews(tmp_path):
    scn = _scene(tmp_path)
    out = tmp_path / "out"
    res = _run("render", scn, "--out", out, "--workers", "1")
    assert res.exit_code == 0, res.output
    chans, attrs = read_exr(out / "tiny.exr")
    for c in ("I", "Q", "U", "V", "Ex2", "Ey2", "ideal.I", "ideal.Ey2"):
        assert c in chans and chans[c].shape == (16, 24)
    np.testing.assert_allclose(chans["I"], chans["Ex2"] + chans["Ey2"], rtol=1e-6)
    assert abs(attrs["pmmw:frequency_hz"] - 35e9) < 1
    # metal block reflects the 40 K sky and the ground at 290 K default temperature: the image
    # spans both and stays inside the scene's temperature range
    assert 40.0 - 1e-3 <= chans["Ex2"].min() and chans["Ex2"].max() <= 290.0 + 1e-3
    assert (out / "report.json").exists() and (out / "report.md").exists()
    assert (out / "previews" / "tiny_I.png").exists()
    assert not (out / ".pmmw-tiles").exists()
    assert attrs["compression"] == "none"  # output.compression's default: the fastest to write
    # the report states what the atmosphere does: dB/km at the ground and the path loss to the target
    atm = json.loads((out / "report.json").read_text())["atmosphere"]
    md = (out / "report.md").read_text()
    assert "## Atmosphere" in md
    assert f"{atm['specific_attenuation_at_ground_dB_per_km']:.3g} dB/km" in md
    assert f"{atm['path_loss_imager_to_target_dB']:.3g} dB" in md


def test_render_is_deterministic_whatever_the_worker_count(tmp_path):
    scn = _scene(tmp_path, render="{spp: 3, max_depth: 4, tile: 8, termination: roulette, threshold: 0.2}")
    assert _run("render", scn, "--out", tmp_path / "w1", "--workers", "1").exit_code == 0
    assert _run("render", scn, "--out", tmp_path / "w2", "--workers", "2").exit_code == 0
    a, _ = read_exr(tmp_path / "w1" / "tiny.exr")
    b, _ = read_exr(tmp_path / "w2" / "tiny.exr")
    for c in a:
        np.testing.assert_array_equal(a[c], b[c])


def test_resume_reuses_finished_tiles(tmp_path):
    scn = _scene(tmp_path)
    out = tmp_path / "out"
    assert _run("render", scn, "--out", out, "--workers", "1", "--keep-tiles").exit_code == 0
    tiles = sorted((out / ".pmmw-tiles").rglob("tile_*.npz"))
    assert len(tiles) == 6  # 24x16 pixels in 8x8 tiles
    first, _ = read_exr(out / "tiny.exr")
    tiles[0].unlink()  # as if the run had been interrupted before this tile
    res = _run("render", scn, "--out", out, "--workers", "1", "--resume")
    assert res.exit_code == 0, res.output
    again, _ = read_exr(out / "tiny.exr")
    for c in first:
        np.testing.assert_array_equal(first[c], again[c])


def test_validate_prints_the_resolved_job(tmp_path):
    res = _run("validate", _scene(tmp_path))
    assert res.exit_code == 0, res.output
    assert "35 GHz" in res.output and "concrete" in res.output and "triangles" in res.output


def test_materials_list_and_show():
    res = _run("materials", "list", "--frequency", "95 GHz")
    assert res.exit_code == 0 and "human_skin" in res.output
    res = _run("materials", "show", "murakowski2014.concrete")
    assert res.exit_code == 0 and "5.5" in res.output
    res = _run("materials", "show", "concrete")
    assert res.exit_code == 0 and "ITU-R P.2040-4" in res.output and "5.24" in res.output


@pytest.mark.parametrize(
    "extra, override, key",
    [
        ("", ["--set", "render.sppp=3"], "render.sppp"),
        ("", ["--set", "render.spp=many"], "render.spp"),
        ("", ["--set", "scene[1].material=unobtainium"], "scene[1].material"),
        ("", ["--set", "scene[0].mesh=missing.obj"], "scene[0].mesh"),
        ("", ["--set", "imager.noise=-3 K"], "imager.noise"),
        ("", ["--set", "frequency=95 m"], "frequency"),
        ("materials: {concrete: {eps: {35 GHz: [5.5, -0.5]}}}", [], "materials.concrete"),
        ("materials: {concrete: {roughness: {model: ggx, alpha: -1}}}", [], "materials.concrete.roughness.alpha"),
        (
            "materials: {concrete: {bump: {model: gaussian, rms: 1 cm, size: 1 m}}}",
            [],
            "materials.concrete.bump.correlation",
        ),
        (
            "materials: {concrete: {kind: thin, thickness: 1 mm, coating: [{material: denim, thickness: 1 mm, "
            "roughness: {model: ggx, alpha: 0.2}}]}}",
            [],
            "materials.concrete.coating[0].roughness",
        ),
    ],
)
def test_user_errors_name_file_and_key_without_traceback(tmp_path, extra, override, key):
    scn = _scene(tmp_path, extra=extra)
    res = _run("render", scn, "--out", tmp_path / "o", *override)
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    assert key in res.output
    assert ("tiny.yaml" in res.output) or ("--set" in res.output)


def test_malformed_yaml_and_missing_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nimager: {position: [0, 0\n")
    res = _run("validate", bad)
    assert res.exit_code == 2 and "bad.yaml" in res.output and "line" in res.output
    res = _run("render", tmp_path / "nope.yaml")
    assert res.exit_code == 2 and "nope.yaml" in res.output


def test_console_script_runs_without_traceback(tmp_path):
    """The installed `pmmw` entry point, as a shell user calls it."""
    exe = Path(sys.executable).parent / "pmmw"
    proc = subprocess.run([str(exe), "validate", str(tmp_path / "nope.yaml")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "nope.yaml" in proc.stderr


def test_interrupted_render_leaves_no_partial_file_and_resumes(tmp_path, monkeypatch):
    """Ctrl-C during tracing: exit 130, no EXR (not even a truncated one), finished tiles kept;
    `--resume` then renders only the rest and gives the same image as an uninterrupted run."""
    from pmmw.trace.integrator import Integrator

    scn = _scene(tmp_path)
    clean = tmp_path / "clean"
    assert _run("render", scn, "--out", clean, "--workers", "1").exit_code == 0
    original = Integrator.render_tile
    calls = {"n": 0}

    def flaky(self, tile):
        calls["n"] += 1
        if calls["n"] == 4:
            raise KeyboardInterrupt
        return original(self, tile)

    monkeypatch.setattr(Integrator, "render_tile", flaky)
    out = tmp_path / "out"
    res = _run("render", scn, "--out", out, "--workers", "1")
    assert res.exit_code == 130 and "--resume" in res.output
    assert not list(out.glob("*.exr")) and not list(out.glob(".*tmp*"))
    assert len(list((out / ".pmmw-tiles").rglob("tile_*.npz"))) == 3
    monkeypatch.setattr(Integrator, "render_tile", original)
    calls["n"] = 0
    assert _run("render", scn, "--out", out, "--workers", "1", "--resume").exit_code == 0
    a, _ = read_exr(clean / "tiny.exr")
    b, _ = read_exr(out / "tiny.exr")
    for c in a:
        np.testing.assert_array_equal(a[c], b[c])


def test_refracting_mesh_that_is_not_watertight_is_warned_about(tmp_path):
    """An open dielectric mesh gets a warning naming it (and goes on, as a user may intend it)."""
    from pmmw.errors import clear_warnings, collected_warnings
    from pmmw.pipeline import resolve

    plane = trimesh.Trimesh(vertices=[[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]], faces=[[0, 1, 2], [0, 2, 3]])
    plane.export(tmp_path / "plane.obj")
    scn = _scene(tmp_path, extra="")
    text = scn.read_text().replace("mesh: block.obj, material: metal", "mesh: plane.obj, material: polypropylene")
    scn.write_text(text)
    clear_warnings()
    resolve(scn)
    assert any("not watertight" in w and "plane.obj" in w for w in collected_warnings())
    clear_warnings()
    resolve(_scene(tmp_path))  # closed meshes: no such warning
    assert not any("not watertight" in w for w in collected_warnings())


def test_shards_then_resume_assemble_the_same_image(tmp_path):
    """Cluster use: two shards render disjoint tiles (any worker count), --resume assembles."""
    scn = _scene(tmp_path)
    assert _run("render", scn, "--out", tmp_path / "clean", "--workers", "1").exit_code == 0
    out = tmp_path / "out"
    for i, w in ((1, 1), (2, 2)):
        res = _run("render", scn, "--out", out, "--workers", w, "--shard", f"{i}/2")
        assert res.exit_code == 0, res.output
        assert not list(out.glob("*.exr"))
    assert len(list((out / ".pmmw-tiles").rglob("tile_*.npz"))) == 6
    res = _run("render", scn, "--out", out, "--resume")
    assert res.exit_code == 0 and "6 tiles found, 0 rendered" in res.output, res.output
    a, _ = read_exr(tmp_path / "clean" / "tiny.exr")
    b, _ = read_exr(out / "tiny.exr")
    for c in a:
        np.testing.assert_array_equal(a[c], b[c])
    for bad in ("0/2", "3/2", "1/0"):  # shards count from 1, as job arrays do
        res = _run("render", scn, "--shard", bad)
        assert res.exit_code == 2 and "--shard" in res.output


def test_a_shard_or_resume_with_other_settings_is_refused_naming_them(tmp_path):
    """A shard rendered with other settings used to be silently re-rendered at assembly, its
    tiles left behind: now the assembly (and any further shard) is refused, naming the folder and
    the settings that differ; a fresh render (no --resume) starts over and deletes them."""
    scn = _scene(tmp_path)
    out = tmp_path / "out"
    assert _run("render", scn, "--out", out, "--shard", "1/2").exit_code == 0
    res = _run("render", scn, "--out", out, "--shard", "2/2", "--spp", "4")
    assert res.exit_code == 2 and "render.spp: 2 -> 4" in res.output and "--shard 2/2" in res.output, res.output
    res = _run("render", scn, "--out", out, "--resume", "--set", "sky.temperature=50 K")
    assert res.exit_code == 2 and "sky.temperature" in res.output and "--resume" in res.output, res.output
    assert len(list((out / ".pmmw-tiles").rglob("tile_*.npz"))) == 3  # nothing deleted
    assert _run("render", scn, "--out", out, "--spp", "4").exit_code == 0
    assert not (out / ".pmmw-tiles").exists()


def test_sky_command_table_csv_map_and_plot(tmp_path):
    """`pmmw sky`: CSV header and rows, colder at zenith than near the horizon, fog warms the sky,
    the EXR map loads as a sky texture and reproduces the table, the plot is written."""
    from pmmw.scene.sky_texture import SkyTexture

    res = _run("sky", "--frequency", "95 GHz", "--format", "csv", "--elevations", "5,30,90")
    assert res.exit_code == 0, res.output
    lines = res.output.strip().splitlines()
    assert lines[0] == "elevation_deg,Tv_K,Th_K" and len(lines) == 4
    t = {float(r.split(",")[0]): float(r.split(",")[1]) for r in lines[1:]}
    assert t[90.0] < t[30.0] < t[5.0] < 300.0
    fog = _run(
        "sky",
        "-f",
        "95 GHz",
        "--format",
        "csv",
        "--elevations",
        "90",
        "--layer",
        "fog,0 m,600 m,1 g/m3",
        "--exr",
        tmp_path / "sky.exr",
        "--plot",
        tmp_path / "sky.png",
    )
    assert fog.exit_code == 0, fog.output
    t_fog = float(fog.output.strip().splitlines()[1].split(",")[1])
    assert t_fog > t[90.0] + 5.0
    tex = SkyTexture.load(tmp_path / "sky.exr")
    tv, th = tex.sample(np.array([[0.0, 0.0, 1.0]]))
    np.testing.assert_allclose(tv, t_fog, atol=0.5)  # the map's top row is within half a row of zenith
    assert (tmp_path / "sky.png").stat().st_size > 1000
    bad = _run("sky", "-f", "95 GHz", "--layer", "smog,0,1,2")
    assert bad.exit_code == 2 and "--layer" in bad.output


def test_resume_does_not_reuse_tiles_of_a_changed_mesh(tmp_path):
    """Tiles are keyed by the scenario and the content of its assets: after a mesh is edited in
    place, --resume refuses the old tiles (naming why) instead of mixing them in, and a fresh
    render draws the new geometry."""
    scn = _scene(tmp_path)
    out = tmp_path / "out"
    assert _run("render", scn, "--out", out, "--workers", "1", "--keep-tiles").exit_code == 0
    before, _ = read_exr(out / "tiny.exr")
    block = trimesh.creation.box(extents=[2.0, 0.2, 1.0])
    block.apply_translation([0, 4, 0.5])
    block.export(tmp_path / "block.obj")
    res = _run("render", scn, "--out", out, "--workers", "1", "--resume")
    assert res.exit_code == 2 and "other input files" in res.output, res.output
    assert _run("render", scn, "--out", out, "--workers", "1").exit_code == 0
    after, _ = read_exr(out / "tiny.exr")
    assert np.abs(after["ideal.Ex2"] - before["ideal.Ex2"]).max() > 1.0


@pytest.mark.parametrize("command", ["render", "sweep", "po", "validate", "brdf", "bench"])
def test_flags_show_no_value_in_help(command):
    """An on/off flag takes no value (`--resume`, not `--resume true`): the help must not show one."""
    res = runner.invoke(app, [command, "--help"], env={"COLUMNS": "200"})
    assert res.exit_code == 0
    flag_lines = [line for line in res.output.splitlines() if "<bool>" in line and "--help" not in line]
    assert flag_lines == []


def test_validate_shows_the_slab_skys_default_opacity():
    """`validate` states the opacity the slab sky takes when none is given, and the zenith
    brightness it gives: 18.5 K at 35 GHz (the clear US standard atmosphere of PHYSICS.md)."""
    from pmmw.pipeline import validate

    sky = validate("configs/cinderblocks_35ghz.yaml")["sky"]["35 GHz"]
    assert sky["zenith_opacity_from"].startswith("default")
    assert sky["zenith_K"] == pytest.approx(18.5, abs=0.01)
    given = validate("configs/cinderblocks_35ghz.yaml", ["sky.zenith_opacity=0.2"])["sky"]["35 GHz"]
    assert given["zenith_opacity_Np"] == pytest.approx(0.2) and given["zenith_opacity_from"] == "sky.zenith_opacity"


def test_the_readme_lists_exactly_the_required_keys():
    """The scenario guide's (docs/guide/scenario.md) "Required keys" against the schema's required fields (source_file is set by the loader;
    `frequency` is the file's spelling of `frequencies`; a scene entry's material is checked apart)."""
    import re

    import pydantic

    from pmmw.config import schema

    def required(model, prefix):
        out = []
        for name, f in model.model_fields.items():
            if f.is_required() and name != "source_file":
                if isinstance(f.annotation, type) and issubclass(f.annotation, pydantic.BaseModel):
                    out += required(f.annotation, prefix + name + ".")  # a section: its required keys
                else:
                    out.append(prefix + {"frequencies": "frequency"}.get(name, name))
        return out

    want = set(required(schema.ScenarioConfig, "")) | {"scene[i]." + k for k in required(schema.SceneEntry, "")}
    want |= {"atmosphere.layers[i]." + k for k in required(schema.WeatherLayer, "")}
    text = (Path(__file__).resolve().parents[2] / "docs" / "guide" / "scenario.md").read_text()  # the scenario guide
    para = text[text.index("Required keys") : text.index("```yaml", text.index("Required keys"))]
    listed = set(
        re.findall(
            r"`([a-z_.\[\]]+)`",
            para.replace("`.base`", "`atmosphere.layers[i].base`").replace("`.top`", "`atmosphere.layers[i].top`"),
        )
    )
    listed -= {"scene[i].material", "scene[i].materials", "# required"}
    assert listed == want


def test_depth_and_material_previews_with_their_legends(tmp_path):
    """`output.aux: [depth, material]` with ``--figures`` gives two more figures, listed in the
    report: depth on a scale in metres, materials in distinct colours with the database ids in a
    legend."""
    scn = _scene(tmp_path, extra="output: {aux: [depth, material]}")
    res = _run("render", scn, "--out", tmp_path / "o", "--workers", "1", "-q", "--figures")
    assert res.exit_code == 0, res.output
    prev = tmp_path / "o" / "previews"
    assert (prev / "tiny_depth.png").stat().st_size > 5_000 and (prev / "tiny_material.png").stat().st_size > 5_000
    md = (tmp_path / "o" / "report.md").read_text()
    assert "![aux.depth](previews/tiny_depth.png)" in md and "![aux.material](previews/tiny_material.png)" in md
    # the legend's colours: the sky, concrete and metal are three distinct colours in the picture
    import OpenImageIO as oiio

    px = oiio.ImageBuf(str(prev / "tiny_material.png")).get_pixels(oiio.FLOAT)[..., :3]
    colours = {tuple(np.round(c, 2)) for c in px.reshape(-1, 3)}
    assert len(colours) >= 4  # sky, concrete, metal and the white page


def test_bench_render_times_report_trace_against_embree(tmp_path):
    """`pmmw bench --render-times`'s table (`docs/benchmarks.md`): per config the rays, the trace
    time, Embree's time for those rays and their ratio (trace x workers / Embree: above 1, since
    the trace contains the intersection), and the whole command."""
    from pmmw_cli.bench import _render_times_section

    scn = _scene(tmp_path)
    text = _render_times_section([str(scn)], workers=1)
    row = [ln for ln in text.splitlines() if ln.startswith(f"| `{scn}`")]
    assert len(row) == 1
    cells = [c.strip() for c in row[0].strip("|").split("|")]
    assert cells[1] == "24 x 16" and cells[2] == "2"
    rays, trace, embree, ratio, command = (float(c) for c in cells[3:])
    assert rays > 0 and trace >= 0 and command >= trace
    assert embree >= 0 and (ratio > 1.0 or embree == 0.0)
    assert "| config | pixels | spp | rays [M] | trace [s] | Embree [s] | ratio | command [s] |" in text


def test_output_compression_zip_writes_the_same_pixels_smaller(tmp_path):
    """``output.compression: zip``: the same float32 pixels (bit for bit) in an OpenEXR ZIP file,
    smaller than the default uncompressed one (the ideal image's smooth ground compresses); the
    Blender add-on's reader takes both (tests/blender). An unknown value is one error line naming
    the key (the control)."""
    scn = _scene(tmp_path)
    assert _run("render", scn, "--out", tmp_path / "a", "--workers", "1", "-q").exit_code == 0
    res = _run("render", scn, "--out", tmp_path / "z", "--workers", "1", "-q", "--set", "output.compression=zip")
    assert res.exit_code == 0, res.output
    a, ha = read_exr(tmp_path / "a" / "tiny.exr")
    z, hz = read_exr(tmp_path / "z" / "tiny.exr")
    assert (ha["compression"], hz["compression"]) == ("none", "zip")
    assert all(np.array_equal(a[c], z[c]) for c in a)
    assert (tmp_path / "z" / "tiny.exr").stat().st_size < (tmp_path / "a" / "tiny.exr").stat().st_size
    res = _run("render", scn, "--out", tmp_path / "b", "-q", "--set", "output.compression=zstd")
    assert res.exit_code == 2 and "output.compression" in res.output
