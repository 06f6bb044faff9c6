"""Reliability of the Python API and of small input-handling paths.

Every misuse of ``import pmmw`` (wrong types, wrong kinds of values, unknown keywords, ...) is a
`pmmw.UserError` naming the argument, never a raw TypeError/AttributeError/ValueError; numpy
scalars stand for Python numbers everywhere; the empty output folder, the sky's elevations and
the temperature keys follow one rule each; symlinked inputs take their format from the name the
user gave; over-long paths are one ``error:`` line; ``pmmw po`` stops soon after Ctrl-C.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh
import yaml

import pmmw
from tests.scenes import ground_and_block

SCENE = {  # the tiny scenario of tests/api/test_api.py
    "name": "tiny",
    "frequency": "35 GHz",
    "imager": {
        "position": [0, 0, 1.5],
        "look_at": [0, 4, 0.1],
        "fov": "20 deg",
        "resolution": [24, 16],
        "noise": "1 K",
    },
    "scene": [{"mesh": "ground.obj", "material": "concrete"}, {"mesh": "block.obj", "material": "metal"}],
    "sky": {"model": "uniform", "temperature": "40 K"},
    "render": {"spp": 2, "max_depth": 4, "tile": 8, "workers": 1},
}

PYTHON = sys.executable
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def f(tmp_path_factory):
    """A folder with the API tests' tiny scenario (tiny.yaml, ground.obj, block.obj) and a
    10 cm plate (plate.ply) for `pmmw.po`."""
    d = tmp_path_factory.mktemp("api")
    ground_and_block(d)
    (d / "tiny.yaml").write_text(yaml.safe_dump(SCENE))
    plate = trimesh.Trimesh(
        [[-0.05, -0.05, 0], [0.05, -0.05, 0], [0.05, 0.05, 0], [-0.05, 0.05, 0]], [[0, 1, 2], [0, 2, 3]]
    )
    plate.export(d / "plate.ply")

    class F:
        dir = d
        yaml = d / "tiny.yaml"
        plate = d / "plate.ply"
        scn = pmmw.Scenario.load(d / "tiny.yaml")
        out = d / "never"  # no misuse may create it

    return F


def _po(f, **kw):
    args = {"frequency": "95 GHz", "material": "metal", "theta": "0:10:5", **kw}
    return pmmw.po(args.pop("mesh", f.plate), **args)


def _brdf(**kw):
    return pmmw.brdf(
        **{
            "method": "analytic",
            "eps": "1+1e4j",
            "frequency": "95 GHz",
            "model": "beckmann",
            "alpha": 0.2,
            "double": False,
            **kw,
        }
    )


def _sweep(f, **kw):
    args = {"scenario": f.yaml, "grid": {"render.seed": [1]}, "out": f.out, **kw}
    return pmmw.sweep(**args)


# (id, call, a text the message must hold: the argument or key it names)
MISUSES = [
    # Scenario.load / from_dict / set
    ("load-int", lambda f: pmmw.Scenario.load(42), "path"),
    ("load-none", lambda f: pmmw.Scenario.load(None), "path"),
    ("load-list", lambda f: pmmw.Scenario.load([str(f.yaml)]), "path"),
    ("load-bytes", lambda f: pmmw.Scenario.load(b"tiny.yaml"), "path"),
    ("load-empty", lambda f: pmmw.Scenario.load(""), "path"),
    ("load-unknown-kw", lambda f: pmmw.Scenario.load(f.yaml, base_dir="."), "base_dir"),
    ("from_dict-str", lambda f: pmmw.Scenario.from_dict("name: x"), "data"),
    ("from_dict-none", lambda f: pmmw.Scenario.from_dict(None), "data"),
    ("from_dict-list", lambda f: pmmw.Scenario.from_dict([SCENE]), "data"),
    ("from_dict-int-key", lambda f: pmmw.Scenario.from_dict({**SCENE, 1: 2}), "data"),
    ("from_dict-base_dir-int", lambda f: pmmw.Scenario.from_dict(SCENE, base_dir=3), "base_dir"),
    ("from_dict-base_dir-none", lambda f: pmmw.Scenario.from_dict(SCENE, base_dir=None), "base_dir"),
    ("from_dict-base_dir-empty", lambda f: pmmw.Scenario.from_dict(SCENE, base_dir=""), "base_dir"),
    ("set-str", lambda f: f.scn.set("imager.noise=2 K"), "values"),
    ("set-list", lambda f: f.scn.set([("imager.noise", "2 K")]), "values"),
    ("set-int-key", lambda f: f.scn.set({1: "x"}), "1"),
    ("set-empty-key", lambda f: f.scn.set({"": 1}), "values"),
    ("set-malformed-key", lambda f: f.scn.set({"imager..noise": 1}), "imager..noise"),
    ("set-float-spp", lambda f: pmmw.validate(f.scn.set({"render.spp": 2.5})), "render.spp"),
    ("set-float-seed", lambda f: pmmw.validate(f.scn.set({"render.seed": 1.5})), "render.seed"),
    ("set-bool-spp", lambda f: pmmw.validate(f.scn.set({"render.spp": True})), "render.spp"),
    ("set-str-resolution", lambda f: pmmw.validate(f.scn.set({"imager.resolution": "big"})), "imager.resolution"),
    ("set-past-end", lambda f: pmmw.validate(f.scn.set({"scene[9].material": "x"})), "scene[9].material"),
    ("set-object-noise", lambda f: pmmw.validate(f.scn.set({"imager.noise": object()})), "imager.noise"),
    ("set-str-workers", lambda f: pmmw.validate(f.scn.set({"render.workers": "two"})), "render.workers"),
    ("set-unknown-key", lambda f: pmmw.validate(f.scn.set({"imager.nosie": "1 K"})), "imager.nosie"),
    ("set-unknown-channel", lambda f: pmmw.validate(f.scn.set({"output.channels": ["I", "X"]})), "output.channels"),
    ("set-empty-dir", lambda f: pmmw.validate(f.scn.set({"output.dir": ""})), "output.dir"),
    ("set-fov-list", lambda f: pmmw.validate(f.scn.set({"imager.fov": [1, 2]})), "imager.fov"),
    ("set-dict-into-scalar", lambda f: pmmw.validate(f.scn.set({"name.x": 1})), "name.x"),
    # validate
    ("validate-int", lambda f: pmmw.validate(42), "scenario"),
    ("validate-none", lambda f: pmmw.validate(None), "scenario"),
    ("validate-list", lambda f: pmmw.validate([str(f.yaml)]), "scenario"),
    ("validate-bytes", lambda f: pmmw.validate(bytes(f.yaml)), "scenario"),
    ("validate-folder", lambda f: pmmw.validate(f.dir), "not a file"),
    ("validate-unknown-kw", lambda f: pmmw.validate(f.yaml, spp=2), "spp"),
    ("validate-missing", lambda f: pmmw.validate(), "scenario"),
    # render
    ("render-str-spp", lambda f: pmmw.render(f.scn, spp="8"), "spp"),
    ("render-negative-spp", lambda f: pmmw.render(f.scn, spp=-1), "spp"),
    ("render-zero-spp", lambda f: pmmw.render(f.scn, spp=0), "spp"),
    ("render-float-spp", lambda f: pmmw.render(f.scn, spp=2.5), "spp"),
    ("render-bool-spp", lambda f: pmmw.render(f.scn, spp=True), "spp"),
    ("render-str-workers", lambda f: pmmw.render(f.scn, workers="2"), "workers"),
    ("render-zero-workers", lambda f: pmmw.render(f.scn, workers=0), "workers"),
    ("render-float-workers", lambda f: pmmw.render(f.scn, workers=1.5), "workers"),
    ("render-float-seed", lambda f: pmmw.render(f.scn, seed=1.5), "seed"),
    ("render-negative-seed", lambda f: pmmw.render(f.scn, seed=-1), "seed"),
    ("render-str-seed", lambda f: pmmw.render(f.scn, seed="1"), "seed"),
    ("render-int-out", lambda f: pmmw.render(f.scn, out=3), "out"),
    ("render-empty-out", lambda f: pmmw.render(f.scn, out=""), "out"),
    ("render-list-out", lambda f: pmmw.render(f.scn, out=[str(f.out)]), "out"),
    ("render-str-quiet", lambda f: pmmw.render(f.scn, quiet="yes"), "quiet"),
    ("render-unknown-kw", lambda f: pmmw.render(f.scn, sp=4), "sp"),
    ("render-positional-spp", lambda f: pmmw.render(f.scn, 4), "spp"),
    ("render-int-scenario", lambda f: pmmw.render(42), "scenario"),
    ("render-none-scenario", lambda f: pmmw.render(None), "scenario"),
    ("render-channels", lambda f: pmmw.render(f.scn.set({"output.channels": ["I", "Z"]})), "output.channels"),
    # sky
    ("sky-str-atmosphere", lambda f: pmmw.sky("95 GHz", atmosphere="standard"), "atmosphere"),
    ("sky-list-atmosphere", lambda f: pmmw.sky("95 GHz", atmosphere=[("profile", "standard")]), "atmosphere"),
    ("sky-negative-elevation", lambda f: pmmw.sky("95 GHz", elevations_deg=[-5]), "elevations_deg"),
    ("sky-elevation-above-90", lambda f: pmmw.sky("95 GHz", elevations_deg=[95]), "elevations_deg"),
    ("sky-scalar-elevations", lambda f: pmmw.sky("95 GHz", elevations_deg=5), "elevations_deg"),
    ("sky-str-elevation", lambda f: pmmw.sky("95 GHz", elevations_deg=["ten"]), "elevations_deg"),
    ("sky-nan-elevation", lambda f: pmmw.sky("95 GHz", elevations_deg=[float("nan")]), "elevations_deg"),
    ("sky-no-elevations", lambda f: pmmw.sky("95 GHz", elevations_deg=[]), "elevations_deg"),
    ("sky-none-frequency", lambda f: pmmw.sky(None), "frequency"),
    ("sky-list-frequency", lambda f: pmmw.sky([95e9]), "frequency"),
    ("sky-bool-frequency", lambda f: pmmw.sky(True), "frequency"),
    ("sky-wrong-unit", lambda f: pmmw.sky("95 kg"), "frequency"),
    ("sky-unknown-profile", lambda f: pmmw.sky("95 GHz", {"profile": "martian"}), "profile"),
    ("sky-unknown-key", lambda f: pmmw.sky("95 GHz", {"profle": "standard"}), "profle"),
    ("sky-unknown-kw", lambda f: pmmw.sky("95 GHz", elevations=[10]), "elevations"),
    # brdf
    ("brdf-unknown-method", lambda f: _brdf(method="fast"), "method"),
    ("brdf-int-method", lambda f: _brdf(method=1), "method"),
    ("brdf-str-incidence", lambda f: _brdf(incidence="thirty"), "incidence"),
    ("brdf-none-incidence", lambda f: _brdf(incidence=None), "incidence"),
    ("brdf-str-samples", lambda f: pmmw.brdf(eps="4+0.1j", frequency="95 GHz", alpha=0.2, samples="many"), "samples"),
    ("brdf-float-samples", lambda f: pmmw.brdf(eps="4+0.1j", frequency="95 GHz", alpha=0.2, samples=1.5), "samples"),
    ("brdf-str-seed", lambda f: pmmw.brdf(eps="4+0.1j", frequency="95 GHz", alpha=0.2, seed="x"), "seed"),
    ("brdf-scalar-stokes", lambda f: _brdf(stokes=5), "stokes"),
    ("brdf-unknown-option", lambda f: _brdf(roughness=0.2), "roughness"),
    ("brdf-str-alpha", lambda f: _brdf(alpha="rough"), "alpha"),
    ("brdf-int-out", lambda f: _brdf(out=5), "out"),
    ("brdf-empty-out", lambda f: _brdf(out=""), "out"),
    ("brdf-int-stack", lambda f: pmmw.brdf(stack=5), "stack"),
    ("brdf-str-threshold", lambda f: _brdf(threshold="x"), "threshold"),
    ("brdf-none-double_samples", lambda f: _brdf(double_samples=None), "double_samples"),
    ("brdf-str-mueller", lambda f: _brdf(mueller="yes"), "mueller"),
    ("brdf-dict-eps", lambda f: _brdf(eps={"re": 1}), "eps"),
    # po
    ("po-int-mesh", lambda f: _po(f, mesh=5), "mesh"),
    ("po-none-mesh", lambda f: _po(f, mesh=None), "mesh"),
    ("po-none-frequency", lambda f: _po(f, frequency=None), "frequency"),
    ("po-tuple-incidence", lambda f: _po(f, incidence=(0, 0, 0)), "incidence"),
    ("po-dict-incidence", lambda f: _po(f, incidence={"theta": 0}), "incidence"),
    ("po-list-theta", lambda f: _po(f, theta=[0, 10, 20, 30]), "theta"),
    ("po-dict-phi", lambda f: _po(f, phi={"a": 1}), "phi"),
    ("po-str-bounces", lambda f: _po(f, bounces="2"), "bounces"),
    ("po-float-bounces", lambda f: _po(f, bounces=1.5), "bounces"),
    ("po-zero-bounces", lambda f: _po(f, bounces=0), "bounces"),
    ("po-bad-polarization", lambda f: _po(f, polarization="x"), "polarization"),
    ("po-bad-method", lambda f: _po(f, method="fast"), "method"),
    ("po-str-monostatic", lambda f: _po(f, monostatic="yes"), "monostatic"),
    ("po-int-material", lambda f: _po(f, material=5), "material"),
    ("po-dict-eps", lambda f: _po(f, material=None, eps={"re": 5}), "eps"),
    ("po-no-material", lambda f: _po(f, material=None), "material"),
    ("po-unknown-kw", lambda f: _po(f, freq="95 GHz"), "freq"),
    ("po-missing-mesh", lambda f: _po(f, mesh=f.dir / "nope.ply"), "nope.ply"),
    # sweep
    ("sweep-list-grid", lambda f: _sweep(f, grid=[("render.seed", [1])]), "grid"),
    ("sweep-scalar-values", lambda f: _sweep(f, grid={"render.seed": 1}), "grid"),
    ("sweep-int-key", lambda f: _sweep(f, grid={1: [1]}), "grid"),
    ("sweep-empty-grid", lambda f: _sweep(f, grid={}), "grid"),
    ("sweep-empty-values", lambda f: _sweep(f, grid={"render.seed": []}), "grid"),
    ("sweep-no-out", lambda f: pmmw.sweep(f.yaml, {"render.seed": [1]}), "out"),
    ("sweep-int-out", lambda f: _sweep(f, out=5), "out"),
    ("sweep-empty-out", lambda f: _sweep(f, out=""), "out"),
    ("sweep-dict-scenario", lambda f: _sweep(f, scenario=SCENE), "scenario"),
    ("sweep-int-scenario", lambda f: _sweep(f, scenario=3), "scenario"),
    ("sweep-bad-executor", lambda f: _sweep(f, executor="slurm"), "executor"),
    ("sweep-str-workers", lambda f: _sweep(f, workers="2"), "workers"),
    ("sweep-str-zip", lambda f: _sweep(f, zip="yes"), "zip"),
    ("sweep-str-resume", lambda f: _sweep(f, resume="no"), "resume"),
]


def test_the_misuse_list_is_long_enough():
    """The issue asks for at least 66 misuses covering every public function."""
    assert len(MISUSES) >= 66
    assert len({m[0] for m in MISUSES}) == len(MISUSES)


@pytest.mark.parametrize("name, call, names", MISUSES, ids=[m[0] for m in MISUSES])
def test_a_misuse_is_a_user_error_naming_the_argument(f, name, call, names):
    """A UserError (exactly what `pmmw render` prints after 'error: '), naming the argument or
    key; nothing written."""
    with pytest.raises(pmmw.UserError) as info:
        call(f)
    assert names in str(info.value), str(info.value)
    assert "\n" not in str(info.value) or isinstance(info.value, pmmw.UserErrors)
    assert not f.out.exists()


# -- numpy values -------------------------------------------------------------------------------

# (key, numpy value, the Python value it stands for): integer, float and boolean types in keys of
# every kind (counts, pixel pairs, quantities, plain numbers, vectors, flags, lists)
NUMPY_VALUES = [
    ("render.spp", np.int64(3), 3),
    ("render.seed", np.uint32(7), 7),
    ("imager.resolution", [np.int64(12), np.int32(8)], [12, 8]),
    ("imager.noise", np.float32(0.5), 0.5),
    ("imager.noise", np.int64(2), 2),
    ("imager.fov", np.float64(15.0), 15.0),
    ("imager.position", np.array([0.0, 0.0, 1.5]), [0.0, 0.0, 1.5]),
    ("imager.band_samples", np.int16(3), 3),
    ("render.threshold", np.float32(0.25), float(np.float32(0.25))),
    ("scene[0].transform.scale", np.int64(2), 2),
    ("output.previews", np.bool_(False), False),
    ("sky.temperature", np.float16(40.0), 40.0),
]


@pytest.mark.parametrize("key, value, same", NUMPY_VALUES, ids=[f"{k}-{type(v).__name__}" for k, v, _ in NUMPY_VALUES])
def test_a_numpy_value_stands_for_its_python_value(f, key, value, same):
    """`Scenario.set` and `Scenario.from_dict` take a numpy value wherever its Python type goes,
    and resolve it to exactly what the Python value gives."""
    want = f.scn.set({key: same}).resolved()
    assert f.scn.set({key: value}).resolved() == want
    top, _, rest = key.partition(".")
    if top != "scene[0]":  # the mapping's own values too (a key of the list's entries: by `set` alone)
        data = yaml.safe_load(f.yaml.read_text())
        data.setdefault(top, {})[rest] = value
        got = pmmw.Scenario.from_dict(data, base_dir=f.dir).resolved()
        assert got.model_dump(exclude={"source_file"}) == want.model_dump(exclude={"source_file"})


def test_numpy_arguments_of_the_functions(f):
    """numpy scalars and arrays as the functions' arguments: the same results as Python's."""
    ds = pmmw.render(f.scn, spp=np.int64(1), seed=np.uint8(3), workers=np.int32(1), quiet=np.bool_(True))
    assert ds.attrs["spp"] == 1 and ds.attrs["seed"] == 3
    sky = pmmw.sky(np.float64(95e9), {"profile": "standard"}, elevations_deg=np.array([10, 90]))
    assert sky["Tv"].sel(elevation=90).item() == pytest.approx(pmmw.sky("95 GHz", elevations_deg=[90])["Tv"].item())
    a = pmmw.po(
        f.plate,
        frequency=np.float32(95e9),
        material="metal",
        theta=np.float64(0.0),
        phi=np.array([0, 90]),
        bounces=np.int64(1),
        monostatic=np.bool_(False),
    )
    b = pmmw.po(f.plate, frequency=float(np.float32(95e9)), material="metal", theta="0", phi="0,90")
    np.testing.assert_array_equal(a["rcs_theta"].values, b["rcs_theta"].values)


# -- one rule each: the empty folder, the sky's elevations, temperatures -------------------------


def test_an_empty_output_folder_is_refused_by_the_api_and_in_a_scenario(f, tmp_path, monkeypatch):
    """``out=""`` and ``output.dir: ""`` are refused alike, each naming its argument or key;
    nothing is written into the current folder."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(pmmw.UserError, match=r"pmmw\.render: out: an empty path"):
        pmmw.render(f.scn, out="")
    for value in ("", "  "):
        with pytest.raises(pmmw.UserError, match=r"output\.dir: expected a folder path"):
            pmmw.render(f.scn.set({"output.dir": value}))
    assert list(tmp_path.iterdir()) == []


ELEVATIONS = [("-5", [-5]), ("95", [95]), ("nan", [float("nan")]), ("ten", ["ten"]), ("", [])]


@pytest.mark.parametrize("text, values", ELEVATIONS, ids=[t or "empty" for t, _ in ELEVATIONS])
def test_the_sky_api_and_command_refuse_the_same_elevations(text, values):
    """`pmmw.sky` and `pmmw sky --elevations` share one check (`skycmd.parse_elevations`)."""
    from typer.testing import CliRunner

    from pmmw_cli.cli import app

    with pytest.raises(pmmw.UserError, match="elevations_deg"):
        pmmw.sky("95 GHz", elevations_deg=values)
    res = CliRunner().invoke(app, ["sky", "-f", "95 GHz", "--elevations", text])
    assert res.exit_code == 2 and "error: --elevations:" in res.output, res.output


def test_the_edges_of_the_elevations_are_taken_by_both():
    from typer.testing import CliRunner

    from pmmw_cli.cli import app

    ds = pmmw.sky("95 GHz", elevations_deg=[0, 90])
    res = CliRunner().invoke(app, ["sky", "-f", "95 GHz", "--elevations", "0,90", "--format", "csv"])
    assert res.exit_code == 0, res.output
    rows = [line.split(",") for line in res.output.strip().splitlines()[1:]]
    np.testing.assert_allclose([float(r[1]) for r in rows], ds["Tv"].values, atol=1e-3)  # the CSV's 3 decimals


TEMPERATURE_KEYS = [
    ("sky", {"model": "uniform", "temperature": "{t}"}),
    ("sky", {"model": "uniform", "temperature": "40 K", "ground_temperature": "{t}"}),
    ("atmosphere", {"model": "uniform", "loss": "0.1 dB/km", "temperature": "{t}"}),
    ("atmosphere", {"profile": "standard", "ground_temperature": "{t}"}),
    ("render", {"spp": 2, "max_depth": 4, "tile": 8, "workers": 1, "default_temperature": "{t}"}),
    ("materials", {"warm": {"eps": [3, 0.1], "temperature": "{t}"}}),
]


def _with(value, t):
    if isinstance(value, dict):
        return {k: _with(v, t) for k, v in value.items()}
    return value.format(t=t) if isinstance(value, str) else value


@pytest.mark.parametrize(
    "top, value",
    TEMPERATURE_KEYS,
    ids=[
        "sky.temperature",
        "sky.ground_temperature",
        "atmosphere.temperature",
        "atmosphere.ground_temperature",
        "render.default_temperature",
        "materials.temperature",
    ],
)
def test_every_temperature_key_has_one_bound(f, top, value):
    """0 K is refused by every temperature key (a uniform sky too, which took it) and the
    smallest physical one, the cosmic background's 2.7 K, is taken by each."""
    pmmw.validate(f.scn.set({top: _with(value, "2.7 K")}))
    with pytest.raises(pmmw.UserError, match=r"temperature must be > 0 K"):
        pmmw.validate(f.scn.set({top: _with(value, "0 K")}))


# -- symbolic links: the format from the name given ----------------------------------------------


@pytest.fixture
def store(f, tmp_path):
    """A content-addressed store (files named by hash, no extension) and links into it: the
    block as GLB and PLY, a sky texture."""
    from pmmw.scene.sky_texture import write_sky_texture

    (tmp_path / "store").mkdir()
    scene = tmp_path / "scene"
    scene.mkdir()
    block = trimesh.load(f.dir / "block.obj", force="mesh")
    (tmp_path / "store" / "ab12cd").write_bytes(trimesh.exchange.gltf.export_glb(trimesh.Scene(block)))
    block.export(tmp_path / "store" / "ef34.ply")
    (tmp_path / "store" / "9999").write_bytes((tmp_path / "store" / "ef34.ply").read_bytes())
    write_sky_texture(tmp_path / "store" / "t.exr", np.full((8, 16), 30.0), np.full((8, 16), 30.0))
    (tmp_path / "store" / "t.exr").rename(tmp_path / "store" / "77aa")
    for name, target in (("block.glb", "ab12cd"), ("block_ply", "ef34.ply"), ("bare", "9999"), ("sky.exr", "77aa")):
        (scene / name).symlink_to(Path("..") / "store" / target)
    (scene / "ground.obj").symlink_to(f.dir / "ground.obj")
    return scene


def _scene_with(mesh: str, sky=None) -> dict:
    data = {**SCENE, "scene": [{"mesh": "ground.obj", "material": "concrete"}, {"mesh": mesh, "material": "metal"}]}
    return {**data, "sky": sky} if sky else data


def test_a_link_to_an_extensionless_file_takes_the_format_of_its_name(store):
    """``scene/block.glb -> ../store/ab12cd``: a GLB, as its name says; an extension-less link
    takes its target's extension; the sky texture links likewise."""
    v = pmmw.validate(pmmw.Scenario.from_dict(_scene_with("block.glb", {"texture": "sky.exr"}), base_dir=store))
    assert v["geometry"]["triangles"] == 24
    v = pmmw.validate(pmmw.Scenario.from_dict(_scene_with("block_ply"), base_dir=store))
    assert v["geometry"]["triangles"] == 24
    rcs = pmmw.po(store / "block.glb", frequency="95 GHz", material="metal", theta="0")
    assert rcs["rcs_theta"].item() > 0


def test_a_file_without_extension_anywhere_is_named_with_the_known_formats(store):
    with pytest.raises(pmmw.UserError) as info:
        pmmw.validate(pmmw.Scenario.from_dict(_scene_with("bare"), base_dir=store))
    text = str(info.value)
    assert "scene[1].mesh" in text and "'bare' has no extension" in text and "store/9999" in text
    assert ".glb, .gltf, .obj, .ply, .stl" in text
    with pytest.raises(pmmw.UserError, match=r"'bare' has no extension to tell its mesh format .*\.ply"):
        pmmw.po(store / "bare", frequency="95 GHz", material="metal", theta="0")


# -- paths too long for the file system -----------------------------------------------------------


def _cli(*args):
    from typer.testing import CliRunner

    from pmmw_cli.cli import app

    return CliRunner().invoke(app, [str(a) for a in args])


def _one_error_line(res, status=2):
    lines = res.output.strip().splitlines()
    assert res.exit_code == status and len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert len(lines[0]) < 400, lines[0]  # the path cut to a readable length (SHOWN = 120 characters)
    return lines[0]


LONG_NAME = "a" * 300 + ".yaml"  # one name over the 255 bytes of a file name


def test_an_overlong_path_is_one_error_line_naming_it(f, tmp_path):
    """A name over 255 bytes, or a path over 4096 bytes, in each input that takes a path: one
    `error:` line (no traceback), exit status 2, the file named but shortened."""
    deep = tmp_path / "/".join(["d" * 200] * 21) / "x.yaml"  # 21 names of 200 bytes: over 4096
    for path in (tmp_path / LONG_NAME, deep):
        line = _one_error_line(_cli("validate", path))
        assert "aaaa" in line or "dddd" in line
        with pytest.raises(pmmw.UserError, match="file systems take at most"):
            pmmw.validate(path)
    line = _one_error_line(_cli("po", tmp_path / ("b" * 300 + ".ply"), "-f", "95 GHz", "--material", "metal"))
    assert "bbbb" in line and "255 per name" in line
    _one_error_line(_cli("brdf", "--stack", tmp_path / LONG_NAME))
    _one_error_line(_cli("sky", "-f", "95 GHz", "--atmosphere", tmp_path / LONG_NAME))
    long_mesh = yaml.safe_load(f.yaml.read_text())
    long_mesh["scene"][1]["mesh"] = "m" * 300 + ".obj"
    (f.dir / "long_mesh.yaml").write_text(yaml.safe_dump(long_mesh))
    line = _one_error_line(_cli("validate", f.dir / "long_mesh.yaml"))
    assert "scene[1].mesh" in line and "mmmm" in line


# -- Ctrl-C in pmmw po ---------------------------------------------------------------------------

PO_EXIT_S = 10.0  # [s] from SIGINT to exit: the issue wants 1-2 s; 5x that for a busy 2-core machine


def test_sigint_stops_po_soon_with_its_own_line(tmp_path):
    """Ctrl-C during a long physical-optics sum (a 20k-facet sphere, 130k directions, minutes in
    one compiled call before): exit 130 within `PO_EXIT_S`, the one line ``interrupted: nothing
    written``, no file in --out."""
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.3)
    sphere.export(tmp_path / "sphere.ply")
    job = {
        "name": "big",
        "targets": [{"mesh": "sphere.ply", "material": "metal"}],
        "frequency": "95 GHz",
        "incidence": ["0 deg", "0 deg"],
        "observation": {"theta": "0:180:0.25", "phi": "0:359:2"},
        "method": "direct",
    }
    (tmp_path / "big.yaml").write_text(yaml.safe_dump(job))
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [PYTHON, "-c", "from pmmw_cli.__main__ import main; main()", "po", tmp_path / "big.yaml", "--out", out],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    time.sleep(6.0)  # past the imports, the mesh and the currents: in the far-field sum
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGINT)
    sent = time.monotonic()
    try:
        _, err = proc.communicate(timeout=PO_EXIT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail(f"pmmw po still running {PO_EXIT_S:g} s after SIGINT")
    took = time.monotonic() - sent
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == ["interrupted: nothing written"], err
    assert took < PO_EXIT_S
    assert not out.exists() or [p.name for p in out.iterdir() if not p.name.startswith(".")] == []
