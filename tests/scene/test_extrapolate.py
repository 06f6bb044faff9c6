"""A permittivity table beyond its ends: ``extrapolate: hold`` (the end row's value, the default) and
``extrapolate: trend`` (eps' and eps'' each the power law a f^b through the two end rows, the form of
ITU-R P.2040-4's materials), its warnings, its errors (file and key) and its bounds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pmmw.errors import UserError, UserErrors, clear_warnings, collected_warnings
from pmmw.scene.materials import TREND_EXPONENT_MAX, Material, MaterialDB, format_material

GHZ = 1e9
SCN = "scenario.yaml"
DENIM = {35: 1.6 + 0.06j, 95: 1.61 + 0.121j}  # Murakowski 2014 Table A.1 / Table 3.3, as shipped


@pytest.fixture(scope="module")
def db() -> MaterialDB:
    return MaterialDB.load()


def _line(f_ghz, rows):
    """The straight line through two (f, v) points in log-log, by numpy's least squares (two
    points: exact), evaluated at f: a second way to the power law, sharing no code with pmmw."""
    (f1, v1), (f2, v2) = rows
    b, log_a = np.polyfit(np.log([f1, f2]), np.log([v1, v2]), 1)
    return float(np.exp(log_a + b * math.log(f_ghz)))


def _entry(eps, **extra):
    return {"eps": {f"{f} GHz": [e.real, e.imag] for f, e in eps.items()}, **extra}


def test_trend_is_the_power_law_through_the_end_rows(db):
    """denim at 140-300 GHz continues its 35 -> 95 GHz rise. Tolerance 1e-12 relative: two exact
    evaluations of the same line in double precision (polyfit's 2x2 solve and a log/exp pair)."""
    d2 = db.with_overrides({"denim": {"extrapolate": "trend"}}, file=SCN)
    denim = d2.get("denim")
    for f in (140, 220, 300):
        e = denim.eps_at(f * GHZ)
        assert e.real == pytest.approx(_line(f, [(35, 1.6), (95, 1.61)]), rel=1e-12)
        assert e.imag == pytest.approx(_line(f, [(35, 0.06), (95, 0.121)]), rel=1e-12)
    # below the table too, through the two lowest rows
    assert denim.eps_at(20 * GHZ).imag == pytest.approx(_line(20, [(35, 0.06), (95, 0.121)]), rel=1e-12)
    # control: the default holds the 95 GHz value, 2.2 times below the trend at 300 GHz
    held = db.get("denim").eps_at(300 * GHZ)
    assert held == DENIM[95] and denim.eps_at(300 * GHZ).imag / held.imag == pytest.approx(
        (300 / 95) ** (math.log(0.121 / 0.06) / math.log(95 / 35)), rel=1e-12
    )
    assert denim.eps_at(300 * GHZ).imag > 2.0 * held.imag


def test_trend_meets_the_table_at_its_ends(db):
    """Continuous at the table's edges: just outside an end row the trend is that row's value
    (to the relative step asked, 1e-6, times the exponent: below 1e-5)."""
    denim = db.with_overrides({"denim": {"extrapolate": "trend"}}, file=SCN).get("denim")
    for f, e in DENIM.items():
        step = 1e-6 if f == 95 else -1e-6
        assert denim.eps_at(f * GHZ * (1 + step)) == pytest.approx(e, rel=1e-5)


def test_trend_uses_the_rows_at_its_own_end(db):
    """A table of three rows: above it the two highest rows' law, below it the two lowest's.
    Control: the line through the lowest two, continued to 300 GHz, is 15 % off."""
    rows = {35: 2.0 + 0.10j, 95: 2.0 + 0.20j, 140: 2.0 + 0.25j}
    mat = db.with_overrides({"x": _entry(rows, extrapolate="trend")}, file=SCN).get("x")
    top = _line(300, [(95, 0.20), (140, 0.25)])
    assert mat.eps_at(300 * GHZ).imag == pytest.approx(top, rel=1e-12)
    assert mat.eps_at(20 * GHZ).imag == pytest.approx(_line(20, [(35, 0.10), (95, 0.20)]), rel=1e-12)
    assert abs(_line(300, [(35, 0.10), (95, 0.20)]) / top - 1) > 0.1  # the control differs
    assert mat.eps_at(120 * GHZ) == pytest.approx(2.0 + (0.20 + (0.25 - 0.20) * 25 / 45) * 1j, rel=1e-12)


def test_a_zero_value_is_held(db):
    """No power law passes through zero: a lossless row's eps'' is held at 0 (not NaN), eps'
    still follows its trend."""
    mat = db.with_overrides({"x": _entry({35: 2.0 + 0.0j, 95: 2.2 + 0.0j}, extrapolate="trend")}, file=SCN).get("x")
    e = mat.eps_at(300 * GHZ)
    assert e.imag == 0.0 and e.real == pytest.approx(_line(300, [(35, 2.0), (95, 2.2)]), rel=1e-12)


def test_trend_warns_once_naming_the_law(db):
    clear_warnings()
    denim = db.with_overrides({"denim": {"extrapolate": "trend"}}, file=SCN).get("denim")
    denim.eps_at(300 * GHZ)
    denim.eps_at(300 * GHZ)
    denim.eps_at(60 * GHZ)  # inside the table: no warning
    warnings = [w for w in collected_warnings() if "'denim'" in w]
    assert len(warnings) == 1
    assert "300 GHz" in warnings[0] and "power law" in warnings[0] and "eps'' as f^0.702" in warnings[0]
    clear_warnings()


def test_materials_show_says_how_the_table_is_extended(db):
    text = format_material(db, "denim", 300 * GHZ)
    assert "extrapolate:    hold" in text and "nearest tabulated value" in text
    d2 = db.with_overrides({"denim": {"extrapolate": "trend"}}, file=SCN)
    text = format_material(d2, "denim", 300 * GHZ)
    assert "extrapolate:    trend" in text and "power law through its rows at 95 GHz and 35 GHz" in text


def test_same_as_and_overrides_carry_it(db):
    d2 = db.with_overrides(
        {"denim": {"extrapolate": "trend"}, "jeans": {"same_as": "denim", "temperature": "300 K"}}, file=SCN
    )
    assert d2.get("jeans").extrapolate == "trend" and d2.get("denim").extrapolate == "trend"
    assert db.get("denim").extrapolate == "hold"  # the original is untouched
    # a change of kind to one without a permittivity drops it, as it drops eps
    d3 = d2.with_overrides({"denim": {"kind": "metal"}}, file=SCN)
    assert d3.get("denim").kind == "metal"


@pytest.mark.parametrize(
    "raw, words",
    [
        ({"denim": {"extrapolate": "trnd"}}, "did you mean 'trend'"),
        ({"water": {"extrapolate": "trend"}}, "a model extrapolates by its own formula"),
        ({"metal": {"extrapolate": "hold"}}, "a metal has none"),
        ({"x": {"eps": [2.0, 0.1], "extrapolate": "trend"}}, "at least two frequencies"),
        ({"x": {"eps": {"95 GHz": [2.0, 0.1]}, "extrapolate": "hold"}}, "at least two frequencies"),
        ({"x": _entry({94: 1.6 + 0.1j, 95: 1.6 + 0.2j}, extrapolate="trend")}, "f^65.5"),
    ],
)
def test_errors_name_the_key(db, raw, words):
    with pytest.raises((UserError, UserErrors)) as ex:
        db.with_overrides(raw, file=SCN)
    errors = list(ex.value.errors) if isinstance(ex.value, UserErrors) else [ex.value]
    assert len(errors) == 1 and errors[0].file == SCN
    assert errors[0].key == f"materials.{next(iter(raw))}.extrapolate" and words in errors[0].message


def test_steep_trends_are_refused_at_the_bound(db):
    """Control of the bound: a law just under TREND_EXPONENT_MAX is accepted, just over it refused."""
    ratio = 2.0
    for b, ok in ((TREND_EXPONENT_MAX * 0.99, True), (TREND_EXPONENT_MAX * 1.01, False)):
        rows = {50: 2.0 + 1e-3j, 100: 2.0 + 1e-3 * ratio**b * 1j}
        if ok:
            db.with_overrides({"x": _entry(rows, extrapolate="trend")}, file=SCN)
        else:
            with pytest.raises(UserError, match="steeper than f"):
                db.with_overrides({"x": _entry(rows, extrapolate="trend")}, file=SCN)


@settings(max_examples=200, deadline=None)
@given(
    st.floats(1.0, 500.0),
    st.floats(1.05, 2.0),
    st.lists(st.floats(1e-4, 100.0), min_size=4, max_size=4),
    st.floats(1.0, 1000.0),
)
def test_trend_is_finite_and_passive_everywhere(f1, ratio, values, f):
    """Every table the entry accepts gives a finite eps with eps'' >= 0 at every frequency a
    scenario accepts (1-1000 GHz), however steep its accepted trend."""
    a, b, c, d = values
    rows = ((f1 * GHZ, complex(a, b)), (f1 * ratio * GHZ, complex(c, d)))
    steep = [abs(math.log(y / x) / math.log(ratio)) for x, y in ((a, c), (b, d))]
    if max(steep) > TREND_EXPONENT_MAX:
        return  # refused when built (tested above)
    mat = Material(
        "x", "x", "dielectric", tuple(r[0] for r in rows), tuple(r[1] for r in rows), None, extrapolate="trend"
    )
    e = mat._lookup(f * GHZ)[0]
    assert math.isfinite(e.real) and math.isfinite(e.imag) and e.real > 0 and e.imag >= 0


def test_same_as_starts_from_the_target_as_the_scenario_leaves_it(db):
    """`holster: {same_as: leather}` written before `leather: {extrapolate: trend}` in one map (as a
    sweep's `materials.leather.extrapolate` key adds it) takes the overridden leather: the map is
    applied in same_as order, not file order. Control: leather not overridden, the holster holds."""
    raw = {"holster": {"same_as": "leather", "temperature": "310 K"}, "leather": {"extrapolate": "trend"}}
    d2 = db.with_overrides(raw, file=SCN)
    assert d2.get("holster").extrapolate == "trend" and d2.get("holster").temperature == 310.0
    assert d2.get("holster").eps_at(300 * GHZ) == d2.get("leather").eps_at(300 * GHZ)
    control = db.with_overrides({"holster": raw["holster"]}, file=SCN)
    assert control.get("holster").extrapolate == "hold"
    assert control.get("holster").eps_at(300 * GHZ).imag < 0.5 * d2.get("holster").eps_at(300 * GHZ).imag


def test_same_as_circles_in_a_scenario_are_an_error(db):
    with pytest.raises(UserErrors) as ex:
        db.with_overrides({"a": {"same_as": "b"}, "b": {"same_as": "a"}}, file=SCN)
    assert sorted(e.key for e in ex.value.errors) == ["materials.a.same_as", "materials.b.same_as"]
    assert all("circle" in e.message for e in ex.value.errors)
    # an entry's same_as itself (a database id) is not a circle: it starts from the database's
    d2 = db.with_overrides({"denim": {"same_as": "denim", "temperature": "300 K"}}, file=SCN)
    assert d2.get("denim").eps == db.get("denim").eps and d2.get("denim").temperature == 300.0


def test_a_long_table_is_read_and_looked_up_as_numpy_interpolates_it(db):
    """A table of 20 000 rows (a measured spectrum): its rows found by bisection and its values
    between them equal to the bit numpy's interpolation over the whole table (each value is
    np.interp's formula on its own segment); a repeated frequency still refused, naming both keys;
    its stated band is its first to its last row."""
    rng = np.random.default_rng(7)
    fs = np.unique(np.round(np.geomspace(20.0, 400.0, 20000), 9))
    re_, im_ = rng.uniform(1.5, 3.0, fs.size), rng.uniform(0.0, 0.2, fs.size)
    raw = {f"{f:.9g} GHz": [float(a), float(b)] for f, a, b in zip(fs, re_, im_)}
    mat = db.with_overrides({"spectrum": {"eps": raw}}, file=SCN).get("spectrum")
    assert len(mat.freqs) == fs.size
    table = np.array(mat.freqs)
    for f in np.concatenate([rng.uniform(20.0, 400.0, 300) * GHZ, table[::997]]):
        e = mat.eps_at(f)
        assert e.real == float(np.interp(f, table, [x.real for x in mat.eps]))
        assert e.imag == float(np.interp(f, table, [x.imag for x in mat.eps]))
    twice = dict(raw, **{"0.02 THz": [2.0, 0.1]})  # 20 GHz again, in another unit
    with pytest.raises(UserError, match="given twice"):
        db.with_overrides({"spectrum": {"eps": twice}}, file=SCN)
    from pmmw.scene.materials import band_text, stated_band

    band, _ = stated_band(db.with_overrides({"spectrum": {"eps": raw}}, file=SCN), ["spectrum"], 290.0, (1e9, 1e12))
    assert band_text(band) == "20-400 GHz"


@pytest.mark.parametrize("merge", ["override", "same_as"])
def test_a_new_eps_or_kind_drops_an_inherited_extrapolate(db, merge):
    """Both ways an entry starts from another (a scenario's change of a database entry, and
    ``same_as``) drop what the result cannot have: a one-value eps or a metal kind does not
    inherit ``extrapolate: trend`` (it was refused at a key the user never wrote). Control: a
    two-row table keeps it."""
    base = {"denim": {"extrapolate": "trend"}}
    for change, kept in (
        ({"eps": [2.0, 0.1]}, "hold"),
        ({"kind": "metal"}, "hold"),
        ({"eps": {"35 GHz": [2.0, 0.1], "95 GHz": [2.1, 0.2]}}, "trend"),
    ):
        if merge == "override":
            d2 = db.with_overrides(base, file=SCN).with_overrides({"denim": change}, file=SCN)
            mat = d2.get("denim")
        else:
            mat = db.with_overrides({**base, "x": {"same_as": "denim", **change}}, file=SCN).get("x")
        assert mat.extrapolate == kept, change
