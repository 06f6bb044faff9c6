"""ITU-R atmosphere equations (`pmmw.atmosphere.itu`) against `itur`, PHYSICS.md and Murakowski 2014.

`itur` 0.4 is an independent implementation of the same Recommendations (P.676-12, P.835-6,
P.840, P.838-3): where the equations and tables are the same, the agreement must be to rounding,
so those tolerances are tight and catch any transcription error in our tables. The numbers quoted
in PHYSICS.md are rounded to 3-4 digits and are checked to that rounding. The seed's tables come
from other models and are checked to what their own spread allows.
"""

from __future__ import annotations

import numpy as np
import pytest

from pmmw.atmosphere import Atmosphere, AtmosphereLayer, AtmosphereModel, itu
from pmmw.atmosphere.model import atmosphere_profile

GHZ = 1e9
SAME_EQUATIONS_RTOL = 1e-6  # same equations and tables, float64 rounding only

# (total pressure [hPa], rho [g/m^3], T [K]) states spanning the lower atmosphere
STATES = [
    (1013.25, 7.5, 288.15),
    (540.5, 0.61, 255.7),
    (1018.9, 3.47, 272.7),
    (1012.0, 19.65, 300.4),
    (100.0, 0.0, 216.65),
]


def _itur():
    return pytest.importorskip("itur")


def _q(x):
    """Plain float array of an itur result (astropy Quantity or ndarray)."""
    return np.asarray(getattr(x, "value", x), dtype=np.float64)


# --- P.676 gases ------------------------------------------------------------------------------


def test_gas_sea_level_matches_physics_md():
    # PHYSICS.md: 0.100 dB/km at 35 GHz and 0.412 at 95 GHz, P.835 standard surface (7.5 g/m^3);
    # quoted to 3 decimals, so agreement to 0.0006 dB/km
    T, p, rho = itu.reference_atmosphere("standard", 0.0)
    assert (float(T), float(p), float(rho)) == pytest.approx((288.15, 101325.0, 7.5e-3))
    e = itu.water_vapour_pressure(rho, T)
    gamma = itu.gas_specific_attenuation_db_km(np.array([35, 95]) * GHZ, p - e, rho, T)
    print(f"gas at sea level: 35 GHz {gamma[0]:.4f} dB/km, 95 GHz {gamma[1]:.4f} dB/km")
    np.testing.assert_allclose(gamma, [0.100, 0.412], atol=6e-4)
    # the model evaluates each cell at its midpoint (5 m up): 0.5 % is the gradient over 5 m
    for f, ref in ((35 * GHZ, 0.100), (95 * GHZ, 0.412)):
        assert AtmosphereModel(Atmosphere(), f).specific_attenuation_db_km(0.0) == pytest.approx(ref, rel=5e-3)


def test_gas_matches_itur_p676_10_to_350_ghz():
    itur = _itur()
    from itur.models import itu676

    # itur 0.4 implements P.676-12 by default; its Annex 1 tables equal P.676-13's (ours)
    assert itu676.get_version() == 12
    f = np.arange(10.0, 350.5, 0.5)
    for P, rho, T in STATES:
        e = rho * T / 216.7
        # itur's P.676 functions take the DRY pressure P - e [hPa]
        ref_o = _q(itur.models.itu676.gamma0_exact(f, P - e, rho, T))
        ref_w = _q(itur.models.itu676.gammaw_exact(f, P - e, rho, T))
        ours_o = itu.oxygen_specific_attenuation_db_km(f * GHZ, (P - e) * 100.0, rho * 1e-3, T)
        ours_w = itu.water_vapour_specific_attenuation_db_km(f * GHZ, (P - e) * 100.0, rho * 1e-3, T)
        np.testing.assert_allclose(ours_o, ref_o, rtol=SAME_EQUATIONS_RTOL)
        np.testing.assert_allclose(ours_w, ref_w, rtol=SAME_EQUATIONS_RTOL, atol=1e-300)


def test_gas_broadcasts_over_layers_and_frequencies():
    f = np.array([35.0, 60.0, 95.0]) * GHZ
    T, p, rho = itu.reference_atmosphere("standard", np.array([0.0, 1e3, 5e3, 20e3]))
    e = itu.water_vapour_pressure(rho, T)
    table = itu.gas_specific_attenuation_db_km(f[None, :], (p - e)[:, None], rho[:, None], T[:, None])
    assert table.shape == (4, 3)
    for i in range(4):
        for j in range(3):
            assert table[i, j] == pytest.approx(
                itu.gas_specific_attenuation_db_km(f[j], p[i] - e[i], rho[i], T[i]), rel=1e-12
            )


# --- P.840 liquid water -----------------------------------------------------------------------


def test_liquid_water_kl_matches_physics_md():
    # PHYSICS.md, (dB/km)/(g/m^3), quoted to 3-4 significant digits: 0.2 % covers the rounding
    f = np.array([35, 35, 95, 95]) * GHZ
    T = np.array([273.15, 288.15, 273.15, 288.15])
    kl = itu.liquid_water_kl(f, T)
    print("K_l 35 GHz 0/15 C, 95 GHz 0/15 C:", np.round(kl, 4))
    np.testing.assert_allclose(kl, [1.019, 0.706, 4.60, 4.08], rtol=2e-3)


def test_liquid_water_kl_matches_itur_p840():
    _itur()
    from itur.models import itu840

    f = np.arange(10.0, 351.0, 5.0)
    for t_c in (-10.0, 0.0, 15.0, 30.0):
        ref = _q(itu840.specific_attenuation_coefficients(f, t_c))  # itur takes T in deg C
        np.testing.assert_allclose(itu.liquid_water_kl(f * GHZ, t_c + 273.15), ref, rtol=SAME_EQUATIONS_RTOL)


def test_water_permittivity_sign_convention():
    eps = itu.water_permittivity(np.array([35e9, 95e9]), 293.15)
    assert np.all(eps.imag > 0.0) and np.all(eps.real > 1.0)  # eps'' >= 0 for a lossy medium


def test_fog_matches_seed_table_3_2():
    """Seed 000 Table 3.2: fog 0-600 m of 0.3 and 1.0 g/m^3, dB/km at 35 and 95 GHz.

    The table's attenuations include the clear-air part of its "Cloudy" row (0.17 / 0.92 dB/km),
    so we compare our fog alone plus that row. Fog attenuation depends strongly on the droplets'
    temperature; we take the P.835 standard surface temperature 15 C (288.15 K), which is also the
    288 K of every object of that scenario (Table 3.1). The seed's rows are not consistent with a
    single temperature (fog alone they imply K_l(95 GHz) = 4.57, i.e. 0 C, at 0.3 g/m^3 but 4.13,
    i.e. 15 C, at 1.0 g/m^3): 7 % is that spread in the totals.
    """
    cloudy = {35: 0.17, 95: 0.92}
    table = {(35, 0.3): 0.40, (95, 0.3): 2.29, (35, 1.0): 0.88, (95, 1.0): 5.05}
    for (f_ghz, lwc_g_m3), ref in table.items():
        clear = AtmosphereModel(Atmosphere(), f_ghz * GHZ)
        fog = AtmosphereModel(
            Atmosphere(layers=(AtmosphereLayer("fog", 0.0, 600.0, liquid_water=lwc_g_m3 * 1e-3),)),
            f_ghz * GHZ,
        )
        fog_alone = fog.specific_attenuation_db_km(0.0) - clear.specific_attenuation_db_km(0.0)
        ours = cloudy[f_ghz] + fog_alone
        print(f"fog {lwc_g_m3} g/m3 at {f_ghz} GHz: ours {ours:.3f} dB/km, seed {ref}")
        assert ours == pytest.approx(ref, rel=0.07)


# --- P.838 rain -------------------------------------------------------------------------------


def test_rain_matches_physics_md():
    # PHYSICS.md: 10 mm/h, P.838-3, H / V: 2.71 / 2.42 at 35 GHz, 6.46 / 6.37 at 95 GHz (3 digits)
    f = np.array([35.0, 95.0]) * GHZ
    h = itu.rain_specific_attenuation_db_km(10.0, f, 0.0, 0.0)
    v = itu.rain_specific_attenuation_db_km(10.0, f, 0.0, np.pi / 2)
    print("rain 10 mm/h H:", np.round(h, 3), "V:", np.round(v, 3))
    np.testing.assert_allclose(h, [2.71, 6.46], atol=6e-3)
    np.testing.assert_allclose(v, [2.42, 6.37], atol=6e-3)
    # unpolarized (tilt 45 deg) is the H/V mean of k, whatever the elevation
    mean = itu.rain_specific_attenuation_db_km(10.0, f, np.radians(30.0))
    assert np.all((mean > v) & (mean < h))


def test_rain_matches_itur_p838():
    itur = _itur()
    from itur.models import itu838

    assert itu838.get_version() == 3
    f = np.arange(10.0, 351.0, 10.0)
    for el in (0.0, 30.0, 60.0):
        for tau in (0.0, 45.0, 90.0):
            for R in (1.0, 10.0, 50.0):
                # itur's P.838 takes one frequency at a time
                ref = [float(_q(itur.models.itu838.rain_specific_attenuation(R, fi, el, tau))) for fi in f]
                ours = itu.rain_specific_attenuation_db_km(R, f * GHZ, np.radians(el), np.radians(tau))
                np.testing.assert_allclose(ours, ref, rtol=SAME_EQUATIONS_RTOL)


def test_rain_against_seed_table_3_5():
    # Seed 000 Table 3.5 (Olsen et al. 1978, 20 C): A = a R^b at 10 mm/h, 2.4 dB/km at 35 GHz,
    # 5.9 at 95 GHz. P.838-3 (2005) is a later fit: at 35 GHz its V value is within 2 % and the
    # unpolarized one within 8 %; at 95 GHz Olsen's fit is ~8 % below P.838.
    f = np.array([35.0, 95.0]) * GHZ
    seed = np.array([0.235 * 10**1.009, 1.06 * 10**0.745])
    np.testing.assert_allclose(seed, [2.4, 5.9], atol=0.05)
    v = itu.rain_specific_attenuation_db_km(10.0, f, 0.0, np.pi / 2)
    mean = itu.rain_specific_attenuation_db_km(10.0, f)
    print(
        "rain 10 mm/h, seed:",
        np.round(seed, 3),
        "P.838 V:",
        np.round(v, 3),
        "unpolarized:",
        np.round(mean, 3),
    )
    assert v[0] == pytest.approx(seed[0], rel=0.02)
    assert mean[0] == pytest.approx(seed[0], rel=0.08)
    assert mean[1] == pytest.approx(seed[1], rel=0.12)


def test_rain_albedo_matches_physics_md():
    # PHYSICS.md: single-scattering albedo 0.37 at 35 GHz and 0.50 at 95 GHz (10 mm/h, 2 digits)
    omega = itu.rain_single_scattering_albedo(np.array([35e9, 95e9]), 10.0)
    np.testing.assert_allclose(omega, [0.37, 0.50], atol=0.005)
    np.testing.assert_allclose(itu.rain_absorption_fraction(np.array([35e9, 95e9]), 10.0), 1.0 - omega)
    # more rain = bigger drops = more scattering; clamped outside the table
    assert np.all(np.diff(itu.rain_single_scattering_albedo(35e9, np.array([1.0, 5.0, 20.0, 100.0]))) > 0)
    assert itu.rain_single_scattering_albedo(2e12, 500.0) == pytest.approx(
        itu.rain_single_scattering_albedo(1e12, 200.0)
    )


def test_rain_albedo_table_matches_mie():
    """Re-derive table entries with an independent Mie code (miepython, m = n - ik convention)."""
    miepython = pytest.importorskip("miepython")
    D = np.linspace(0.01, 10.0, 2000)  # drop diameters [mm]
    for f_ghz, R in ((35.0, 10.0), (95.0, 1.0), (20.0, 50.0)):
        lam_mm = 299.792458 / f_ghz
        n = np.sqrt(itu.water_permittivity(f_ghz * GHZ, 293.15))
        qext, qsca, _, _ = miepython.efficiencies(np.conj(n), D, lam_mm)
        w = 8000.0 * np.exp(-4.1 * R**-0.21 * D) * D**2  # Marshall-Palmer N(D) x cross-section
        omega = np.trapezoid(w * qsca, D) / np.trapezoid(w * qext, D)
        # table rounded to 4 digits, tabulated with 4000 diameters
        assert itu.rain_single_scattering_albedo(f_ghz * GHZ, R) == pytest.approx(omega, abs=1e-3)


# --- P.835 profiles ---------------------------------------------------------------------------

_ITUR_PROFILES = {
    "low_latitude": (10.0, "summer"),
    "mid_latitude_summer": (30.0, "summer"),
    "mid_latitude_winter": (30.0, "winter"),
    "high_latitude_summer": (60.0, "summer"),
    "high_latitude_winter": (60.0, "winter"),
}


@pytest.mark.filterwarnings("ignore:overflow encountered in exp:RuntimeWarning")  # inside itur, aloft
def test_p835_profiles_match_itur():
    _itur()
    from itur.models import itu835

    h_km = np.array([0.0, 0.5, 1.0, 2.0, 5.0, 8.0, 10.0, 12.0, 15.0, 20.0, 30.0, 50.0, 70.0, 80.0, 90.0, 99.0])
    for name, (lat, season) in _ITUR_PROFILES.items():
        T, p, rho = itu.reference_atmosphere(name, h_km * 1e3)
        np.testing.assert_allclose(T, _q(itu835.temperature(lat, h_km, season)), rtol=1e-12)
        # itur rounds the 72 km pressure constant of the low-latitude profile to 6 digits
        np.testing.assert_allclose(p / 100.0, _q(itu835.pressure(lat, h_km, season)), rtol=1e-5)
        np.testing.assert_allclose(
            rho * 1e3, _q(itu835.water_vapour_density(lat, h_km, season)), rtol=1e-12, atol=1e-12
        )
    T, p, rho = itu.reference_atmosphere("standard", h_km * 1e3)
    np.testing.assert_allclose(T, _q(itu835.standard_temperature(h_km)), rtol=1e-12)
    np.testing.assert_allclose(p / 100.0, _q(itu835.standard_pressure(h_km)), rtol=1e-12)
    # water vapour: 7.5 exp(-h/2) g/m^3 until the mixing ratio reaches its 2e-6 floor (~15 km)
    exponential = _q(itu835.standard_water_vapour_density(h_km))
    low = h_km <= 12.0
    np.testing.assert_allclose(rho[low] * 1e3, exponential[low], rtol=1e-12)
    floor = itu.MIXING_RATIO_FLOOR * (p / 100.0) * 216.7 / T * 1e-3  # [kg/m^3]
    np.testing.assert_allclose(rho[~low], np.maximum(exponential[~low] * 1e-3, floor[~low]), rtol=1e-12)


def test_p835_standard_mixing_ratio_floor():
    T, p, rho = itu.reference_atmosphere("standard", np.array([30e3, 50e3, 80e3]))
    e = itu.water_vapour_pressure(rho, T)
    np.testing.assert_allclose(e / p, itu.MIXING_RATIO_FLOOR, rtol=1e-12)


def test_unknown_profile_lists_the_known_ones():
    with pytest.raises(ValueError, match="mid_latitude_summer"):
        itu.reference_atmosphere("tropical", 0.0)
    with pytest.raises(ValueError, match="standard"):
        Atmosphere(profile="arctic")


def test_ground_overrides():
    z = np.array([0.0, 1e3, 5e3, 11e3, 15e3])
    T0, p0, rho0 = atmosphere_profile(Atmosphere(), z)
    T, p, rho = atmosphere_profile(Atmosphere(ground_temperature=298.15, humidity=15e-3), z)
    assert T[0] == pytest.approx(298.15)
    # the shift tapers linearly to zero at the tropopause (11 km); pressure is untouched
    np.testing.assert_allclose(T - T0, 10.0 * np.clip(1 - z / 11e3, 0, 1), atol=1e-9)
    np.testing.assert_allclose(p, p0)
    assert rho[0] == pytest.approx(15e-3)
    np.testing.assert_allclose(rho[:3] / rho0[:3], 2.0)
    # a scene on a plateau starts its profile at its altitude
    T_alt, p_alt, _ = atmosphere_profile(Atmosphere(ground_altitude=1500.0), 0.0)
    T_ref, p_ref, _ = itu.reference_atmosphere("standard", 1500.0)
    assert (float(T_alt), float(p_alt)) == pytest.approx((float(T_ref), float(p_ref)))
