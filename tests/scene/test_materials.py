"""The material database: shipped numbers against Murakowski 2014's tables, interpolation, overrides,
validation errors (file + dotted key), duplicate ids, suggestions, and the `pmmw materials` text."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pmmw.errors import UserError, UserErrors, clear_warnings, collected_warnings
from pmmw.scene.materials import (
    KINDS,
    CoatingLayer,
    Material,
    MaterialDB,
    default_materials_dir,
    format_material,
    format_material_table,
)

GHZ = 1e9
SCN = "scenario.yaml"


@pytest.fixture(scope="module")
def db() -> MaterialDB:
    return MaterialDB.load()


def _errors(exc: UserError) -> list[UserError]:
    return list(exc.errors) if isinstance(exc, UserErrors) else [exc]


def _keys(excinfo) -> list[str]:
    return [e.key for e in _errors(excinfo.value)]


def _eps(db, mid, f_ghz):
    return db.get(mid).eps_at(f_ghz * GHZ)


# --- the shipped database ------------------------------------------------------------------


APPENDIX_A = {  # Murakowski 2014 Table A.1, the set murakowski2014.*: id -> {GHz: eps}
    "murakowski2014.concrete": {35: 5.5 + 0.5j, 95: 2.49 + 6.8e-2j},
    "murakowski2014.asphalt": {35: 2.5 + 0.6j},
    "murakowski2014.brick": {35: 1.3 + 7.4e-2j},
    "murakowski2014.sand": {35: 3.0 + 0.56j, 95: 4.6 + 7e-3j},
    "murakowski2014.ice": {35: 3.1 + 2e-3j, 95: 3.1 + 9e-3j},
    "murakowski2014.dry_soil": {35: 3.1 + 0.2j, 95: 2.9 + 0.2j},
    "murakowski2014.moist_soil": {35: 4.9 + 2.1j, 95: 3.1 + 1.2j},
    "murakowski2014.basalt": {35: 6.7 + 0.28j, 95: 6.8 + 0.45j},
    "murakowski2014.granite": {35: 5.3 + 2.3e-2j},
    "murakowski2014.denim": {35: 1.6 + 6e-2j},
    "murakowski2014.beige_leather": {35: 2.2 + 6e-2j},
    "murakowski2014.human_skin": {35: 14 + 16j, 95: 5.9 + 9.4j},
    "murakowski2014.oak_leaves": {35: 7.3 + 5.6j, 95: 4.1 + 3.3j},
    "murakowski2014.polypropylene": {35: 2.3 + 1.8e-4j, 95: 2.26 + 1.3e-3j},
    "murakowski2014.plexiglass": {35: 2.3 + 2e-2j, 95: 2.59 + 1.9e-2j},
    "murakowski2014.nylon": {35: 2.99 + 2.1e-2j, 95: 2.99 + 2.5e-2j},
    "murakowski2014.fiberglass": {35: 4.3 + 0.11j, 95: 3.78 + 9.3e-2j},
    "murakowski2014.water": {35: 12.5 + 22.5j, 95: 6.65 + 9.4j},
    "murakowski2014.salt_water": {35: 12.3 + 23.2j, 95: 5.82 + 10.1j},
}

CHAPTERS = {  # Murakowski 2014 Tables 2.1-2.3, 3.1, 3.3, 3.4: id -> ({GHz: eps}, T [K])
    "cinderblock": ({35: 5.5 + 0.5j}, 300),  # Table 2.1
    "desert_sand": ({35: 3.9 + 0.56j}, 300),  # Tables 2.1, 2.2
    "sa9_tire": ({35: 7.7 + 0.38j}, 300),  # Table 2.2
    "leather_interior": ({35: 2.2 + 0.06j}, 300),
    "concrete_table_2_3": ({35: 5.5 + 0.5j}, 288),  # Table 2.3
    "fused_silica": ({35: 3.9 + 0j}, 288),
    "moist_soil_bikes": ({35: 4.9 + 2.1j}, 288),
    "sa9_tire_table_2_3": ({35: 7.7 + 0.38j}, 288),
    "polypropylene_table_2_3": ({35: 1.9 + 0.01j}, 288),
    "runway_asphalt": ({35: 2.5 + 0.6j, 95: 2.25 + 0.18j}, 288),  # Table 3.1
    "landing_ground": ({35: 4.9 + 2.1j, 95: 3.7 + 1.2j}, 288),
    "shoe_leather": ({35: 2.2 + 0.06j, 95: 2.21 + 0.161j}, 300),  # Table 3.3
    "holster_leather": ({35: 2.2 + 0.06j, 95: 2.21 + 0.161j}, 310),
    "denim_clothing": ({35: 1.6 + 0.06j, 95: 1.61 + 0.121j}, 300),
    "dry_skin": ({35: 14 + 16j, 95: 5.9 + 9.4j}, 310),
    "cwd_ground": ({35: 2.5 + 0.6j, 95: 2.25 + 0.18j}, 296),
    "sar_dry_ground": ({35: 3.1 + 0.2j, 95: 2.9 + 0.2j}, 300),  # Table 3.4
    "sar_wet_ground": ({35: 4.9 + 2.1j, 95: 3.1 + 1.2j}, 300),
    "sar_rocks": ({35: 6.7 + 0.31j, 95: 6.7 + 0.43j}, 300),
}


def test_default_dir_is_the_repo_materials_folder(monkeypatch):
    monkeypatch.delenv("PMMW_MATERIALS", raising=False)
    d = default_materials_dir()
    assert d.name == "materials" and (d / "appendix_a.yaml").is_file()
    monkeypatch.setenv("PMMW_MATERIALS", "/somewhere/else")
    assert str(default_materials_dir()) == "/somewhere/else"


def test_spot_checks_from_the_seed_tables(db):
    assert _eps(db, "murakowski2014.concrete", 35) == 5.5 + 0.5j
    assert _eps(db, "murakowski2014.human_skin", 95) == 5.9 + 9.4j
    assert _eps(db, "runway_asphalt", 95) == 2.25 + 0.18j
    assert db.get("runway_asphalt").temperature == 288.0
    assert db.get("holster_leather").temperature == 310.0


@pytest.mark.parametrize("mid", sorted(APPENDIX_A))
def test_every_appendix_a_row(db, mid):
    m = db.get(mid)
    assert m.kind == "dielectric" and m.temperature is None  # the appendix gives no temperature
    assert tuple(f / GHZ for f in m.freqs) == pytest.approx(tuple(sorted(APPENDIX_A[mid])))
    for f, e in APPENDIX_A[mid].items():
        assert m.eps_at(f * GHZ) == pytest.approx(e, rel=1e-12)
    assert "Table A.1" in m.source and "[" in m.source  # names the table and the references


@pytest.mark.parametrize("mid", sorted(CHAPTERS))
def test_every_chapter_table_row(db, mid):
    table, t = CHAPTERS[mid]
    m = db.get(mid)
    assert m.temperature == t
    assert tuple(f / GHZ for f in m.freqs) == pytest.approx(tuple(sorted(table)))
    for f, e in table.items():
        assert m.eps_at(f * GHZ) == pytest.approx(e, rel=1e-12)
    assert "Table " in m.source


def test_generic_and_composite_entries(db):
    assert db.get("metal").kind == "metal" and db.get("metal").freqs == () and db.get("metal").eps == ()
    assert db.get("blackbody").kind == "blackbody"
    with pytest.raises(ValueError):
        db.get("metal").eps_at(95 * GHZ)
    skin = db.get("clothed_skin")  # Table 3.3 person under 0.8 mm denim (sec. 3.2.1)
    assert skin.coating == (CoatingLayer("denim_clothing", pytest.approx(0.8e-3), 300.0),)
    assert skin.eps_at(95 * GHZ) == db.get("dry_skin").eps_at(95 * GHZ)


def test_shipped_database_is_consistent(db):
    db.check()
    ids = db.ids()
    assert len(ids) == len(set(ids))
    for mid in ids:
        m = db.get(mid)
        assert m.id == mid and m.kind in KINDS and m.name and m.source and m.origin.endswith(".yaml")
        assert list(m.freqs) == sorted(m.freqs)
        assert all(e.imag >= 0 for e in m.eps)
        assert (m.kind in ("metal", "blackbody")) == (not m.has_eps())
        if m.model is not None:  # a model entry: lossy or lossless, never gain, across 35-300 GHz
            assert not m.eps and all(m.eps_at(f * GHZ).imag >= 0 for f in (35, 95, 140, 220, 300))


# --- interpolation -------------------------------------------------------------------------


def test_interpolation_is_linear_in_frequency(db):
    c = db.get("murakowski2014.concrete")
    mid = c.eps_at(65 * GHZ)
    assert mid == pytest.approx(((5.5 + 0.5j) + (2.49 + 0.068j)) / 2, rel=1e-12)
    w = (50 - 35) / (95 - 35)
    assert c.eps_at(50 * GHZ) == pytest.approx((1 - w) * (5.5 + 0.5j) + w * (2.49 + 0.068j), rel=1e-12)


def test_outside_the_table_clamps_and_warns_once(db):
    clear_warnings()
    c = db.get("murakowski2014.concrete")
    assert c.eps_at(10 * GHZ) == 5.5 + 0.5j
    assert c.eps_at(140 * GHZ) == 2.49 + 0.068j
    assert c.eps_at(140 * GHZ) == 2.49 + 0.068j  # the same frequency again: no second warning
    warnings = [w for w in collected_warnings() if "murakowski2014.concrete" in w]
    # one per frequency asked, each naming the material, the frequency and the table's range
    assert len(warnings) == 2 and all("35 GHz to 95 GHz" in w for w in warnings)
    assert "10 GHz" in warnings[0] and "140 GHz" in warnings[1]
    assert db.get("murakowski2014.asphalt").eps_at(95 * GHZ) == 2.5 + 0.6j  # 35 GHz only in Table A.1
    assert any("murakowski2014.asphalt" in w and "35 GHz" in w for w in collected_warnings())
    clear_warnings()
    assert c.eps_at(35 * GHZ) == 5.5 + 0.5j and c.eps_at(95 * GHZ) == 2.49 + 0.068j
    assert collected_warnings() == []


@settings(max_examples=50, deadline=None)
@given(st.floats(35.0, 95.0))
def test_interpolated_values_lie_between_the_table_values(f_ghz):
    m = Material("x", "x", "dielectric", (35e9, 95e9), (5.5 + 0.5j, 2.49 + 0.068j), None)
    e = m.eps_at(f_ghz * GHZ)
    assert 2.49 - 1e-12 <= e.real <= 5.5 + 1e-12 and 0.068 - 1e-12 <= e.imag <= 0.5 + 1e-12


def test_model_temperature_of_a_table_material():
    """The temperature asked, else the material's own: a table (no model) has no reference
    temperature, which is an error only when neither is given (it was an AttributeError on
    None even with a temperature given)."""
    m = Material("x", "x", "dielectric", (35e9, 95e9), (5.5 + 0.5j, 2.49 + 0.068j), None)
    assert m.model_temperature(250.0) == 250.0  # exact: the value given is returned
    warm = Material("y", "y", "dielectric", (35e9,), (5.5 + 0.5j,), 300.0)
    assert warm.model_temperature() == 300.0
    with pytest.raises(ValueError, match="has no model"):
        m.model_temperature()


def test_frequency_independent_eps(db):
    d2 = db.with_overrides({"foam": {"eps": [1.05, "1e-3"], "temperature": "290 K"}}, file=SCN)
    foam = d2.get("foam")
    assert foam.freqs == () and foam.eps == (1.05 + 1e-3j,)  # YAML reads 1e-3 as a string: accepted
    clear_warnings()
    assert foam.eps_at(10 * GHZ) == foam.eps_at(300 * GHZ) == 1.05 + 1e-3j
    assert collected_warnings() == []


# --- overrides ----------------------------------------------------------------------------


def test_partial_override_keeps_the_rest(db):
    d2 = db.with_overrides({"murakowski2014.concrete": {"temperature": "290 K"}}, file=SCN)
    c = d2.get("murakowski2014.concrete")
    assert c.temperature == 290.0
    assert c.eps == db.get("murakowski2014.concrete").eps and c.freqs == db.get("murakowski2014.concrete").freqs
    assert c.name == "Concrete" and "Table A.1" in c.source and c.origin == SCN
    assert db.get("murakowski2014.concrete").temperature is None  # the original is untouched
    d3 = db.with_overrides(
        {"murakowski2014.asphalt": {"eps": {"95 GHz": [2.25, 0.18], "35 GHz": [2.5, 0.6]}, "temperature": "288 K"}},
        file=SCN,
    )
    a = d3.get("murakowski2014.asphalt")
    assert a.freqs == (35e9, 95e9) and a.eps_at(95 * GHZ) == 2.25 + 0.18j and a.temperature == 288.0
    d4 = db.with_overrides({"murakowski2014.concrete": {"eps": {"60 GHz": [4, 0.3]}}}, file=SCN)
    assert d4.get("murakowski2014.concrete").freqs == (60e9,)  # eps replaces the whole table


def test_override_to_metal_drops_eps(db):
    d2 = db.with_overrides({"murakowski2014.concrete": {"kind": "metal"}}, file=SCN)
    assert d2.get("murakowski2014.concrete").kind == "metal" and d2.get("murakowski2014.concrete").eps == ()


def test_new_material_with_coating(db):
    raw = {
        "painted_steel": {
            "kind": "metal",
            "coating": [{"material": "plexiglass", "thickness": "0.5 mm", "temperature": "20 degC"}],
            "source": "test",
        },
        "tarp": {"kind": "thin", "eps": {"35 GHz": [2.3, 0.02]}, "thickness": "0.2 mm", "temperature": 290},
    }
    d2 = db.with_overrides(raw, file=SCN)
    p = d2.get("painted_steel")
    assert p.coating[0].material == "plexiglass"
    assert p.coating[0].thickness == pytest.approx(0.5e-3) and p.coating[0].temperature == pytest.approx(293.15)
    t = d2.get("tarp")
    assert t.kind == "thin" and t.thickness == pytest.approx(0.2e-3) and t.temperature == 290.0
    assert set(d2.ids()) == set(db.ids()) | {"painted_steel", "tarp"}
    assert "tarp" not in db.ids()


def test_unknown_key_names_the_dotted_path(db):
    with pytest.raises(UserError) as ei:
        db.with_overrides({"foo": {"epss": [2, 0.1]}}, file=SCN)
    (e,) = _errors(ei.value)
    assert e.file == SCN and e.key == "materials.foo.epss"
    assert e.message.startswith("unknown key 'epss' for a material (did you mean 'eps'?); allowed: ")


def test_negative_loss_is_an_error(db):
    with pytest.raises(UserError) as ei:
        db.with_overrides({"runway": {"eps": {"35 GHz": [2.5, 0.6], "95 GHz": [2.25, -0.18]}}}, file=SCN)
    (e,) = _errors(ei.value)
    assert e.key == 'materials.runway.eps."95 GHz"[1]' and "eps''" in e.message and e.file == SCN
    assert str(e).startswith(f"{SCN}: materials.runway.eps.")


@pytest.mark.parametrize("freq", ["95 m", "95", "ninety GHz", 95])
def test_bad_frequency_key_is_an_error(db, freq):
    with pytest.raises(UserError) as ei:
        db.with_overrides({"runway": {"eps": {freq: [2.25, 0.18]}}}, file=SCN)
    (e,) = _errors(ei.value)
    assert e.key.startswith("materials.runway.eps.") and "frequency" in e.message


def test_unknown_coating_material_is_an_error(db):
    raw = {"coat": {"eps": [3, 0.1], "coating": [{"material": "demin", "thickness": "0.8 mm"}]}}
    with pytest.raises(UserError) as ei:
        db.with_overrides(raw, file=SCN)
    (e,) = _errors(ei.value)
    assert e.key == "materials.coat.coating[0].material" and "demin" in e.message and "'denim'" in e.message


@pytest.mark.parametrize(
    "raw, key, words",
    [
        ({"x": {"eps": [2, "a"]}}, "materials.x.eps[1]", "number"),
        ({"x": {"eps": [2]}}, "materials.x.eps", "two numbers"),
        ({"x": {"eps": [2, float("inf")]}}, "materials.x.eps[1]", "finite"),
        ({"x": {"eps": [2, 0.1], "temperature": "-3 K"}}, "materials.x.temperature", "below absolute zero"),
        ({"x": {"eps": [2, 0.1], "temperature": "3 m"}}, "materials.x.temperature", "temperature"),
        ({"x": {"eps": [2, 0.1], "kind": "metl"}}, "materials.x.kind", "metal"),
        ({"x": {"temperature": "300 K"}}, "materials.x", "needs `eps`"),
        ({"x": {"kind": "thin", "eps": [2, 0.1]}}, "materials.x", "thickness"),
        ({"x": {"eps": [2, 0.1], "thickness": "1 mm"}}, "materials.x.thickness", "only for kind thin"),
        ({"x": {"kind": "metal", "eps": [2, 0.1]}}, "materials.x.eps", "no permittivity"),
        (
            {"x": {"eps": [2, 0.1], "coating": [{"material": "metal", "thickness": "1 mm"}]}},
            "materials.x.coating[0].material",
            "metal",
        ),
        (
            {"x": {"eps": [2, 0.1], "coating": [{"material": "clothed_skin", "thickness": "1 mm"}]}},
            "materials.x.coating[0].material",
            "nested",
        ),
        (
            {"x": {"eps": [2, 0.1], "coating": [{"material": "denim", "thickness": "-1 mm"}]}},
            "materials.x.coating[0].thickness",
            ">= 0",
        ),
        (
            {"x": {"eps": [2, 0.1], "coating": [{"material": "denim", "thick": "1 mm"}]}},
            "materials.x.coating[0].thick",
            "for a coating layer (did you mean 'thickness'?); allowed: ",
        ),
        ({"x": {"eps": [2, 0.1], "coating": {"material": "denim"}}}, "materials.x.coating", "list"),
        ({"x": 5}, "materials.x", "mapping"),
        ({"Bad-Id": {"eps": [2, 0.1]}}, 'materials."Bad-Id"', "lower_snake_case"),
        ({"x": {"eps": {"35 GHz": [2, 0.1], "35000 MHz": [2, 0.1]}}}, 'materials.x.eps."35000 MHz"', "twice"),
        ({"x": {"eps": {}}}, "materials.x.eps", "empty"),
    ],
)
def test_validation_errors_name_file_and_key(db, raw, key, words):
    with pytest.raises(UserError) as ei:
        db.with_overrides(raw, file=SCN)
    errs = _errors(ei.value)
    assert any(e.key == key and words in e.message and e.file == SCN for e in errs), [str(e) for e in errs]


def test_errors_are_collected_across_entries(db):
    raw = {"a": {"epss": 1}, "b": {"eps": [1, -1]}, "c": {"kind": "thin", "eps": [2, 0]}}
    with pytest.raises(UserErrors) as ei:
        db.with_overrides(raw, file=SCN)
    assert set(_keys(ei)) == {"materials.a.epss", "materials.b.eps[1]", "materials.c"}


def test_overrides_must_be_a_mapping(db):
    with pytest.raises(UserError) as ei:
        db.with_overrides(["concrete"], file=SCN)
    assert ei.value.key == "materials"
    assert db.with_overrides(None, file=SCN) is db


# --- files --------------------------------------------------------------------------------


def test_duplicate_ids_across_files_name_both(tmp_path):
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    a.write_text("foam: {eps: [1.05, 0.001]}\n")
    b.write_text("foam: {eps: [1.1, 0.002]}\n")
    with pytest.raises(UserError) as ei:
        MaterialDB.load(tmp_path)
    (e,) = _errors(ei.value)
    assert "a.yaml" in e.message and "b.yaml" in e.message and e.key == "foam"


def test_duplicate_id_against_the_shipped_database(tmp_path):
    extra = tmp_path / "extra.yaml"
    extra.write_text("concrete: {eps: [5, 0.5]}\n")
    with pytest.raises(UserError) as ei:
        MaterialDB.load([default_materials_dir(), extra])
    assert "buildings.yaml" in str(ei.value) and "extra.yaml" in str(ei.value)


def test_malformed_yaml_names_file_and_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("a:\n  eps: {35 GHz: [1, 0.1]\nb: {eps: [2, 0.1]}\n")
    with pytest.raises(UserError) as ei:
        MaterialDB.load(bad)
    assert ei.value.file == str(bad) and "line" in ei.value.message


def test_duplicate_key_in_one_file_is_an_error(tmp_path):
    f = tmp_path / "d.yaml"
    f.write_text("a: {eps: [1, 0.1]}\na: {eps: [2, 0.1]}\n")
    with pytest.raises(UserError) as ei:
        MaterialDB.load(f)
    assert "duplicate" in ei.value.message and "line 2" in ei.value.message


def test_file_errors_use_the_entry_id_as_key(tmp_path):
    f = tmp_path / "m.yaml"
    f.write_text("a: {eps: {95 GHz: [1, -0.1]}}\nb: {eps: [1, 0.1], coating: [{material: nope, thickness: 1 mm}]}\n")
    with pytest.raises(UserErrors) as ei:
        MaterialDB.load(f)
    assert set(_keys(ei)) == {'a.eps."95 GHz"[1]', "b.coating[0].material"}
    assert all(e.file == str(f) for e in ei.value.errors)


def test_env_var_selects_the_database(tmp_path, monkeypatch):
    (tmp_path / "only.yaml").write_text("foam: {eps: [1.05, 0.001], temperature: 290 K}\n")
    monkeypatch.setenv("PMMW_MATERIALS", str(tmp_path))
    assert MaterialDB.load().ids() == ["foam"]


# --- lookup and text ----------------------------------------------------------------------


def test_unknown_id_suggests_close_matches(db):
    with pytest.raises(UserError) as ei:
        db.get("concret", file=SCN, key="scene[0].material")
    e = ei.value
    assert e.file == SCN and e.key == "scene[0].material" and "'concrete'" in e.message
    with pytest.raises(UserError) as ei:
        db.get("moist_sol")
    assert "'moist_soil'" in ei.value.message


def test_format_material_table(db):
    text = format_material_table(db, None)
    for mid in db.ids():
        assert mid in text
    assert "5.5+0.5j" in text and "2.49+0.068j" in text
    text95 = format_material_table(db, 95 * GHZ)
    assert "95 GHz" in text95 and "5.9+9.4j" in text95 and "human_skin" in text95
    lines = text95.splitlines()
    header = lines[0]
    col = header.index("kind")
    assert all(line[col - 2 : col] == "  " for line in lines[2 : 2 + len(db.ids())])  # aligned


def test_format_material(db):
    text = format_material(db, "murakowski2014.concrete")
    assert (
        "murakowski2014.concrete" in text and "5.5 + 0.5j" in text and "Table A.1" in text and "appendix_a.yaml" in text
    )
    text = format_material(db, "murakowski2014.concrete", 65 * GHZ)
    assert "65 GHz" in text and "interpolated" in text
    text = format_material(db, "clothed_skin", 95 * GHZ)
    assert "denim_clothing" in text and "0.8 mm" in text
    assert "metal" in format_material(db, "metal", 95 * GHZ)
    with pytest.raises(UserError):
        format_material(db, "no_such_material")


def test_materials_are_immutable(db):
    m = db.get("murakowski2014.concrete")
    with pytest.raises(Exception):
        m.temperature = 3.0  # type: ignore[misc]
    assert math.isclose(m.eps_at(35 * GHZ).real, 5.5)


# ---------------------------------------------------------------------------------------------
# roughness: and bump:
# ---------------------------------------------------------------------------------------------


def test_roughness_and_bump_entries(db):
    from pmmw.physics.roughness import GGX, AshikhminShirley
    from pmmw.scene.bump import BumpMap

    new = db.with_overrides(
        {
            "rough_sand": {
                "eps": [3.9, 0.56],
                "roughness": {"model": "ggx", "alpha": 0.3},
                "bump": {"model": "gaussian", "rms": "3 mm", "correlation": "3 cm", "size": "2 m"},
            },
            "sand": {"roughness": {"model": "ashikhmin_shirley", "ex": 5, "ey": 50, "orientation_deg": 20}},
        },
        file=SCN,
    )
    r = new.get("rough_sand")
    assert isinstance(r.roughness, GGX) and isinstance(r.bump, BumpMap)
    # RMS slope of a Gaussian surface: sqrt(2) rms / correlation = 0.141 per direction; one
    # realization holds ~(2 m / 3 cm)^2 = 4400 correlation areas (variance estimate +-2 %) and
    # central differences at correlation / 8 lose ~1 %: 5 %
    assert r.bump.rms_slope == pytest.approx(math.sqrt(2) * 3e-3 / 3e-2, rel=0.05)
    assert isinstance(new.get("sand").roughness, AshikhminShirley)
    assert new.get("sand").eps == db.get("sand").eps  # the rest of the entry is kept
    assert db.get("sand").roughness is None  # smooth by default
    assert "roughness" in format_material(new, "rough_sand") and "bump" in format_material(new, "rough_sand")
    # null switches roughness off again
    assert new.with_overrides({"sand": {"roughness": None}}, file=SCN).get("sand").roughness is None


def test_coating_layer_roughness_is_parsed(db):
    new = db.with_overrides(
        {
            "painted": {
                "kind": "metal",
                "coating": [
                    {
                        "material": "polypropylene",
                        "thickness": "0.1 mm",
                        "roughness": {"model": "blinn_phong", "m": 100},
                    }
                ],
            }
        },
        file=SCN,
    )
    assert new.get("painted").coating[0].roughness is not None


@pytest.mark.parametrize(
    "raw, key, words",
    [
        ({"roughness": {"model": "fuzzy"}}, "materials.sand.roughness.model", "known"),
        ({"roughness": {"model": "ggx"}}, "materials.sand.roughness.alpha", "missing"),
        ({"roughness": {"model": "ggx", "alpha": -1}}, "materials.sand.roughness.alpha", "must be"),
        (
            {"roughness": {"model": "ashikhmin_shirley", "ex": 3, "ey": 3, "m": 2}},
            "materials.sand.roughness.m",
            "unknown parameter",
        ),
        ({"roughness": 0.3}, "materials.sand.roughness", "mapping"),
        ({"bump": {"model": "gaussian", "rms": "3 mm", "size": "1 m"}}, "materials.sand.bump.correlation", "missing"),
        (
            {"bump": {"model": "gaussian", "rms": "3 mm", "correlation": "0.1 mm", "size": "10 m"}},
            "materials.sand.bump.size",
            "too large",
        ),
        (
            {"bump": {"texture": "nope.png", "height": "1 mm", "size": "1 m"}},
            "materials.sand.bump.texture",
            "not found",
        ),
        ({"bump": {"model": "perlin"}}, "materials.sand.bump.model", "unknown bump model"),
        (
            {"coating": [{"material": "polypropylene", "thickness": "1 mm", "roughness": {"model": "ggx"}}]},
            "materials.sand.coating[0].roughness.alpha",
            "missing",
        ),
        (
            {
                "kind": "thin",
                "thickness": "1 mm",
                "coating": [
                    {"material": "polypropylene", "thickness": "1 mm", "roughness": {"model": "ggx", "alpha": 0.2}}
                ],
            },
            "materials.sand.coating[0].roughness",
            "thin sheet",
        ),
    ],
)
def test_roughness_and_bump_errors_name_file_and_key(db, raw, key, words):
    with pytest.raises(UserError) as ei:
        db.with_overrides({"sand": raw}, file=SCN)
    errs = _errors(ei.value)
    assert key in [e.key for e in errs], [e.key for e in errs]
    assert any(words in str(e) for e in errs)
    assert all(e.file is not None for e in errs)
