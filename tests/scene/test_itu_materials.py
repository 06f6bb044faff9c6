"""ITU-R P.2040-4 Table 3 building materials and ITU-R P.527-6 sec. 5.3 vegetation
(`pmmw.scene.itu_materials`).

P.2040: the table against three transcriptions made by other people (Sionna RT before and after
it moved to P.2040-4, and the "wave tracer" renderer's P.2040-2 table), values printed in MathWorks'
``buildingMaterialPermittivity`` documentation, the closed form eps'' = 17.98 sigma / f_GHz, and
the stated row selection, gap interpolation and extrapolation. P.527 vegetation: the bound- and
free-water terms against their complex closed forms, the above-freezing model against Ulaby and
El-Rayes (1987)'s original (they differ only in the free-water model), and finiteness, loss sign
and continuity over the ranges where the fits are physical.
"""

from __future__ import annotations

import cmath
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pmmw.scene.dielectric import EPS0
from pmmw.scene.itu_materials import (
    P527_VEGETATION_T_F,
    P2040_BUILDING_MATERIALS,
    P2040_ROWS,
    _p527_f1,
    p527_vegetation_permittivity,
    p2040_permittivity,
    p2040_valid_ranges,
)

GHZ = 1e9
TRANSCRIPTION_TOL = 0.0  # decimal copies of the same printed digits: equal, or a transcription error

# --- independent transcriptions, as their files hold them: {material: {(f_lo, f_hi): (a, b, c, d)}}
# Sionna RT v1.0.0 (NVlabs/sionna-rt, commit d0429340b2ee3848e48ed648db9a014dfba22cc8, 2025-03-18,
# src/sionna/rt/radio_materials/itu.py; its docs cite P.2040-3 (08/2023)).
SIONNA_P2040_3 = {
    "concrete": {(1.0, 100.0): (5.24, 0.0, 0.0462, 0.7822)},
    "brick": {(1.0, 40.0): (3.91, 0.0, 0.0238, 0.16)},
    "plasterboard": {(1.0, 100.0): (2.73, 0.0, 0.0085, 0.9395)},
    "wood": {(0.001, 100.0): (1.99, 0.0, 0.0047, 1.0718)},
    "glass": {(0.1, 100.0): (6.31, 0.0, 0.0036, 1.3394), (220.0, 450.0): (5.79, 0.0, 0.0004, 1.658)},
    "ceiling_board": {(1.0, 100.0): (1.48, 0.0, 0.0011, 1.0750), (220.0, 450.0): (1.52, 0.0, 0.0029, 1.029)},
    "chipboard": {(1.0, 100.0): (2.58, 0.0, 0.0217, 0.7800)},
    "plywood": {(1.0, 40.0): (2.71, 0.0, 0.33, 0.0)},
    "marble": {(1.0, 60.0): (7.074, 0.0, 0.0055, 0.9262)},
    "floorboard": {(50.0, 100.0): (3.66, 0.0, 0.0044, 1.3515)},
    "metal": {(1.0, 100.0): (1.0, 0.0, 1e7, 0.0)},
    "very_dry_ground": {(1.0, 10.0): (3.0, 0.0, 0.00015, 2.52)},
    "medium_dry_ground": {(1.0, 10.0): (15.0, -0.1, 0.035, 1.63)},
    "wet_ground": {(1.0, 10.0): (30.0, -0.4, 0.15, 1.30)},
}
# "wave tracer" (Shlomi Steinberg), src/wt/spectrum/util/spectrum_from_ITU.cpp, map
# ITU_P2040_2_table3 (P.2040-2, 09/2021): the same rows typed independently.
WAVE_TRACER_P2040_2 = {
    "concrete": {(1, 100): (5.24, 0, 0.0462, 0.7822)},
    "brick": {(1, 40): (3.91, 0, 0.0238, 0.16)},
    "plasterboard": {(1, 100): (2.73, 0, 0.0085, 0.9395)},
    "wood": {(0.001, 100): (1.99, 0, 0.0047, 1.0718)},
    "glass": {(0.1, 100): (6.31, 0, 0.0036, 1.3394), (220, 450): (5.79, 0, 0.0004, 1.658)},
    "ceiling_board": {(1, 100): (1.48, 0, 0.0011, 1.0750), (220, 450): (1.52, 0, 0.0029, 1.029)},
    "chipboard": {(1, 100): (2.58, 0, 0.0217, 0.7800)},
    "plywood": {(1, 40): (2.71, 0, 0.33, 0)},
    "marble": {(1, 60): (7.074, 0, 0.0055, 0.9262)},
    "floorboard": {(50, 100): (3.66, 0, 0.0044, 1.3515)},
    "metal": {(1, 100): (1, 0, 1e7, 0)},
    "very_dry_ground": {(1, 10): (3, 0, 0.00015, 2.52)},
    "medium_dry_ground": {(1, 10): (15, -0.1, 0.035, 1.63)},
    "wet_ground": {(1, 10): (30, -0.4, 0.15, 1.30)},
}
# Sionna RT main after PR #70 "update ITU materials to version 4" (NVlabs/sionna-rt, file version
# aeb346fe9ed1da24ff088a7acaa02252e45779eb of src/sionna/rt/radio_materials/itu.py): the only
# transcription found of the rows P.2040-4 added.
SIONNA_P2040_4_ADDED = {
    "concrete": {(110.0, 330.0): (5.17, 0.0, 0.0145, 1.0900)},
    "brick": {(110.0, 330.0): (4.15, 0.0, 0.0006, 1.5712)},
    "plasterboard": {(110.0, 330.0): (2.56, 0.0, 0.0001, 1.7799), (100.0, 400.0): (2.65, 0.0, 0.0002, 1.598)},
    "wood": {(110.0, 330.0): (1.82, 0.0, 0.0040, 1.0761), (100.0, 400.0): (2.1183, 0.0, 0.0055, 1.1113)},
    "glass": {(100.0, 400.0): (6.5767, 0.0, 0.0012, 1.4697)},
    "clear_acrylic": {(110.0, 330.0): (2.58, 0.0, 0.0001, 1.6524)},
    "ceiling_board": {(100.0, 400.0): (1.2567, 0.0, 0.00013, 1.454)},
    "chipboard": {(100.0, 200.0): (2.16, 0.0, 0.0023, 1.359)},
    "plywood": {(110.0, 330.0): (1.94, 0.0, 0.0067, 0.9982), (100.0, 400.0): (2.17, 0.0, 0.0063, 1.045)},
    "marble": {(110.0, 330.0): (7.94, 0.0, 0.0001, 1.7330), (100.0, 400.0): (8.62, 0.0, 0.0027, 1.15)},
    "floorboard": {
        (220.0, 300.0): (5.27, 0.0, 2.22e-17, 7.3413),
        (300.0, 400.0): (5.27, 0.0, 0.0003, 2.0298),
        (400.0, 450.0): (5.27, 0.0, 49.8726, 0.0),
        (100.0, 400.0): (3.1575, 0.0, 0.001675, 1.32775),
    },
    "vinyl_tile": {(1.0, 40.0): (3.62, 0.0, 0.0051, 0.8422)},
    "carpet_tile": {(1.0, 40.0): (2.08, 0.0, 0.0009, 0.8200)},
    "asphalt_concrete": {(1.0, 40.0): (4.83, 0.0, 0.0108, 1.3969)},
}


def _ours(material):
    return {(r[4], r[5]): r[:4] for r in P2040_ROWS[material]}


@pytest.mark.parametrize(
    "name, table", [("sionna_p2040_3", SIONNA_P2040_3), ("wave_tracer_p2040_2", WAVE_TRACER_P2040_2)]
)
def test_p2040_rows_kept_from_editions_2_and_3_match_two_transcriptions(name, table):
    """Every row P.2040-2/-3 printed is in our P.2040-4 table with the same digits; exact (TRANSCRIPTION_TOL)."""
    for material, rows in table.items():
        ours = _ours(material)
        for rng, abcd in rows.items():
            assert rng in ours, f"{name}: {material} row {rng} GHz missing"
            assert all(abs(x - y) <= TRANSCRIPTION_TOL for x, y in zip(ours[rng], abcd)), (name, material, rng)


def test_p2040_4_table_is_exactly_the_old_rows_plus_the_added_ones():
    """No row more or less than edition 3's plus edition 4's additions (Sionna RT's transcription)."""
    expected = {}
    for table in (SIONNA_P2040_3, SIONNA_P2040_4_ADDED):
        for material, rows in table.items():
            expected.setdefault(material, {}).update(rows)
    assert set(P2040_ROWS) == set(expected)
    for material, rows in expected.items():
        assert _ours(material) == {k: tuple(float(x) for x in v) for k, v in rows.items()}, material


@pytest.mark.parametrize("material, eps_r, sigma", [("wood", 1.99, 0.049528), ("metal", 1.0, 1e7)])
def test_p2040_matches_mathworks_documented_values_at_9_ghz(material, eps_r, sigma):
    """MathWorks' buildingMaterialPermittivity page (R2021a, P.2040-1) prints eps' and sigma at 9 GHz;
    wood's and metal's rows are unchanged since P.2040-1. Printed to 5 significant digits: rel 1e-4."""
    e, status = p2040_permittivity(9 * GHZ, material)
    assert status.startswith("in row")
    assert e.real == pytest.approx(eps_r, rel=1e-4)
    assert e.imag * 2.0 * math.pi * 9 * GHZ * EPS0 == pytest.approx(sigma, rel=1e-4)


@pytest.mark.parametrize("material", list(P2040_ROWS))
def test_p2040_eps_imag_is_17_98_sigma_over_f(material):
    """P.2040-4 eq. (9b) eps'' = 17.98 sigma / f_GHz inside each row; 17.98 is 1 / (2 pi 1e9 eps0) =
    17.975 rounded to 4 digits, so rel 3e-4 (half a unit in its last digit: 0.005 / 17.98 = 2.8e-4)."""
    for row in P2040_ROWS[material]:
        f_ghz = math.sqrt(row[4] * row[5])
        e, status = p2040_permittivity(f_ghz * GHZ, material)
        if status != f"in row {row[4]:g}-{row[5]:g} GHz":
            continue  # a narrower overlapping row serves this frequency
        assert e.real == pytest.approx(row[0] * f_ghz ** row[1], rel=1e-12)  # float64 rounding only
        assert e.imag == pytest.approx(17.98 * row[2] * f_ghz ** row[3] / f_ghz, rel=3e-4)


def test_p2040_overlapping_rows_pick_the_narrowest_as_sionna_does():
    """Where rows overlap the narrowest serves; Sionna RT's first-listed row is the same row at these
    frequencies, so both give the same eps' (exact: the same row's a)."""
    cases = [
        ("plasterboard", 200, "110-330", 2.56),
        ("plasterboard", 105, "100-400", 2.65),
        ("floorboard", 250, "220-300", 5.27),
        ("floorboard", 90, "50-100", 3.66),
        ("glass", 300, "220-450", 5.79),
        ("chipboard", 150, "100-200", 2.16),
    ]
    for material, f_ghz, row, a in cases:
        e, status = p2040_permittivity(f_ghz * GHZ, material)
        assert status == f"in row {row} GHz"
        assert e.real == a


@pytest.mark.parametrize(
    "material, gap",
    [("concrete", (100.0, 110.0)), ("brick", (40.0, 110.0)), ("plywood", (40.0, 100.0)), ("marble", (60.0, 100.0))],
)
def test_p2040_gap_is_interpolated_between_the_two_rows_and_flagged(material, gap):
    """In a gap: flagged, eps' and sigma between the two rows' edge values (inclusive), and continuous
    with each row at its edge (rel 1e-6 over a step of 1e-9 in f: power laws with |exponent| < 8)."""
    f0, f1 = gap
    e0, s0 = p2040_permittivity(f0 * GHZ, material)
    e1, s1 = p2040_permittivity(f1 * GHZ, material)
    assert s0.startswith("in row") and s1.startswith("in row")
    for t in (1e-9, 0.25, 0.5, 0.75, 1 - 1e-9):
        f = f0 * (f1 / f0) ** t
        e, status = p2040_permittivity(f * GHZ, material)
        assert status == f"interpolated between rows {s0[7:-4]} GHz and {s1[7:-4]} GHz"
        sig = [x.imag * 2 * math.pi * ff * GHZ * EPS0 for x, ff in ((e0, f0), (e, f), (e1, f1))]
        assert min(e0.real, e1.real) <= e.real <= max(e0.real, e1.real)
        assert min(sig[0], sig[2]) * (1 - 1e-12) <= sig[1] <= max(sig[0], sig[2]) * (1 + 1e-12)
    near0, _ = p2040_permittivity(f0 * (1 + 1e-9) * GHZ, material)
    near1, _ = p2040_permittivity(f1 * (1 - 1e-9) * GHZ, material)
    assert near0 == pytest.approx(e0, rel=1e-6)
    assert near1 == pytest.approx(e1, rel=1e-6)


def test_p2040_outside_all_rows_is_extrapolated_from_the_nearest_and_flagged():
    e, status = p2040_permittivity(300 * GHZ, "asphalt_concrete")
    assert status == "extrapolated from row 1-40 GHz"
    assert e.imag == pytest.approx(0.0108 * 300**1.3969 / (2 * math.pi * 300 * GHZ * EPS0), rel=1e-12)
    assert p2040_permittivity(0.5 * GHZ, "concrete")[1] == "extrapolated from row 1-100 GHz"
    assert "1-10 GHz only" in p2040_permittivity(35 * GHZ, "wet_ground")[1]
    assert p2040_valid_ranges("glass") == ((0.1e9, 100e9), (220e9, 450e9), (100e9, 400e9))
    with pytest.raises(KeyError, match="known"):
        p2040_permittivity(35 * GHZ, "cardboard")


@settings(max_examples=400, deadline=None, derandomize=True)
@given(material=st.sampled_from(P2040_BUILDING_MATERIALS), log_f=st.floats(math.log(1.0), math.log(450.0)))
def test_p2040_is_finite_lossy_and_piecewise_continuous(material, log_f):
    """1-450 GHz: finite, eps' >= 1, eps'' > 0; a step of 1e-7 in f that stays in one row or gap
    changes eps by under 1e-5 relative (|d ln eps / d ln f| < 8 for every row and gap)."""
    f = math.exp(log_f) * GHZ
    e, status = p2040_permittivity(f, material)
    assert math.isfinite(e.real) and math.isfinite(e.imag)
    assert e.real >= 1.0 and e.imag > 0.0
    e2, status2 = p2040_permittivity(f * (1 + 1e-7), material)
    if status2 == status:
        assert abs(e2 - e) <= 1e-5 * abs(e)


# --- P.527-6 sec. 5.3 vegetation -----------------------------------------------------------------


def test_vegetation_bound_water_terms_are_their_complex_closed_forms():
    """Sec. 5.3.1's real expansion of 55 / (1 + sqrt(-i f / (0.01 f_1))) (exp(-i w t) sign) and
    sec. 5.3.2's X_1, Y_1 of 1 / (1 + (-i f / 1.2582)^0.2054), evaluated with complex arithmetic
    instead of the Recommendation's real expansion; 1e-9 (float64 rounding, no fit)."""
    f_ghz, T = 35.0, 293.15
    f_1 = _p527_f1(T)
    bound = 2.9 + 55.0 / (1.0 + cmath.sqrt(-1j * f_ghz / (0.01 * f_1)))
    assert bound.imag > 0  # loss in pmmw's sign
    # eq. (73)-(74) minus the dry and free-water parts leaves v_bw * bound
    from pmmw.atmosphere.itu import p527_water_permittivity

    for mg in (0.2, 0.5):
        e = p527_vegetation_permittivity(f_ghz * GHZ, T, mg)
        eps_dv = 1.7 - 0.74 * mg + 6.16 * mg**2
        v_fw = mg * (0.55 * mg - 0.076)
        v_bw = 4.64 * mg**2 / (1 + 7.36 * mg**2)
        eps_pw = complex(p527_water_permittivity(f_ghz * GHZ, T))
        rest = e - eps_dv - v_fw * (eps_pw + 1j * 22.86 / f_ghz)
        assert rest == pytest.approx(v_bw * bound, rel=1e-9)
    # below freezing at T = T_f (Delta = 0) the volume fractions are the quadratics' constants
    T = 273.15 + P527_VEGETATION_T_F
    mg = 0.5
    v_fw = -0.106 + 0.6591 * mg - 0.610 * mg**2
    v_bw = -0.16 + 1.1876 * mg - 0.387 * mg**2
    v_ice = -0.0538 + 0.4616 * mg - 0.3398 * mg**2
    eps_dv = 6.76 - 10.24 * mg + 6.19 * mg**2
    free = 4.9 + 82.2 / (1 - 1j * f_ghz / 9.0) + 1j * 11.394 / f_ghz
    bound = 8.092 + 14.2067 / (1.0 + (-1j * f_ghz / 1.2582) ** 0.2054)
    expected = eps_dv + v_fw * free + v_bw * bound + 3.15 * v_ice
    assert p527_vegetation_permittivity(f_ghz * GHZ, T, mg) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("f_ghz", [1.0, 5.0, 10.0, 20.0])
@pytest.mark.parametrize("mg", [0.2, 0.4, 0.6])
def test_vegetation_above_freezing_is_ulaby_el_rayes_with_p527_water(f_ghz, mg):
    """Ulaby and El-Rayes 1987 (eqs. as the corn-leaf code and P.527-6 give them) with their free
    water 4.9 + 75 / (1 - i f/18) + i 18 sigma / f, sigma = 1.27 S/m: P.527-6 replaced that free
    water by its pure water, so the two differ by exactly v_fw (eps_pw - their Debye water); 1e-9."""
    from pmmw.atmosphere.itu import p527_water_permittivity

    T = 295.15  # 22 C, their laboratory temperature
    v_fw = mg * (0.55 * mg - 0.076)
    v_bw = 4.64 * mg**2 / (1 + 7.36 * mg**2)
    eps_dv = 1.7 - 0.74 * mg + 6.16 * mg**2
    debye = 4.9 + 75.0 / (1 - 1j * f_ghz / 18.0) + 1j * 22.86 / f_ghz
    bound = 2.9 + 55.0 / (1.0 + cmath.sqrt(-1j * f_ghz / 0.18))
    ulaby = eps_dv + v_fw * debye + v_bw * bound
    # their bound-water relaxation is 0.18 GHz; P.527-6 writes it as 0.01 f_1(T) (0.178 GHz at 22 C)
    ours = p527_vegetation_permittivity(f_ghz * GHZ, T, mg)
    eps_pw = complex(p527_water_permittivity(f_ghz * GHZ, T))
    bound_p527 = 2.9 + 55.0 / (1.0 + cmath.sqrt(-1j * f_ghz / (0.01 * _p527_f1(T))))
    assert ours - ulaby == pytest.approx(
        v_fw * (eps_pw + 22.86j / f_ghz - debye) + v_bw * (bound_p527 - bound), rel=1e-9, abs=1e-9
    )
    # and the replacement moves eps by under 5 % at 1-20 GHz (the two water models agree to ~3 % there)
    assert abs(ours - ulaby) <= 0.05 * abs(ulaby)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(log_f=st.floats(math.log(1.0), math.log(450.0)), t_c=st.floats(0.01, 40.0), mg=st.floats(0.1, 0.7))
def test_vegetation_above_freezing_finite_lossy_continuous(log_f, t_c, mg):
    """Above 0 C, M_g >= 0.1 (below 0.09 the negative free-water fraction makes eps'' < 0 at mm-waves):
    finite, eps' >= 1, eps'' >= 0, and a 1e-7 step in f, T or M_g moves eps by under 1e-5 relative."""
    f, T = math.exp(log_f) * GHZ, 273.15 + t_c
    e = p527_vegetation_permittivity(f, T, mg)
    assert math.isfinite(e.real) and math.isfinite(e.imag)
    assert e.real >= 1.0 and e.imag >= 0.0
    for e2 in (
        p527_vegetation_permittivity(f * (1 + 1e-7), T, mg),
        p527_vegetation_permittivity(f, T * (1 + 1e-7), mg),
        p527_vegetation_permittivity(f, T, mg * (1 + 1e-7)),
    ):
        assert abs(e2 - e) <= 1e-5 * abs(e)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(
    log_f=st.floats(math.log(1.0), math.log(450.0)), t_c=st.floats(-20.0, P527_VEGETATION_T_F), mg=st.floats(0.2, 0.7)
)
def test_vegetation_frozen_finite_lossy_continuous(log_f, t_c, mg):
    """-20 C to T_f = -6.5 C, M_g >= 0.2 (the frozen fit's loss turns negative below M_g ~ 0.2):
    finite, eps' >= 1, eps'' >= 0, and a 1e-7 step in f, T or M_g moves eps by under 1e-5 relative."""
    f, T = math.exp(log_f) * GHZ, 273.15 + t_c
    e = p527_vegetation_permittivity(f, T, mg)
    assert math.isfinite(e.real) and math.isfinite(e.imag)
    assert e.real >= 1.0 and e.imag >= 0.0
    for e2 in (
        p527_vegetation_permittivity(f * (1 + 1e-7), T, mg),
        p527_vegetation_permittivity(f, T * (1 + 1e-7), mg),
        p527_vegetation_permittivity(f, T, mg * (1 + 1e-7)),
    ):
        assert abs(e2 - e) <= 1e-5 * abs(e)
