"""Scenario YAML -> typed Scenario: SI values, defaults, overrides, and one clear error per problem."""

import math
from pathlib import Path

import pytest
import yaml

from pmmw.config import apply_overrides, load_scenario, scenario_to_display
from pmmw.errors import UserError, UserErrors

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


FULL = """
name: landing
frequency: 95 GHz
imager:
  position: [0, -1 km, 70 m]
  look_at: [0, 0, 0]
  up: [0, 0, 1]
  fov: 10 deg
  resolution: [500, 400]
  aperture_diameter: 60 cm
  noise: 0.5 K
scene:
  - mesh: meshes/runway.glb
    materials: {runway: asphalt, ground: moist_soil}
  - mesh: m.obj
    material: metal
    transform: {translate: [10, 50 m, 0], rotate_deg: [0, 0, 90], scale: [1, 2, 3]}
    up_axis: y
    name: beacon
materials:
  asphalt: {eps: {35 GHz: [2.5, 0.6]}, temperature: 288 K}
atmosphere: {loss: 0.9 dB/km, temperature: 300 K}
sky: {model: uniform, temperature: 300 K, ground_temperature: 280 K}
render: {spp: 8, max_depth: 4, threshold: '1e-2', seed: 5, workers: auto, tile: 16, termination: temperature,
         default_temperature: 20 degC}
output: {dir: results, channels: [I, Q], previews: false, aux: [depth, stderr]}
"""


def test_full_scenario(tmp_path, monkeypatch):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "runway.glb").write_bytes(b"glTF")
    monkeypatch.chdir(tmp_path / "meshes")  # outputs resolve against the current directory
    s = load_scenario(write(tmp_path, FULL))
    assert s.name == "landing" and s.source_file == (tmp_path / "s.yaml").resolve()
    assert s.frequencies == (9.5e10,)
    im = s.imager
    assert im.position == (0.0, -1000.0, 70.0) and im.look_at == (0.0, 0.0, 0.0) and im.up == (0.0, 0.0, 1.0)
    assert math.isclose(im.fov, math.radians(10)) and im.resolution == (500, 400)
    assert math.isclose(im.aperture_diameter, 0.6) and im.noise == 0.5
    runway, beacon = s.scene
    assert runway.mesh == (tmp_path / "meshes" / "runway.glb").resolve() and runway.material is None
    assert runway.materials == {"runway": "asphalt", "ground": "moist_soil"} and runway.key == "scene[0]"
    assert runway.up_axis is None and runway.transform.scale == 1.0
    assert beacon.material == "metal" and beacon.up_axis == "y" and beacon.name == "beacon" and beacon.key == "scene[1]"
    assert beacon.transform.translate == (10.0, 50.0, 0.0) and beacon.transform.rotate_deg == (0.0, 0.0, 90.0)
    assert beacon.transform.scale == (1.0, 2.0, 3.0)
    # raw: the materials module validates these
    assert s.materials == {"asphalt": {"eps": {"35 GHz": [2.5, 0.6]}, "temperature": "288 K"}}
    assert math.isclose(s.atmosphere.loss, 0.9e-3 * math.log(10) / 10) and s.atmosphere.temperature == 300.0
    assert (s.sky.model, s.sky.temperature, s.sky.ground_temperature, s.sky.file) == ("uniform", 300.0, 280.0, None)
    r = s.render
    assert (r.spp, r.max_depth, r.threshold, r.seed, r.workers, r.tile) == (8, 4, 1e-2, 5, None, 16)
    assert r.termination == "temperature"
    assert math.isclose(r.default_temperature, 293.15)
    assert s.output.dir == (tmp_path / "meshes" / "results").resolve()
    assert (s.output.channels, s.output.previews, s.output.aux) == (("I", "Q"), False, ("depth", "stderr"))


def test_display_has_units_and_loads_back(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "runway.glb").write_bytes(b"glTF")
    s = load_scenario(write(tmp_path, FULL))
    d = scenario_to_display(s)
    assert d["frequency"] == "95 GHz" and d["imager"]["fov"] == "10 deg" and d["imager"]["aperture_diameter"] == "0.6 m"
    assert d["imager"]["position"] == ["0 m", "-1000 m", "70 m"] and d["sky"]["temperature"] == "300 K"
    assert d["atmosphere"]["loss"] == "0.9 dB/km" and d["scene"][0]["mesh"] == str(s.scene[0].mesh)
    text = yaml.safe_dump(d, sort_keys=False)
    again = yaml.safe_load(text)
    again.pop("source_file")
    (tmp_path / "again.yaml").write_text(yaml.safe_dump(again))
    again_path = tmp_path / "again.yaml"
    assert scenario_to_display(load_scenario(again_path)) == {**d, "source_file": str(again_path)}


def test_defaults(tmp_path):
    s = load_scenario(write(tmp_path))
    # default: the ITU-R standard atmosphere along paths and its own sky
    assert s.atmosphere.model == "layered" and s.atmosphere.profile == "standard" and not s.atmosphere.layers
    assert s.sky.model == "atmosphere" and s.sky.ground_temperature == 290.0
    assert (s.render.spp, s.render.max_depth, s.render.threshold, s.render.seed) == (16, 32, 1e-3, 1)
    assert s.render.workers is None and s.render.termination == "roulette"
    assert s.output.channels == ("I", "Q", "U", "V", "Ex2", "Ey2") and s.output.aux == ()
    assert s.scene[0].transform.scale == 1.0 and s.scene[0].up_axis is None and s.materials == {}
    assert s.sky.temperature is None and s.sky.zenith_opacity is None and s.render.tile == 64
    assert s.render.default_temperature == 290.0 and s.output.dir is None and s.output.previews is True
    assert s.imager.up == (0.0, 0.0, 1.0)
    assert load_scenario(write(tmp_path, BASE.replace("name: t\n", ""), name="stem.yaml")).name == "stem"


@pytest.mark.parametrize("text", ["atmosphere: none", "atmosphere: null", "atmosphere: None"])
def test_atmosphere_none_is_vacuum(tmp_path, text):
    assert load_scenario(write(tmp_path, BASE + text + "\n")).atmosphere is None


def test_atmosphere_defaults(tmp_path):
    atm = load_scenario(write(tmp_path, BASE + "atmosphere: {}\n")).atmosphere
    assert atm.model == "layered" and atm.profile == "standard" and atm.loss is None
    atm = load_scenario(write(tmp_path, BASE + "atmosphere: {loss: 0.2 dB/km}\n")).atmosphere
    assert atm.model == "uniform" and atm.temperature == 288.0


def test_layered_atmosphere_with_weather(tmp_path):
    text = (
        BASE
        + """atmosphere:
  profile: mid_latitude_winter
  ground_temperature: 280 K
  humidity: 5 g/m3
  layers:
    - {kind: fog, base: 0 m, top: 600 m, liquid_water: 0.3 g/m3}
    - {kind: rain, base: 0 m, top: 2 km, rain_rate: 10 mm/h}
sky: {model: atmosphere}
"""
    )
    s = load_scenario(write(tmp_path, text))
    a = s.atmosphere
    assert a.profile == "mid_latitude_winter" and a.ground_temperature == 280.0
    assert math.isclose(a.humidity, 5e-3) and math.isclose(a.layers[0].liquid_water, 3e-4)
    assert math.isclose(a.layers[1].rain_rate, 10.0) and a.layers[1].top == 2000.0
    for bad, key, words in (("liquid_water: 0.3 g/m3}", "atmosphere.layers[0]", "top must be above base"),):
        path = write(tmp_path, text.replace("top: 600 m, " + bad, "top: 0 m, " + bad))
        with pytest.raises(UserError, match=words) as e:
            load_scenario(path)
        assert key in str(e.value)
    with pytest.raises(UserError, match="needs a layered atmosphere"):
        load_scenario(write(tmp_path, BASE + "atmosphere: none\nsky: {model: atmosphere}\n"))
    with pytest.raises(UserError, match="takes rain_rate"):
        load_scenario(
            write(tmp_path, BASE + "atmosphere: {layers: [{kind: rain, base: 0, top: 9, liquid_water: 1 g/m3}]}\n")
        )


def test_sky_forms(tmp_path):
    (tmp_path / "sky.exr").write_bytes(b"x")
    sky = load_scenario(write(tmp_path, BASE + "sky: {texture: sky.exr}\n")).sky
    assert sky.model == "texture" and sky.file == (tmp_path / "sky.exr").resolve()
    sky = load_scenario(write(tmp_path, BASE + "sky: {model: texture, file: sky.exr}\n")).sky
    assert sky.file == (tmp_path / "sky.exr").resolve()
    sky = load_scenario(write(tmp_path, BASE + "sky: {model: slab, zenith_opacity: 0.05, temperature: 270 K}\n")).sky
    assert (sky.model, sky.zenith_opacity, sky.temperature) == ("slab", 0.05, 270.0)


def test_frequency_list_and_imager_alias(tmp_path):
    s = load_scenario(write(tmp_path, BASE.replace("frequency: 95 GHz", "frequency: [35 GHz, 95 GHz]")))
    assert s.frequencies == (35e9, 95e9)
    s = load_scenario(write(tmp_path), ["imager.frequency=35 GHz"])
    assert s.frequencies == (35e9,)  # imager.frequency takes precedence
    s = load_scenario(write(tmp_path, BASE.replace("fov: 10 deg", "fov: 10 deg, frequency: [35 GHz, 140 GHz]")))
    assert s.frequencies == (35e9, 140e9) and s.imager.frequency is None
    only_imager = BASE.replace("frequency: 95 GHz\n", "").replace("fov: 10 deg", "fov: 10 deg, frequency: 35 GHz")
    s = load_scenario(write(tmp_path, only_imager))
    assert s.frequencies == (35e9,)
    s = load_scenario(write(tmp_path), ['frequency="35 GHz"'])  # quoted as a shell user may pass it
    assert s.frequencies == (35e9,)


def test_overrides(tmp_path):
    raw = {"render": {"spp": 4}, "scene": [{"material": "a"}, {"material": "b"}]}
    out = apply_overrides(
        raw,
        [
            "render.spp=64",
            "scene[1].material=metal",
            "scene.0.material=x",
            "sky.model=uniform",
            "imager.resolution=[100, 80]",
            "name=a b",
        ],
    )
    assert out["render"]["spp"] == 64 and out["scene"][1]["material"] == "metal"
    assert out["scene"][0]["material"] == "x" and out["sky"] == {"model": "uniform"}
    assert out["imager"]["resolution"] == [100, 80] and out["name"] == "a b"
    assert raw["render"]["spp"] == 4  # the input is not modified
    with pytest.raises(UserError, match="KEY.PATH=VALUE"):
        apply_overrides(raw, ["render.spp"])
    with pytest.raises(UserError, match="past the end"):
        apply_overrides(raw, ["scene[5].material=x"])


def test_override_values_and_errors():
    raw = {"sky": None, "materials": {"7": {"temperature": "1 K"}}, "scene": [{"transform": {"scale": 1}}]}
    out = apply_overrides(
        raw,
        [
            "sky.temperature=290 K",
            "render.threshold=1e-3",
            "render.previews=true",
            "name=[not yaml",
            "scene[0].transform.scale=[1, 2, 3]",
            "materials.7.temperature=2 K",
            "output.dir=",
        ],
    )
    assert out["sky"] == {"temperature": "290 K"}  # a null mapping is replaced, as a missing one is created
    # YAML 1.1 reads 1e-3 (no dot) as a string; the schema accepts numeric strings
    assert out["render"] == {"threshold": "1e-3", "previews": True}
    assert out["name"] == "[not yaml" and out["scene"][0]["transform"]["scale"] == [1, 2, 3]
    assert out["materials"]["7"]["temperature"] == "2 K" and out["output"]["dir"] == ""
    for item, key in [
        ("render.spp", "render.spp"),
        ("scene[3].material=x", "scene[3].material"),
        ("scene.a=x", "scene.a"),
        ("render..spp=1", "render..spp"),
        ("scene[0].transform.scale.x=1", "scene[0].transform.scale.x"),
    ]:
        with pytest.raises(UserError) as e:
            apply_overrides({"scene": [{"transform": {"scale": 1}}]}, [item])
        assert e.value.file == "--set" and e.value.key == key and str(e.value).startswith(f"--set: {key}: ")


def test_cli_values_apply_after_overrides(tmp_path):
    s = load_scenario(write(tmp_path), ["render.spp=3"], cli={"spp": 7, "seed": 9, "workers": 2, "out": tmp_path / "o"})
    assert (s.render.spp, s.render.seed, s.render.workers) == (7, 9, 2)
    assert s.output.dir == (tmp_path / "o").resolve()
    s = load_scenario(write(tmp_path), ["render.threshold=1e-2", "render.workers=auto"], cli={"spp": None})
    assert (s.render.threshold, s.render.workers, s.render.spp) == (1e-2, None, 16)  # None flags leave the file's value


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
        (("name: t", "name: t\nsky: {texture: missing.exr}"), "sky.texture", "file not found"),
        (("name: t", "name: t\nsky: {model: texture, file: missing.exr}"), "sky.file", "file not found"),
        (("name: t", "name: t\nsky: {model: texture}"), "sky", "needs 'texture"),
        (("name: t", "name: t\nsky: {model: uniform}"), "sky", "needs 'temperature'"),
        (("name: t", "name: t\nsky: {model: cloudy}"), "sky.model", "'slab', 'uniform' or 'texture'"),
        (("name: t", "name: t\nweather: rain"), "weather", "allowed: name, frequency, imager"),
        (("name: t", "name: t\nsource_file: x.yaml"), "source_file", "unknown key"),
        (("name: t", "name: ../t"), "name", "plain file name"),
        (("name: t", "name: t\nrender: {seed: -1}"), "render.seed", "greater than or equal to 0"),
        (("name: t", "name: t\nrender: {spp: true}"), "render.spp", "integer"),
        (("name: t", "name: t\nrender: {spp: 0}"), "render.spp", "greater than or equal to 1"),
        (("name: t", "name: t\nrender: {max_depth: 65}"), "render.max_depth", "less than or equal to 64"),
        (("name: t", "name: t\nrender: {threshold: 1}"), "render.threshold", "[0, 1)"),
        (("name: t", "name: t\nrender: {tile: 4}"), "render.tile", "greater than or equal to 8"),
        (("name: t", "name: t\nrender: {workers: 0}"), "render.workers", "greater than or equal to 1"),
        (("name: t", "name: t\nrender: {termination: never}"), "render.termination", "'roulette' or 'temperature'"),
        (("name: t", "name: t\nrender: {atmosphere_tolerance: -1 K}"), "render.atmosphere_tolerance", ">= 0 K"),
        (("name: t", "name: t\noutput: {dir: 5}"), "output.dir", "folder path"),
        (("name: t", "name: t\noutput: {channels: [I, I]}"), "output.channels", "twice"),
        (("name: t", "name: t\noutput: {aux: [normals]}"), "output.aux", "unknown auxiliary channel"),
        (
            ("name: t", "name: t\natmosphere: {loss: 0.9 dB/s}"),
            "atmosphere.loss",
            "not an attenuation; expected e.g. '0.9 dB/km'",
        ),
        (("name: t", "name: t\natmosphere: {temprature: 3 K}"), "atmosphere.temprature", "allowed: model, profile"),
        (("name: t", "name: t\nmaterials: [asphalt]"), "materials", "mapping"),
        (("name: t", "name: t\nfrequencies: 95 GHz"), "frequencies", "did you mean 'frequency'"),
        (("frequency: 95 GHz\n", ""), "frequency", "required key missing"),
        (("95 GHz", "[35 GHz, -95 GHz]"), "frequency", "outside the 1-1000 GHz"),
        (("95 GHz", "95"), "frequency", "give a unit"),
        (("fov: 10 deg", "fov: 10 deg, frequency: 95 m"), "imager.frequency", "not a frequency"),
        (("resolution: [50, 40]", "resolution: [50, 0]"), "imager.resolution", "integers >= 1"),
        (("position: [0, -1000, 70]", "position: [0, -1000]"), "imager.position", "3 numbers"),
        (("position: [0, -1000, 70]", "position: [0, -1000, 70 K]"), "imager.position", "not a length"),
        (("look_at: [0, 0, 0]", "look_at: [0, 0, 0], up: [0, 1000, -70]"), "imager", "parallel"),
        (("aperture_diameter: 0.6 m", "aperture_diameter: -1 m"), "imager.aperture_diameter", ">= 0"),
        (("m.obj, material: concrete", "m.obj"), "scene[0]", "exactly one"),
        (("m.obj", "s.yaml"), "scene[0].mesh", "unsupported mesh format"),
        (("material: concrete", "material: concrete, transform: {scale: -1}"), "scene[0].transform.scale", "> 0"),
        (
            ("material: concrete", "material: concrete, transform: {rotate: [0, 0, 1]}"),
            "scene[0].transform.rotate",
            "allowed: translate, rotate_deg, scale",
        ),
        (("material: concrete", "material: concrete, up_axis: x"), "scene[0].up_axis", "'y' or 'z'"),
        (("material: concrete", "material: concrete, key: mine"), "scene[0].key", "unknown key"),
        (("material: concrete", "materials: {a: [b]}"), "scene[0].materials.a", "string"),
        (("  - {mesh: m.obj, material: concrete}", "  - m.obj"), "scene[0]", "dictionary"),
        (("scene:\n  - {mesh: m.obj, material: concrete}", "scene: []"), "scene", "at least one entry"),
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
    assert not isinstance(e.value, UserErrors)  # exactly one error, no echo from an enclosing list


def test_error_in_second_scene_entry(tmp_path):
    path = write(tmp_path, BASE + "  - {mesh: m.obj, material: a, transform: {translate: [0, 0]}}\n")
    with pytest.raises(UserError) as e:
        load_scenario(path)
    assert not isinstance(e.value, UserErrors) and e.value.key == "scene[1].transform.translate"


def test_several_errors_are_all_reported(tmp_path):
    path = write(tmp_path, BASE.replace("noise: 4 K", "noise: -4 K").replace("fov: 10 deg", "fov: 200 deg"))
    with pytest.raises(UserErrors) as e:
        load_scenario(path)
    assert len(e.value.errors) == 2
    assert [err.key for err in e.value.errors] == ["imager.fov", "imager.noise"]

    path = write(tmp_path, BASE.replace("m.obj", "gone.obj") + "render: {sppp: 1, spp: many}\nsky: {model: x}\n")
    with pytest.raises(UserErrors) as e:
        load_scenario(path)
    assert {err.key for err in e.value.errors} == {"scene[0].mesh", "render.sppp", "render.spp", "sky.model"}
    assert all(err.file == str(path.resolve()) for err in e.value.errors)


def test_malformed_yaml_and_wrong_top_level(tmp_path):
    with pytest.raises(UserError, match=r"s\.yaml: malformed YAML: line 3, column 1"):
        load_scenario(write(tmp_path, "name: t\nimager: {a: [1, 2\n"))
    with pytest.raises(UserError, match="top level must be a mapping"):
        load_scenario(write(tmp_path, "- 1\n- 2\n"))
    with pytest.raises(UserError, match="not found"):
        load_scenario(tmp_path / "none.yaml")
    with pytest.raises(UserError, match="not a file"):
        load_scenario(tmp_path)
    with pytest.raises(UserError, match=r"s\.yaml: malformed YAML: line 2"):
        load_scenario(write(tmp_path, "name: t\n  bad: indent\n"))
