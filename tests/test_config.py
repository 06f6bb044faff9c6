"""Scenario YAML -> typed Scenario: SI values, defaults, overrides, and one clear error per problem."""

import math
from pathlib import Path

import pytest

from pmmw_cli.config import apply_overrides, load_scenario
from pmmw_cli.errors import UserError, UserErrors

BASE = """
name: t
frequency: 95 GHz
imager: {position: [0, -1000, 70], look_at: [0, 0, 0], fov: 10 deg, resolution: [50, 40], aperture_diameter: 0.6 m, noise: 4 K}
scene:
  - {mesh: m.obj, material: concrete}
"""


def write(tmp_path: Path, text: str = BASE, name="s.yaml") -> Path:
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    p = tmp_path / name
    p.write_text(text)
    return p


def error_text(excinfo) -> str:
    return str(excinfo.value)


def test_quantities_become_si(tmp_path):
    s = load_scenario(write(tmp_path, BASE + "atmosphere: {loss: 1 dB/km, temperature: 10 degC}\n"))
    assert s.frequencies == (95e9,)
    assert math.isclose(s.imager.fov, math.radians(10))
    assert s.imager.aperture_diameter == 0.6 and s.imager.noise == 4.0
    assert s.imager.resolution == (50, 40)
    assert math.isclose(s.atmosphere.loss, math.log(10) / 10 * 1e-3)  # power Np/m
    assert math.isclose(s.atmosphere.temperature, 283.15)
    assert s.scene[0].mesh == (tmp_path / "m.obj").resolve()


def test_defaults(tmp_path):
    s = load_scenario(write(tmp_path))
    assert s.atmosphere is None and s.sky.model == "slab" and s.sky.ground_temperature == 290.0
    assert (s.render.spp, s.render.max_depth, s.render.threshold, s.render.seed) == (16, 6, 1e-3, 1)
    assert s.render.workers is None and s.render.termination == "roulette"
    assert s.output.channels == ("I", "Q", "U", "V", "Ex2", "Ey2") and s.output.aux == ()
    assert s.scene[0].transform.scale == 1.0


def test_frequency_list_and_imager_alias(tmp_path):
    s = load_scenario(write(tmp_path, BASE.replace("frequency: 95 GHz", "frequency: [35 GHz, 95 GHz]")))
    assert s.frequencies == (35e9, 95e9)
    s = load_scenario(write(tmp_path), ["imager.frequency=35 GHz"])
    assert s.frequencies == (35e9,)  # imager.frequency takes precedence


def test_overrides(tmp_path):
    raw = {"render": {"spp": 4}, "scene": [{"material": "a"}, {"material": "b"}]}
    out = apply_overrides(raw, ["render.spp=64", "scene[1].material=metal", "scene.0.material=x",
                                "sky.model=uniform", "imager.resolution=[100, 80]", "name=a b"])
    assert out["render"]["spp"] == 64 and out["scene"][1]["material"] == "metal"
    assert out["scene"][0]["material"] == "x" and out["sky"] == {"model": "uniform"}
    assert out["imager"]["resolution"] == [100, 80] and out["name"] == "a b"
    assert raw["render"]["spp"] == 4  # the input is not modified
    with pytest.raises(UserError, match="KEY.PATH=VALUE"):
        apply_overrides(raw, ["render.spp"])
    with pytest.raises(UserError, match="past the end"):
        apply_overrides(raw, ["scene[5].material=x"])


def test_cli_values_apply_after_overrides(tmp_path):
    s = load_scenario(write(tmp_path), ["render.spp=3"], cli={"spp": 7, "seed": 9, "workers": 2, "out": tmp_path / "o"})
    assert (s.render.spp, s.render.seed, s.render.workers) == (7, 9, 2)
    assert s.output.dir == (tmp_path / "o").resolve()


@pytest.mark.parametrize(
    "edit, key, words",
    [
        (("fov: 10 deg", "fov: 10 deg, fvo: 3"), "imager.fvo", "unknown key"),
        (("name: t", "name: t\nrender: {sppp: 3}"), "render.sppp", "allowed: spp"),
        (("name: t", "name: t\nrender: {spp: many}"), "render.spp", "integer"),
        (("fov: 10 deg, ", ""), "imager.fov", "required key missing"),
        (("m.obj", "nope.obj"), "scene[0].mesh", "file not found"),
        (("noise: 4 K", "noise: -4 K"), "imager.noise", ">= 0"),
        (("fov: 10 deg", "fov: 200 deg"), "imager.fov", "between 0 and 180"),
        (("fov: 10 deg", "fov: .nan"), "imager.fov", "finite"),
        (("95 GHz", "95 m"), "frequency", "not a frequency"),
        (("material: concrete", "material: concrete, materials: {a: b}"), "scene[0]", "exactly one"),
        (("name: t", "name: t\nsky: {texture: missing.exr}"), "sky.file", "file not found"),
        (("name: t", "name: t\noutput: {channels: [I, X]}"), "output.channels", "unknown channel"),
        (("look_at: [0, 0, 0]", "look_at: [0, -1000, 70]"), "imager", "look_at equals position"),
    ],
)
def test_each_bad_input_names_file_and_key(tmp_path, edit, key, words):
    path = write(tmp_path, BASE.replace(*edit))
    with pytest.raises(UserError) as e:
        load_scenario(path)
    text = error_text(e)
    assert f"s.yaml: {key}:" in text and words in text


def test_several_errors_are_all_reported(tmp_path):
    path = write(tmp_path, BASE.replace("noise: 4 K", "noise: -4 K").replace("fov: 10 deg", "fov: 200 deg"))
    with pytest.raises(UserErrors) as e:
        load_scenario(path)
    assert len(e.value.errors) == 2


def test_malformed_yaml_and_wrong_top_level(tmp_path):
    with pytest.raises(UserError, match=r"s\.yaml: malformed YAML: line 3, column 1"):
        load_scenario(write(tmp_path, "name: t\nimager: {a: [1, 2\n"))
    with pytest.raises(UserError, match="top level must be a mapping"):
        load_scenario(write(tmp_path, "- 1\n- 2\n"))
    with pytest.raises(UserError, match="not found"):
        load_scenario(tmp_path / "none.yaml")
