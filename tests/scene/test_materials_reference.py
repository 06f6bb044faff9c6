"""Material permittivity models against independent references over 35-300 GHz.

pmmw's models (`pmmw.scene.dielectric.MODELS`, `pmmw.atmosphere.itu`) are checked against
code that shares nothing with them:

* SMRT (`smrt.permittivity.*`): its own transcriptions of Liebe 1991, Maetzler 2006, Hufford 1991,
  Klein-Swift 1977, Stogryn et al. 1995 and Dobson et al. 1985;
* pyrtlib (`pyrtlib.utils.dilec12`): Rosenkranz 2015's liquid-water model (Patek 2009 static
  permittivity, Ellison 2007 Debye term, Rosenkranz's B band), an independent fit to newer data,
  "validated for 1 < f < 1000 GHz at 273 < T < 330 K";
* itur (`itur.models.itu840.specific_attenuation_coefficients`): ITU-R P.840's liquid-water K_l,
  which is all of P.840's Liebe permittivity that `itur` exposes.

Conventions, checked in `test_reference_sign_conventions`: pmmw writes eps' + i eps'' with
eps'' >= 0 lossy, f [Hz], T [K], salinity [g/kg]. SMRT writes eps' + j eps'' with eps'' > 0, f
[Hz], T [K], salinity [kg/kg] (multiply g/kg by `smrt.PSU` = 1e-3), soil sand and clay as
fractions [1]. pyrtlib's dilec12 takes f [GHz], T [K] and returns eps' - j eps'' (loss negative):
it is conjugated here.

Where two different models are compared the tolerance is the spread expected between independent
fits to the same laboratory data, fixed before the comparison was run (each test says why); where
the reference is the same published formula, double-precision rounding. The nadir emissivity
e = 1 - |(sqrt(eps) - 1) / (sqrt(eps) + 1)|^2 is what a radiometer sees and is less sensitive to
eps than eps itself, so model-to-model checks use it where eps alone would be too loose to say
anything.
"""

import cmath

import numpy as np
import pytest

F_GHZ = (35.0, 94.0, 140.0, 220.0, 300.0)  # the imager bands and the band edge [GHz]
T_WATER = (273.15, 283.15, 293.15, 303.15, 310.15)  # liquid water [K]


def nadir_emissivity(eps: complex) -> float:
    """1 - |r|^2 at normal incidence from air, r = (sqrt(eps) - 1) / (sqrt(eps) + 1); either sign of
    eps'' gives the same |r|."""
    n = cmath.sqrt(eps)
    return 1.0 - abs((n - 1.0) / (n + 1.0)) ** 2


def _p527(f_ghz, t_k, salinity=0.0) -> complex:
    from pmmw.atmosphere.itu import p527_water_permittivity

    return complex(p527_water_permittivity(f_ghz * 1e9, t_k, salinity))


def _liebe(f_ghz, t_k) -> complex:
    from pmmw.scene.dielectric import MODELS

    return complex(MODELS["water"].fn(f_ghz * 1e9, t_k))


def _rosenkranz15(f_ghz, t_k) -> complex:
    from pyrtlib.utils import dilec12

    return complex(dilec12(f_ghz, t_k)).conjugate()  # pyrtlib: eps' - j eps''


def test_reference_sign_conventions():
    """The references' loss sign and units, so the conversions above are right: SMRT's water, sea
    water, ice and soil return eps'' > 0, pyrtlib's dilec12 eps'' < 0; SMRT's salinity is in kg/kg
    (PSU = 1e-3: 35 g/kg is 0.035, and passing 35 would put the static term far off); pmmw's own
    models return eps'' >= 0."""
    from pyrtlib.utils import dilec12
    from smrt import PSU
    from smrt.permittivity.ice import ice_permittivity_maetzler06
    from smrt.permittivity.saline_water import seawater_permittivity_klein76, seawater_permittivity_stogryn95
    from smrt.permittivity.soil import soil_permittivity_dobson85_original
    from smrt.permittivity.water import water_permittivity_maetzler87

    assert PSU == 1e-3
    assert complex(water_permittivity_maetzler87(94e9, 293.15)).imag > 0
    assert complex(seawater_permittivity_stogryn95(94e9, 293.15, 35 * PSU)).imag > 0
    assert complex(seawater_permittivity_klein76(1.4e9, 293.15, 35 * PSU)).imag > 0
    assert complex(ice_permittivity_maetzler06(94e9, 263.15)).imag > 0
    assert complex(soil_permittivity_dobson85_original(18e9, 293.15, 0.2, 0.4, 0.2)).imag > 0
    assert complex(dilec12(94.0, 293.15)).imag < 0
    # salinity in kg/kg: sea water's static permittivity at 1.4 GHz is ~70, not negative or huge
    assert 60 < complex(seawater_permittivity_klein76(1.4e9, 293.15, 35 * PSU)).real < 80
    assert _p527(94, 293.15).imag > 0 and _p527(94, 293.15, 35).imag > 0 and _liebe(94, 293.15).imag > 0


# --- pure water ---------------------------------------------------------------------------------


@pytest.mark.parametrize("f_ghz", F_GHZ)
@pytest.mark.parametrize("t_k", T_WATER)
def test_p527_pure_water_equals_smrt_liebe91(f_ghz, t_k):
    """P.527-6 sec. 5.1.1 (salinity 0) is Liebe, Hufford and Manabe 1991 with eps_inf = 3.52 - 7.52
    theta and 146.4 in f_1: exactly what SMRT codes (from its own source, theta = 1 - 300/T) as
    `smrt.permittivity.water.water_permittivity_maetzler87` (named after Maetzler and Wegmueller
    1987, but the formula is Liebe 1991's; SMRT states no range, Liebe 1991 states below 1 THz,
    T >= 273.15 K by its check). Same formula in double precision: 1e-12 relative."""
    from smrt.permittivity.water import water_permittivity_maetzler87

    theirs = complex(water_permittivity_maetzler87(f_ghz * 1e9, t_k))
    assert abs(_p527(f_ghz, t_k) - theirs) <= 1e-12 * abs(theirs)


@pytest.mark.parametrize("f_ghz", F_GHZ)
@pytest.mark.parametrize("t_k", T_WATER)
def test_water_model_gives_itur_p840_kl(f_ghz, t_k):
    """pmmw's ``water`` model (P.840-8 eqs. 4-10, Liebe 1991 with eps_inf 3.52) through P.840's
    K_l = 0.819 f / (eps'' (1 + eta^2)), eta = (2 + eps') / eps'' [(dB/km)/(g/m^3)], against
    `itur.models.itu840.specific_attenuation_coefficients(f [GHz], T [C])` (P.840, to 1000 GHz).
    The same published equations: 1e-9 relative."""
    import itur.models.itu840 as p840

    e = _liebe(f_ghz, t_k)
    eta = (2.0 + e.real) / e.imag
    ours = 0.819 * f_ghz / (e.imag * (1.0 + eta**2))
    theirs = float(np.asarray(p840.specific_attenuation_coefficients(f_ghz, t_k - 273.15)))
    assert ours == pytest.approx(theirs, rel=1e-9)


# Two fits of double-Debye (or Debye + resonance) form to the same laboratory water data above
# 0 C: they are expected to agree to a few per cent in eps over 35-300 GHz. Tolerance: 5 % of |eps|
# (complex difference), and 0.01 in nadir emissivity (about 3 K of brightness at 290 K, the size of
# the spread between modern water models at millimetre waves). Decided before the comparison.
WATER_MODEL_REL = 0.05
WATER_MODEL_EMISSIVITY = 0.01


# Found, not hidden: above 140 GHz Liebe 1991 (P.527-6, P.840-8) and Rosenkranz 2015 part by more
# than the tolerance: up to 12.8 % in eps and 0.014 in emissivity at 273 K and 303-310 K, 220-300
# GHz (Rosenkranz adds a far-infrared band Liebe's double Debye lacks). pmmw follows the
# Recommendation; these cases are expected to fail (strict: one that starts passing is reported).
_WATER_SPREAD = {(273.15, 220.0, "p527"), (273.15, 300.0, "p527"), (273.15, 300.0, "water")} | {
    (t, f, m) for t in (303.15, 310.15) for f in (220.0, 300.0) for m in ("p527", "water")
}


def _water_cases():
    for t_k in T_WATER:
        for f_ghz in F_GHZ:
            for model in ("p527", "water"):
                marks = (
                    [
                        pytest.mark.xfail(
                            strict=True, reason="Liebe 1991 against Rosenkranz 2015: model spread above 140 GHz"
                        )
                    ]
                    if (t_k, f_ghz, model) in _WATER_SPREAD
                    else []
                )
                yield pytest.param(model, f_ghz, t_k, marks=marks, id=f"{t_k}-{f_ghz}-{model}")


@pytest.mark.parametrize("model, f_ghz, t_k", list(_water_cases()))
def test_pure_water_against_rosenkranz_2015(model, f_ghz, t_k):
    """pmmw's pure water (P.527-6 sec. 5.1.1, and the ``water`` model, P.840-8's Liebe 1991)
    against Rosenkranz 2015 as `pyrtlib.utils.dilec12` codes it (validated 1-1000 GHz at
    273-330 K): an independent model fitted to newer data (Ellison 2007's compilation). Tolerances
    `WATER_MODEL_REL` and `WATER_MODEL_EMISSIVITY` (above)."""
    ours = _p527(f_ghz, t_k) if model == "p527" else _liebe(f_ghz, t_k)
    theirs = _rosenkranz15(f_ghz, t_k)
    assert abs(ours - theirs) <= WATER_MODEL_REL * abs(theirs), (ours, theirs)
    assert abs(nadir_emissivity(ours) - nadir_emissivity(theirs)) <= WATER_MODEL_EMISSIVITY, (ours, theirs)


@pytest.mark.parametrize("f_ghz, target", [(35, 0.448), (94, 0.586), (140, 0.652), (220, 0.719), (300, 0.756)])
def test_p527_pure_water_nadir_emissivity_at_293_k(f_ghz, target):
    """The nadir emissivity of pure water at 293 K that the issue quotes from ITU-R P.527-6 (a
    user's computation with P.527 and Fresnel): 0.448, 0.586, 0.652, 0.719, 0.756 at 35, 94, 140,
    220, 300 GHz. Quoted to 3 digits: 0.005."""
    assert nadir_emissivity(_p527(f_ghz, 293.0)) == pytest.approx(target, abs=0.005)


# --- sea water (salinity 35 g/kg) ----------------------------------------------------------------


@pytest.mark.parametrize("f_ghz", [1.4, 2.65])
@pytest.mark.parametrize("t_k", [273.15, 283.15, 293.15, 303.15])
def test_p527_sea_water_against_klein_swift_at_l_and_s_band(f_ghz, t_k):
    """P.527-6 sec. 5.1.2 at 35 g/kg against Klein and Swift 1977,
    `smrt.permittivity.saline_water.seawater_permittivity_klein76` (salinity in kg/kg). Klein and
    Swift fitted L- and S-band measurements (1.43, 2.65 GHz) and state brightness errors under
    0.3 K only below X band; at millimetre waves they disclaim accuracy, so this compares where
    they are valid: where the salinity and conductivity terms dominate eps, which 35-300 GHz tests
    barely see. The L-band models (Klein-Swift, Meissner-Wentz whose salinity terms P.527 uses,
    Boutin, GW2020) differ by about 1 %: 2 % of |eps|."""
    from smrt import PSU
    from smrt.permittivity.saline_water import seawater_permittivity_klein76

    ours = _p527(f_ghz, t_k, 35.0)
    theirs = complex(seawater_permittivity_klein76(f_ghz * 1e9, t_k, 35.0 * PSU))
    assert abs(ours - theirs) <= 0.02 * abs(theirs), (ours, theirs)


def test_standard_sea_water_conductivity():
    """Both sea-water codes' ionic conductivity, read off eps'' at 1 kHz (ionic term 18 sigma / f
    [GHz] in P.527-6, 17.9751 sigma / f in Stogryn), for standard sea water, 35 g/kg at 15 C:
    4.2914 S/m (PSS-78's definition, C(35, 15, 0) = 42.914 mS/cm). 1e-3 relative (Stogryn's
    sigma_35 polynomial is a fit; P.527 rounds 17.9751 to 18, which this reading takes back)."""
    sigma_p527 = _p527(1e-6, 288.15, 35.0).imag * 1e-6 / 18.0
    assert sigma_p527 == pytest.approx(4.2914, rel=1e-3)
    sigma_stogryn = _stogryn95(1e-6, 288.15, 35.0).imag * 1e-6 / 17.97510
    assert sigma_stogryn == pytest.approx(4.2914, rel=1e-3)


# Sea water at 35-300 GHz: Stogryn et al. 1995 (a double Debye with its own parameters, fitted to
# data to about 100 GHz and stated "valid from 0 to 1000 GHz") against P.527-6 (Liebe's pure water
# with Meissner and Wentz 2004's salinity terms, their sea-water fit stated to at least 90 GHz).
# Sea-water models differ by a few K in brightness at 37-90 GHz (the reason Meissner-Wentz 2004 and
# Ellison et al. 2003 refitted them): nadir emissivity within 0.015 (~4 K at 290 K), and eps, less
# constrained by the data above 100 GHz, within 10 % of |eps|. Decided before the comparison.
SEA_WATER_EMISSIVITY = 0.015
SEA_WATER_REL = 0.10


def _stogryn95(f_ghz, t_k, salinity) -> complex:
    """`smrt.permittivity.saline_water.seawater_permittivity_stogryn95` with its one known typo
    undone: its R15 denominator reads 10004.75 where Stogryn et al. 1995 (and Meissner-Wentz's
    code, P.527-6 eq. (24)) have 1004.75, which halves the ionic conductivity at 35 g/kg (R15 is 1
    for standard sea water at 15 C by definition). SMRT's own conductivity is read off its eps''
    at 1 kHz, where the ionic term j 17.9751 sigma / f [GHz] exceeds the dipolar one ~1e13-fold,
    and scaled by the ratio of the two denominators; the rest is SMRT's code."""
    from smrt import PSU
    from smrt.permittivity.saline_water import seawater_permittivity_stogryn95

    s = salinity
    eps = complex(seawater_permittivity_stogryn95(f_ghz * 1e9, t_k, s * PSU))
    sigma_smrt = complex(seawater_permittivity_stogryn95(1e3, t_k, s * PSU)).imag * 1e-6 / 17.97510  # [S/m]
    ratio = (10004.75 + 182.283 * s + s**2) / (1004.75 + 182.283 * s + s**2)
    return eps + 1j * 17.97510 * sigma_smrt * (ratio - 1.0) / f_ghz


# Found, not hidden: cold sea water (0-10 C) at 94-300 GHz parts by up to 0.018 in emissivity and
# 28 % in eps: Meissner and Wentz's salinity terms lower the second relaxation frequency 0.30-fold
# at 0 C, Stogryn et al.'s do not, and neither is fitted to sea-water data above about 100 GHz.
# Expected to fail (strict).
_SEA_SPREAD = {(273.15, f) for f in (94.0, 140.0, 220.0, 300.0)} | {(283.15, 220.0), (283.15, 300.0)}


@pytest.mark.parametrize(
    "f_ghz, t_k",
    [
        pytest.param(
            f,
            t,
            id=f"{t}-{f}",
            marks=[
                pytest.mark.xfail(
                    strict=True, reason="Meissner-Wentz against Stogryn salinity terms, cold water above 90 GHz"
                )
            ]
            if (t, f) in _SEA_SPREAD
            else [],
        )
        for t in (273.15, 283.15, 293.15, 303.15)
        for f in F_GHZ
    ],
)
def test_p527_sea_water_against_stogryn_1995(f_ghz, t_k):
    """P.527-6 at 35 g/kg against `smrt.permittivity.saline_water.seawater_permittivity_stogryn95`
    (salinity in kg/kg; stated 0-1000 GHz), its conductivity typo undone (`_stogryn95`).
    Tolerances `SEA_WATER_REL`, `SEA_WATER_EMISSIVITY`."""
    ours = _p527(f_ghz, t_k, 35.0)
    theirs = _stogryn95(f_ghz, t_k, 35.0)
    assert abs(nadir_emissivity(ours) - nadir_emissivity(theirs)) <= SEA_WATER_EMISSIVITY, (ours, theirs)
    assert abs(ours - theirs) <= SEA_WATER_REL * abs(theirs), (ours, theirs)


# --- ice ---------------------------------------------------------------------------------------

T_ICE = (243.15, 253.15, 263.15, 268.15, 273.15)


@pytest.mark.parametrize("f_ghz", F_GHZ)
@pytest.mark.parametrize("t_k", T_ICE)
def test_ice_equals_smrt_maetzler06(f_ghz, t_k):
    """pmmw's ``ice`` (Maetzler 2006) against `smrt.permittivity.ice.ice_permittivity_maetzler06`
    (Maetzler 2006 pp. 456-461; 0.01-3000 GHz by the source): the same formula, 1e-12 relative."""
    from smrt.permittivity.ice import ice_permittivity_maetzler06

    from pmmw.scene.dielectric import MODELS

    ours = complex(MODELS["ice"].fn(f_ghz * 1e9, t_k))
    theirs = complex(ice_permittivity_maetzler06(f_ghz * 1e9, t_k))
    assert abs(ours.real - theirs.real) <= 1e-12 * theirs.real
    assert abs(ours.imag - theirs.imag) <= 1e-12 * theirs.imag


@pytest.mark.parametrize("f_ghz", F_GHZ)
@pytest.mark.parametrize("t_k", T_ICE)
def test_ice_against_smrt_hufford91(f_ghz, t_k):
    """pmmw's ``ice`` against `smrt.permittivity.ice.ice_permittivity_hufford91_maetzler87`
    (Hufford 1991's loss, stated to 1000 GHz and -40-0 C; Maetzler-Wegmueller 1987's eps'
    referred to 273.0 K). eps': the same 3.1884 + 9.1e-4 dT, apart from the 0.15 K reference
    offset: 2e-4 absolute. eps'': Maetzler 2006 keeps Hufford's alpha/f and refits beta with
    Mishima et al. 1983's data; ice-loss measurements at millimetre waves scatter by tens of per cent,
    so 20 % relative."""
    from smrt.permittivity.ice import ice_permittivity_hufford91_maetzler87

    from pmmw.scene.dielectric import MODELS

    ours = complex(MODELS["ice"].fn(f_ghz * 1e9, t_k))
    theirs = complex(ice_permittivity_hufford91_maetzler87(f_ghz * 1e9, t_k))
    assert ours.real == pytest.approx(theirs.real, abs=2e-4)
    assert ours.imag == pytest.approx(theirs.imag, rel=0.20)


# --- soil --------------------------------------------------------------------------------------


def _soil(f_ghz, sand, clay, mv, t_k=293.15) -> complex:
    """pmmw's ``soil`` with SMRT's fixed bulk and particle densities (1.3, 2.664 g/cm^3)."""
    from pmmw.scene.dielectric import make_dielectric

    return make_dielectric(
        {"name": "soil", "sand": sand, "clay": clay, "moisture": mv, "bulk_density": 1.3, "particle_density": 2.664}
    ).eps(f_ghz * 1e9, t_k)


# Textures whose Dobson sigma_2 is positive at rho_b 1.3 (for sandy soils it is negative, P.527's
# regression outside its data, and the two codes treat it differently): loam, silty clay, clay loam.
SOILS = [(40, 20), (10, 40), (30, 30)]


@pytest.mark.parametrize("sand, clay", SOILS)
@pytest.mark.parametrize("f_ghz", [10.0, 18.0])
@pytest.mark.parametrize("mv", [0.1, 0.2, 0.3])
def test_soil_against_smrt_dobson85_inside_its_fit(sand, clay, f_ghz, mv):
    """P.527-6 sec. 5.2 soil against `smrt.permittivity.soil.soil_permittivity_dobson85_original`
    (Dobson et al. 1985 with Peplinski 1995's eq. 8 sigma_2, sand and clay as fractions; Dobson's
    fit covers 1.4-18 GHz) at 10 and 18 GHz, where P.527's blend of sigma_1 into sigma_2 has
    become sigma_2 (within 2 %). The mixing is the same; SMRT's free water is Stogryn 1971's single
    Debye (eps_inf 4.9) for P.527's double Debye, and eps_solid 4.7 for P.527's 4.68. Below 20 GHz
    single- and double-Debye water agree to a few per cent, which the 0.65 exponent passes on at
    most whole: eps' within 5 %; eps'' carries the conductivity term and the water's loss: 10 %."""
    from smrt.permittivity.soil import soil_permittivity_dobson85_original

    ours = _soil(f_ghz, sand, clay, mv)
    theirs = complex(soil_permittivity_dobson85_original(f_ghz * 1e9, 293.15, mv, sand / 100, clay / 100))
    assert ours.real == pytest.approx(theirs.real, rel=0.05), (ours, theirs)
    assert ours.imag == pytest.approx(theirs.imag, rel=0.10), (ours, theirs)


@pytest.mark.parametrize("sand, clay", SOILS)
@pytest.mark.parametrize("mv", [0.1, 0.2, 0.3])
def test_soil_against_smrt_dobson85_extrapolated_to_35_ghz(sand, clay, mv):
    """The same comparison at 35 GHz, outside both fits: the two codes share the mixing equations,
    and the conductivity term (1/f) is by now small, so their difference is that of the free-water
    models, single Debye against double Debye, which grows above 20 GHz (the single Debye's
    eps_inf 4.9 against ~ 5.5-6 from the second relaxation at 35 GHz). This checks that pmmw
    extrapolates the same equations, not the physics: eps' within 10 %, eps'' within 20 %."""
    from smrt.permittivity.soil import soil_permittivity_dobson85_original

    ours = _soil(35.0, sand, clay, mv)
    theirs = complex(soil_permittivity_dobson85_original(35e9, 293.15, mv, sand / 100, clay / 100))
    assert ours.real == pytest.approx(theirs.real, rel=0.10), (ours, theirs)
    assert ours.imag == pytest.approx(theirs.imag, rel=0.20), (ours, theirs)
