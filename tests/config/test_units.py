"""Every quantity key takes every unit of its dimension and loads as pint converts it.

The table below covers every field of the scenario schema that parses a quantity; the list of
those fields is derived from the schema (fields marked ``Quantity(kind)``) and from the material
entry models (validators that call `parse_quantity`), so a new quantity key without a row fails
`test_table_covers_every_quantity_field`.

Reference values come from a separate ``pint.UnitRegistry()`` converting the same string. The
tolerance, `UNIT_RTOL`, is a few ulp: both sides are the same unit arithmetic (one multiplication
by a conversion factor, plus an offset for degC/degF), possibly with the factor composed in
another order, so anything beyond rounding is a bug (e.g. 0.5 rad read as 0.5 deg is off by 57x).
"""

import math
import re
from dataclasses import dataclass
from pathlib import Path

import pint
import pytest
from pydantic import BaseModel
from typer.testing import CliRunner

from pmmw import units as units_mod
from pmmw.config import load_scenario
from pmmw.config.schema import Quantity, ScenarioConfig
from pmmw.errors import UserError
from pmmw.scene import bump as bump_mod
from pmmw.scene import materials as mat_mod
from pmmw.scene.materials import MaterialDB
from pmmw.sky_table import parse_layer
from pmmw.units import parse_quantity
from pmmw_cli.cli import app

UNIT_RTOL = 1e-12  # pure unit arithmetic: rounding only (module docstring)
REF = pint.UnitRegistry()  # independent of pmmw's registry
LN10_10 = math.log(10.0) / 10.0  # [Np of power per dB]
ROOT = Path(__file__).resolve().parents[2]

BASE = """
name: t
frequency: 95 GHz
imager: {position: [0, -1000, 70], look_at: [0, 0, 0], up: [0, 0, 1], fov: 10 deg, resolution: [8, 6],
         aperture_diameter: 0.6 m, noise: 1 K}
scene:
  - {mesh: m.obj, material: concrete}
atmosphere:
  profile: standard
  layers:
    - {kind: fog, base: 0 m, top: 600 m, liquid_water: 0.3 g/m3}
    - {kind: rain, base: 0 m, top: 3 km, rain_rate: 10 mm/h}
output: {regions: {r: {center: [0, 0, 0]}}}
"""
RECEIVER = BASE.replace(
    "noise: 1 K}",
    "receiver: {noise_temperature: 600 K, bandwidth: 2 GHz, integration_time: 1 ms, "
    "mode: dicke, reference_temperature: 300 K},\n         antenna: {spillover: 0.05}}",
)
SCANNED = BASE.replace("noise: 1 K}", "receiver: {noise_figure: 5 dB, bandwidth: 2 GHz, frame_rate: 10 Hz}}")
UNIFORM = (
    BASE.split("atmosphere:")[0]
    + "atmosphere: {loss: 0.9 dB/km, temperature: 288 K}\n"
    + "output:"
    + BASE.split("output:")[1]
)


def write(tmp_path: Path, text: str) -> Path:
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    p = tmp_path / "s.yaml"
    p.write_text(text)
    return p


# ------------------------------------------------------------------------------------------------
# Cases per dimension: a value as the user writes it, or (value, the same for plain pint) where
# pmmw accepts a shorthand pint does not (g/m3). Bare numbers take the kind's documented unit.
# ------------------------------------------------------------------------------------------------

LENGTHS = ["1.5 km", "250 mm", "3 ft", "2 in", "0.1 mi", "0.01 nmi", "40 cm", "5e5 um", "2 yd", 7]
ANGLES = ["0.5 rad", "600 mrad", "10 deg", "600 arcmin", "3600 arcsec", "0.1 turn", "50 grad", "20 gon", "2 mil", 10]
TEMPERATURES = ["300 K", "20 degC", "20 °C", "68 degF", "527 degR", "-5 degC", "290000 mK", "20 celsius", 288]
DIFFERENCES = ["2 K", "1 delta_degC", "1.8 delta_degF", "500 mK", 3]
FREQUENCIES = ["95 GHz", "0.095 THz", "95000 MHz", "9.5e10 Hz", "3.5e7 kHz"]
BANDWIDTHS = ["1 GHz", "500 MHz", "0.002 THz", "2e9 Hz", 0]
DENSITIES = [
    ("7.5 g/m3", "7.5 g/m**3"),
    ("0.3 g/m^3", "0.3 g/m**3"),
    "0.0075 kg/m**3",
    "7.5 mg/L",
    "3e-4 kg/m**3",
    "0.5 g/L",
    0.3,
]
RATES = ["10 mm/h", "10 mm/hr", "0.5 in/h", "1e-6 m/s", "25 mm/hour", "2.4 cm/day", 10]
TIMES = ["1 ms", "20 us", "0.5 s", "2e-3 s", "1 minute", 0.01]
ATTENUATIONS = ["0.9 dB/km", "0.0009 dB/m", "0.2 Np/km", "2e-4 Np/m", "1 dB/mi", "0.9 dB/kilometer", 0.9]

BARE = {
    "time": "s",
    "length": "m",
    "angle": "deg",
    "temperature": "K",
    "temperature_difference": "K",
    "density": "g/m**3",
    "rate": "mm/h",
}
SI = {
    "time": "s",
    "frequency": "Hz",
    "length": "m",
    "angle": "rad",
    "temperature": "K",
    "temperature_difference": "K",
    "density": "kg/m**3",
    "rate": "m/s",
}


def expected(case, kind: str, unit: str | None = None) -> float:
    """What pint makes of ``case`` in ``unit`` (default: the kind's SI unit)."""
    value, text = case if isinstance(case, tuple) else (case, case)
    if kind == "attenuation":  # pint's dB/Np are logarithmic; power level per length, 1 dB = ln10/10 Np
        number, per = (float(value), "dB/km") if not isinstance(value, str) else value.split(" ", 1)
        level, length = per.split("/")
        return float(number) * (LN10_10 if level == "dB" else 1.0) / REF.Quantity(1.0, length).to("m").magnitude
    if not isinstance(text, str):
        return 0.0 if value == 0 else REF.Quantity(float(value), BARE[kind]).to(unit or SI[kind]).magnitude
    number, units = text.split(" ", 1)  # as pint's docs build offset quantities: Quantity(20, "degC")
    return REF.Quantity(float(number), units).to(unit or SI[kind]).magnitude


def same(got: float, want: float) -> bool:
    return got == want if want == 0 else math.isclose(got, want, rel_tol=UNIT_RTOL, abs_tol=0.0)


# ------------------------------------------------------------------------------------------------
# The table: schema field path -> how to set it (a --set key on a base scenario) and read it back
# ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Row:
    kind: str
    set_key: str  # `--set` key path
    get: object  # Scenario -> float
    cases: list
    base: str = BASE
    unit: str | None = None  # stored unit when not SI (Quantity(unit=...))
    wrong: str = "3 kg"  # a value of another dimension


TABLE = {
    "frequencies": Row("frequency", "frequency", lambda s: s.frequencies[0], FREQUENCIES),
    "imager.position": Row("length", "imager.position[0]", lambda s: s.imager.position[0], LENGTHS),
    "imager.look_at": Row("length", "imager.look_at[0]", lambda s: s.imager.look_at[0], LENGTHS),
    "imager.up": Row("length", "imager.up[0]", lambda s: s.imager.up[0], LENGTHS),
    "imager.fov": Row("angle", "imager.fov", lambda s: s.imager.fov, ANGLES, wrong="3 m"),
    "imager.aperture_diameter": Row(
        "length", "imager.aperture_diameter", lambda s: s.imager.aperture_diameter, LENGTHS
    ),
    "imager.noise": Row("temperature_difference", "imager.noise", lambda s: s.imager.noise, DIFFERENCES),
    "imager.focus_distance": Row("length", "imager.focus_distance", lambda s: s.imager.focus_distance, LENGTHS),
    "imager.bandwidth": Row("frequency", "imager.bandwidth", lambda s: s.imager.bandwidth, BANDWIDTHS),
    "imager.receiver.noise_temperature": Row(
        "temperature",
        "imager.receiver.noise_temperature",
        lambda s: s.imager.receiver.noise_temperature,
        TEMPERATURES,
        RECEIVER,
    ),
    "imager.receiver.bandwidth": Row(
        "frequency", "imager.receiver.bandwidth", lambda s: s.imager.receiver.bandwidth, FREQUENCIES, RECEIVER
    ),
    "imager.receiver.integration_time": Row(
        "time", "imager.receiver.integration_time", lambda s: s.imager.receiver.integration_time, TIMES, RECEIVER
    ),
    "imager.receiver.frame_rate": Row(
        "frequency",
        "imager.receiver.frame_rate",
        lambda s: s.imager.receiver.frame_rate,
        ["30 Hz", "0.03 kHz", "1e-5 GHz"],
        SCANNED,
    ),
    "imager.receiver.reference_temperature": Row(
        "temperature",
        "imager.receiver.reference_temperature",
        lambda s: s.imager.receiver.reference_temperature,
        TEMPERATURES,
        RECEIVER,
    ),
    "imager.antenna.spillover_temperature": Row(
        "temperature",
        "imager.antenna.spillover_temperature",
        lambda s: s.imager.antenna.spillover_temperature,
        TEMPERATURES,
        RECEIVER,
    ),
    "scene[].transform.translate": Row(
        "length", "scene[0].transform.translate", lambda s: s.scene[0].transform.translate[2], LENGTHS
    ),
    "scene[].transform.rotate_deg": Row(
        "angle",
        "scene[0].transform.rotate_deg",
        lambda s: s.scene[0].transform.rotate_deg[2],
        ANGLES + ["-0.25 turn"],
        unit="deg",
    ),
    "atmosphere.ground_temperature": Row(
        "temperature", "atmosphere.ground_temperature", lambda s: s.atmosphere.ground_temperature, TEMPERATURES
    ),
    "atmosphere.humidity": Row("density", "atmosphere.humidity", lambda s: s.atmosphere.humidity, DENSITIES),
    "atmosphere.ground_altitude": Row(
        "length", "atmosphere.ground_altitude", lambda s: s.atmosphere.ground_altitude, LENGTHS
    ),
    "atmosphere.loss": Row(
        "attenuation", "atmosphere.loss", lambda s: s.atmosphere.loss, ATTENUATIONS, base=UNIFORM, wrong="0.9 dB/s"
    ),
    "atmosphere.temperature": Row(
        "temperature", "atmosphere.temperature", lambda s: s.atmosphere.temperature, TEMPERATURES, base=UNIFORM
    ),
    "atmosphere.layers[].base": Row(
        "length",
        "atmosphere.layers[0].base",
        lambda s: s.atmosphere.layers[0].base,
        [c for c in LENGTHS if c != "1.5 km"],
    ),  # below the fog's top (600 m)
    "atmosphere.layers[].top": Row("length", "atmosphere.layers[0].top", lambda s: s.atmosphere.layers[0].top, LENGTHS),
    "atmosphere.layers[].liquid_water": Row(
        "density", "atmosphere.layers[0].liquid_water", lambda s: s.atmosphere.layers[0].liquid_water, DENSITIES
    ),
    "atmosphere.layers[].rain_rate": Row(
        "rate", "atmosphere.layers[1].rain_rate", lambda s: s.atmosphere.layers[1].rain_rate, RATES, unit="mm/h"
    ),
    "sky.temperature": Row("temperature", "sky.temperature", lambda s: s.sky.temperature, TEMPERATURES),
    "sky.ground_temperature": Row(
        "temperature", "sky.ground_temperature", lambda s: s.sky.ground_temperature, TEMPERATURES
    ),
    "render.target_error": Row(
        "temperature_difference", "render.target_error", lambda s: s.render.target_error, DIFFERENCES
    ),
    "render.default_temperature": Row(
        "temperature", "render.default_temperature", lambda s: s.render.default_temperature, TEMPERATURES
    ),
    "render.atmosphere_tolerance": Row(
        "temperature_difference", "render.atmosphere_tolerance", lambda s: s.render.atmosphere_tolerance, DIFFERENCES
    ),
    "output.regions{}.center": Row(
        "length", "output.regions.r.center", lambda s: s.output.regions["r"].center[1], LENGTHS
    ),
}


def _models(tp):
    """Pydantic models inside a type, with the path suffix of their items: [] list, {} mapping."""
    import typing

    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return [(tp, "")]
    if origin is dict:
        return [(m, "{}" + s) for m, s in _models(args[1])]
    if origin in (tuple, list) and args and (len(args) == 1 or args[-1] is Ellipsis):
        return [(m, "[]" + s) for m, s in _models(args[0])]
    return [ms for a in args for ms in _models(a)]


def schema_quantity_fields(model=ScenarioConfig, prefix="") -> dict[str, Quantity]:
    """Dotted path -> `Quantity` marker of every quantity field reachable from `model`."""
    out = {}
    for name, info in model.model_fields.items():
        path = f"{prefix}.{name}" if prefix else name
        out.update({path: m for m in info.metadata if isinstance(m, Quantity)})
        for sub, suffix in _models(info.annotation):
            out.update(schema_quantity_fields(sub, path + suffix))
    return out


def test_table_covers_every_quantity_field():
    fields = schema_quantity_fields()
    assert set(fields) == set(TABLE), "a quantity field of the schema has no row in TABLE (or a row is stale)"
    for path, marker in fields.items():
        row = TABLE[path]
        assert (marker.kind, marker.unit) == (row.kind, row.unit), path


def _vector(set_key: str) -> bool:
    return set_key.endswith(("translate", "rotate_deg", "center"))


def _override(row: Row, value) -> str:
    text = value if isinstance(value, str) else repr(value)
    if _vector(row.set_key):  # the whole vector, checking its last component(s)
        return f"{row.set_key}=['{text}', '{text}', '{text}']"
    return f"{row.set_key}={text}"


CASES = [(path, case) for path, row in TABLE.items() for case in row.cases]


@pytest.mark.parametrize("path, case", CASES, ids=[f"{p}={c[0] if isinstance(c, tuple) else c}" for p, c in CASES])
def test_every_quantity_key_takes_every_unit(tmp_path, path, case):
    row = TABLE[path]
    value = case[0] if isinstance(case, tuple) else case
    s = load_scenario(write(tmp_path, row.base), [_override(row, value)])
    got = row.get(s)
    want = expected(case, row.kind, row.unit)
    assert same(got, want), f"{path} = {value!r}: loaded {got!r}, pint {want!r}"


@pytest.mark.parametrize("path", list(TABLE))
def test_a_wrong_dimension_names_the_key(tmp_path, path):
    row = TABLE[path]
    with pytest.raises(UserError) as e:
        load_scenario(write(tmp_path, row.base), [_override(row, row.wrong)])
    assert e.value.key is not None and e.value.key.startswith(_user_key(row)), (e.value.key, str(e.value))
    assert f"{row.wrong!r} is not a" in str(e.value) and "expected e.g." in str(e.value), str(e.value)
    assert str(e.value).startswith(str((tmp_path / "s.yaml").resolve()))


def _user_key(row: Row) -> str:
    """The key a user wrote, as the error names it (a vector's key without the component)."""
    key = row.set_key
    if key.endswith("]") and key.rsplit("[", 1)[1][:-1].isdigit():
        key = key.rsplit("[", 1)[0]
    return key


# ------------------------------------------------------------------------------------------------
# Refused: dimensionless units that are not angles, offsets where a difference is meant, ...
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "key, value, words",
    [
        ("imager.fov", "0.5 percent", "is not an angle"),
        ("imager.fov", "3 dimensionless", "is not an angle"),
        ("imager.fov", "1 sr", "is not an angle"),
        ("imager.fov", "10 ppm", "is not an angle"),
        ("imager.fov", "3 m", "'3 m' is not an angle; expected e.g. '10 deg'"),
        ("imager.fov", "10 degreez", "unknown unit"),
        ("imager.noise", "2 degC", "offset scale"),
        ("render.target_error", "1 degF", "offset scale"),
        ("render.default_temperature", "1 delta_degC", "temperature difference"),
        ("sky.ground_temperature", "2 m", "is not a temperature"),
        ("frequency", "95", "give a unit"),
        ("frequency", "1 rad/s", "angular frequency"),
        ("frequency", "95 GHz m", "is not a frequency"),
        ("atmosphere.layers[1].rain_rate", "10 mm", "is not a rain rate"),
        ("atmosphere.humidity", "7.5 g", "is not a mass density"),
    ],
)
def test_refused_with_the_key(tmp_path, key, value, words):
    with pytest.raises(UserError) as e:
        load_scenario(write(tmp_path, BASE), [f"{key}={value}"])
    assert e.value.key == key and words in e.value.message, str(e.value)


@pytest.mark.parametrize(
    "value, words",
    [
        ("0.9 /km", "dB or Np"),
        ("0.9 dB", "is not an attenuation"),
        ("-1 dB/km", ">= 0"),
        ("0.9 dB/K", "is not an attenuation"),
    ],
)
def test_attenuation_refused(tmp_path, value, words):
    with pytest.raises(UserError) as e:
        load_scenario(write(tmp_path, UNIFORM), [f"atmosphere.loss={value}"])
    assert e.value.key == "atmosphere.loss" and words in e.value.message, str(e.value)


def test_decibel_and_neper_are_power_levels():
    """1 dB = ln(10)/10 Np of power, exactly as the old hand-rolled parser had it."""
    assert parse_quantity("1 dB/m", "attenuation") == math.log(10.0) / 10.0
    assert parse_quantity("1 Np/m", "attenuation") == 1.0
    assert same(parse_quantity("10 dB/km", "attenuation"), parse_quantity(f"{10 * LN10_10!r} Np/km", "attenuation"))


def test_bare_numbers_keep_their_documented_unit():
    assert parse_quantity(10, "angle") == parse_quantity("10 deg", "angle")
    assert parse_quantity("10", "angle") == parse_quantity("10 deg", "angle")
    assert parse_quantity(0.5, "angle") != 0.5  # a bare 0.5 is degrees, "0.5 rad" is radians
    assert parse_quantity("0.5 rad", "angle") == 0.5
    assert parse_quantity(5, "length") == 5.0 and parse_quantity(300, "temperature") == 300.0
    assert parse_quantity(2, "temperature_difference") == 2.0
    assert parse_quantity(0.3, "density") == parse_quantity("0.3 g/m3", "density")
    assert parse_quantity(10, "rate") == parse_quantity("10 mm/h", "rate")
    assert parse_quantity(0.9, "attenuation") == parse_quantity("0.9 dB/km", "attenuation")
    assert parse_quantity(0, "frequency") == 0.0  # zero needs no unit; other bare frequencies do
    assert parse_quantity(7, "angle", unit="deg") == 7.0  # exact: no round trip through radians


DISPLAY_RTOL = 1e-11  # scenario_to_display writes 12 significant digits


@pytest.mark.parametrize(
    "base, overrides",
    [
        (
            BASE,
            [
                "imager.fov=0.5 rad",
                "imager.noise=1 delta_degC",
                "imager.position[2]=200 ft",
                "imager.focus_distance=1 mi",
                "imager.bandwidth=0.002 THz",
                "atmosphere.humidity=7.5 mg/L",
                "atmosphere.ground_temperature=20 degC",
                "atmosphere.layers[1].rain_rate=0.5 in/h",
                "atmosphere.layers[0].top=2000 ft",
                "render.target_error=900 mK",
                "render.atmosphere_tolerance=0.018 delta_degF",
                "render.default_temperature=68 degF",
                "sky.ground_temperature=-5 degC",
                "scene[0].transform.rotate_deg=[0, 0, 0.25 turn]",
                "output.regions.r.center=[1 km, 2 ft, 3 in]",
            ],
        ),
        (UNIFORM, ["atmosphere.loss=0.2 Np/km", "atmosphere.temperature=15 degC", "frequency=[0.035 THz, 95 GHz]"]),
    ],
)
def test_display_round_trips_any_units(tmp_path, base, overrides):
    """`scenario_to_display` writes SI values back as unit strings that load to the same values."""
    import yaml

    from pmmw.config import scenario_to_display

    s = load_scenario(write(tmp_path, base), overrides)
    shown = scenario_to_display(s)
    shown.pop("source_file")
    (tmp_path / "again.yaml").write_text(yaml.safe_dump(shown))
    again = load_scenario(tmp_path / "again.yaml")
    checked = 0
    for path, row in TABLE.items():
        try:
            a, b = row.get(s), row.get(again)
        except (IndexError, AttributeError):
            continue  # no such layer, or no receiver block, in this scenario
        if a is not None or b is not None:
            assert math.isclose(a, b, rel_tol=DISPLAY_RTOL), (path, a, b)
            checked += 1
    assert checked >= 16
    again_shown = scenario_to_display(again)
    again_shown.pop("source_file")
    assert again_shown == shown


# ------------------------------------------------------------------------------------------------
# Material database entries and bump maps
# ------------------------------------------------------------------------------------------------


def _material_quantity_fields() -> set[str]:
    """Fields of the material entry models whose validator parses a quantity."""
    out = set()
    for model, prefix in ((mat_mod._EntryIn, ""), (mat_mod._LayerIn, "coating[].")):
        for name, info in model.model_fields.items():
            funcs = [getattr(m, "func", None) for m in info.metadata]
            if any(f is not None and "parse_quantity" in f.__code__.co_names for f in funcs):
                out.add(prefix + name)
    return out


MATERIAL_CASES = {
    # field -> (kind, entry maker, getter)
    "temperature": ("temperature", lambda v: {"eps": [3.0, 0.1], "temperature": v}, lambda m: m.temperature),
    "thickness": ("length", lambda v: {"kind": "thin", "eps": [3.0, 0.1], "thickness": v}, lambda m: m.thickness),
    "eps": ("frequency", lambda v: {"eps": {v: [3.0, 0.1]}}, lambda m: m.freqs[0]),
    "coating[].thickness": (
        "length",
        lambda v: {"eps": [3.0, 0.1], "coating": [{"material": "concrete", "thickness": v}]},
        lambda m: m.coating[0].thickness,
    ),
    "coating[].temperature": (
        "temperature",
        lambda v: {"eps": [3.0, 0.1], "coating": [{"material": "concrete", "thickness": "1 mm", "temperature": v}]},
        lambda m: m.coating[0].temperature,
    ),
}
UNITS_OF = {"temperature": TEMPERATURES, "length": LENGTHS, "frequency": FREQUENCIES}


def test_material_table_covers_every_quantity_field():
    assert _material_quantity_fields() == set(MATERIAL_CASES)


@pytest.fixture(scope="module")
def db():
    return MaterialDB.load()


@pytest.mark.parametrize("field, case", [(f, c) for f, (k, _, _) in MATERIAL_CASES.items() for c in UNITS_OF[k]])
def test_material_quantities(db, field, case):
    kind, make, get = MATERIAL_CASES[field]
    mat = db.with_overrides({"mine": make(case)}, file="s.yaml").get("mine")
    assert same(get(mat), expected(case, kind))


def test_material_wrong_dimension_names_the_key(db):
    with pytest.raises(UserError) as e:
        db.with_overrides({"mine": {"eps": [3.0, 0.1], "temperature": "3 m"}}, file="s.yaml")
    assert "materials.mine.temperature" in str(e.value) and "is not a temperature" in str(e.value)


@pytest.mark.parametrize("case", LENGTHS)
def test_bump_lengths(monkeypatch, case):
    seen = {}

    def fake_surface(rms, correlation, size, seed=0):
        seen.update(rms=rms, correlation=correlation, size=size)
        import numpy as np

        return np.zeros((16, 16))

    monkeypatch.setattr(bump_mod, "gaussian_surface", fake_surface)
    want = expected(case, "length")
    # size/correlation stays small whatever the case (the grid limit is on that ratio)
    bump_mod.make_bump({"model": "gaussian", "rms": case, "correlation": case, "size": case}, file="s.yaml")
    assert all(same(seen[k], want) for k in ("rms", "correlation", "size")), seen
    errors = []
    assert same(bump_mod._length({"height": case}, "height", "s.yaml", "bump", errors), want) and not errors


def test_bump_wrong_dimension_names_the_key():
    with pytest.raises(UserError) as e:
        bump_mod.make_bump(
            {"model": "gaussian", "rms": "3 K", "correlation": "3 cm", "size": "1 m"},
            file="s.yaml",
            key="materials.x.bump",
        )
    assert "materials.x.bump.rms" in str(e.value) and "is not a length" in str(e.value)


# ------------------------------------------------------------------------------------------------
# Command line
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("layer", ["rain,0 ft,3 km,0.5 in/h", "rain,0,3000 m,3.5277777777777777e-06 m/s"])
def test_sky_layer_option_units(layer):
    from pmmw.config.schema import WeatherLayer

    w = WeatherLayer.model_validate(parse_layer(layer))
    assert (w.base, w.top) == (0.0, 3000.0) and same(w.rain_rate, REF.Quantity("0.5 in/h").to("mm/h").magnitude)


def test_cli_materials_frequency_units():
    runner = CliRunner()
    a = runner.invoke(app, ["materials", "show", "concrete", "--frequency", "95 GHz"])
    b = runner.invoke(app, ["materials", "show", "concrete", "--frequency", "0.095 THz"])
    assert a.exit_code == 0 and a.output == b.output
    c = runner.invoke(app, ["materials", "show", "concrete", "--frequency", "95 mrad"])
    assert c.exit_code == 2 and "--frequency" in c.output and "is not a frequency" in c.output
    assert "Traceback" not in c.output


def test_cli_validate_fov_in_radians():
    """The reported bug: ``--set "imager.fov=0.5 rad"`` was read as 0.5 deg."""
    runner = CliRunner()
    cfg = str(ROOT / "configs" / "landing_95ghz.yaml")
    res = runner.invoke(app, ["validate", cfg, "--set", "imager.fov=0.5 rad"])
    assert res.exit_code == 0, res.output
    assert "fov: 28.6478897565 deg" in res.output  # 0.5 rad in degrees, 12 significant digits
    res = runner.invoke(app, ["validate", cfg, "--set", "imager.fov=600 mrad"])
    assert res.exit_code == 0 and "fov: 34.3774677078 deg" in res.output, res.output
    res = runner.invoke(app, ["validate", cfg, "--set", "imager.fov=3 m"])
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert "imager.fov: '3 m' is not an angle; expected e.g. '10 deg'" in res.output


@pytest.mark.parametrize("text, unit", [("95 Ghz", "GHz"), ("95 ghz", "GHz"), ("3 MM", "mm"), ("1.0 dB/Km", "dB/km")])
def test_a_unit_in_the_wrong_case_is_suggested(text, unit):
    kind = "attenuation" if "dB" in text else "frequency" if "hz" in text.lower() else "length"
    with pytest.raises(UserError, match=f"did you mean '{re.escape(unit)}'"):
        parse_quantity(text, kind, file="--x")


def _python_says(code: str) -> list[str]:
    """The words ``code`` prints in a fresh Python (which modules a first import loads)."""
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()


def test_units_import_without_dask_and_dask_still_imports_after():
    # pint imports Dask (and Jinja2) at its own import when installed: pmmw.units hides it, and
    # the control (dask imported afterwards) shows it is hidden only while pint is imported

    code = (
        "import sys\nimport pmmw.units as u\n"
        "print('dask' in sys.modules, 'jinja2' in sys.modules, u.parse_quantity('95 gigahertz', 'frequency'))\n"
        "import dask.array\nprint('dask' in sys.modules)\n"
    )
    assert _python_says(code) == ["False", "False", "95000000000.0", "True"]


# numbers of every magnitude and sign, with digits that no factor divides evenly
_VALUES = (0.0, -0.0, 1.0, 95.0, 0.8, 0.1, 1 / 3, -273.15, 1e-300, 6.02214076e23, 123456.789, 7e-7, 2.5, 1e308)


@pytest.mark.parametrize("kind", sorted(units_mod._EXACT))
def test_units_parsed_without_pint_are_pints_to_the_bit(kind):
    """The usual units are converted without importing pint (`pmmw.units._EXACT`): each factor is
    pint's, and every value parsed so is the float pint's own conversion gives (exact equality:
    both are one multiplication by the same factor; a factor off by one bit fails)."""
    reg = units_mod.ureg()
    internal, bare = units_mod._KINDS[kind][:2]
    for text, factor in units_mod._EXACT[kind].items():
        source = reg.Unit(bare) if text == "" else reg.parse_units(units_mod._unit_text(text, kind))
        assert factor == reg.get_root_units(source)[0] / reg.get_root_units(reg.Unit(internal))[0], text
        for v in _VALUES:
            expected = float(reg.Quantity(v, source).to(internal).magnitude)
            try:
                got = parse_quantity(f"{v!r} {text}" if text else v, kind)
            except UserError:  # out of the kind's range (1e308 km, a negative temperature): pint's value too
                with pytest.raises(UserError):
                    units_mod._checked(expected, v, kind, kind)
                continue
            assert got == expected and math.copysign(1.0, got) == math.copysign(1.0, expected), (text, v)


def test_the_usual_units_need_no_pint():
    # a scenario in the usual units is parsed without importing pint; the control, a unit outside
    # the table, imports it

    code = (
        "import sys\nfrom pmmw.units import parse_quantity as p\n"
        "p('95 GHz', 'frequency'), p('10 deg', 'angle'), p('15 g/m3', 'density'), p(288, 'temperature')\n"
        "print('pint' in sys.modules)\np('0.5 inch', 'length')\nprint('pint' in sys.modules)\n"
    )
    assert _python_says(code) == ["False", "True"]
