"""ITU-R models of the clear and wet atmosphere, vectorized with numpy broadcasting.

* P.835-6: reference standard atmospheres (temperature, pressure, water vapour vs altitude).
* P.676-13 Annex 1: line-by-line specific attenuation of oxygen (+ dry continuum) and water
  vapour, 1-1000 GHz. Its Tables 1 and 2 are unchanged since P.676-11; `itur` 0.4 ("P.676-12")
  uses the same tables and equations.
* P.840-8: specific attenuation of cloud and fog liquid water (Rayleigh, double-Debye water).
* P.527-6 sec. 5.1: the permittivity of pure and sea water (the same double-Debye family with the
  temperature-dependent eps_inf of Liebe et al. 1991, and Meissner and Wentz's salinity terms),
  used by the soil and leaf models of `pmmw.scene.dielectric`.
* P.838-3: rain specific attenuation gamma_R = k R^alpha, and the Mie single-scattering albedo of
  rain (`pmmw.atmosphere.data.rain_albedo`) that splits it into absorption and scattering,
  with the asymmetry parameter of its scattering (`pmmw.atmosphere.data.rain_asymmetry`).
* P.453-14: radio refractivity (for the bending of sky rays).

Arguments are SI, ``f`` [Hz], ``p`` [Pa], ``T`` [K], ``rho`` [kg/m^3], heights [m], and may be
arrays of any broadcastable shapes (layers x frequencies, say); results have the broadcast shape.
Specific attenuations are returned in dB/km, the Recommendations' unit (``_db_km``); multiply by
`NP_M_PER_DB_KM` for the power attenuation coefficient [Np/m] used everywhere else. Rain rates
stay in mm/h (``_mm_h``). Pressures passed to the P.676 functions are the DRY air pressure
``p_dry = p - e``, as in the Recommendation (and in `itur`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from pmmw.arrays import FloatArray
from pmmw.atmosphere.data import p676, p838, rain_albedo, rain_asymmetry

if TYPE_CHECKING:  # scipy.interpolate is imported where it is used (~0.3 s)
    from scipy.interpolate import RegularGridInterpolator

NP_M_PER_DB_KM = np.log(10.0) / 10.0 / 1000.0  # [Np/m] per [dB/km] (power)

PROFILES = (
    "standard",
    "low_latitude",
    "mid_latitude_summer",
    "mid_latitude_winter",
    "high_latitude_summer",
    "high_latitude_winter",
)

# Tropopause altitude [m] of each profile: the top of its tropospheric temperature formula.
TROPOPAUSE_HEIGHT = {
    "standard": 11.0e3,
    "low_latitude": 17.0e3,
    "mid_latitude_summer": 13.0e3,
    "mid_latitude_winter": 10.0e3,
    "high_latitude_summer": 10.0e3,
    "high_latitude_winter": 8.5e3,
}

PROFILE_TOP = 100.0e3  # P.835 profiles are defined up to 100 km altitude [m]

# a scalar or an array, for the closed forms that keep their arguments' kind (no np.asarray)
FloatLike = float | FloatArray
ComplexLike = complex | npt.NDArray[np.complexfloating]

_OX = np.array(p676.OXYGEN_LINES, dtype=np.float64)  # (44, 7)
_WV = np.array(p676.WATER_VAPOUR_LINES, dtype=np.float64)  # (35, 7)


def water_vapour_pressure(rho: npt.ArrayLike, T: npt.ArrayLike) -> FloatArray:
    """Partial pressure of water vapour ``e = rho T / 216.7`` (P.835-6 eq. 8) [Pa].

    Parameters
    ----------
    rho : array_like
        Water-vapour density [kg/m^3].
    T : array_like
        Temperature [K].
    """
    return np.asarray(rho) * 1e3 * np.asarray(T) / 216.7 * 100.0


def _ghz_hpa(
    f: npt.ArrayLike, p_dry: npt.ArrayLike, rho: npt.ArrayLike, T: npt.ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Recommendation units: f [GHz], p [hPa], e [hPa], theta = 300/T; each with a line axis."""
    f_ghz = np.asarray(f, dtype=np.float64)[..., None] / 1e9
    p = np.asarray(p_dry, dtype=np.float64)[..., None] / 100.0
    T = np.asarray(T, dtype=np.float64)[..., None]
    e = np.asarray(rho, dtype=np.float64)[..., None] * 1e3 * T / 216.7
    return f_ghz, p, e, 300.0 / T


def oxygen_specific_attenuation_db_km(
    f: npt.ArrayLike, p_dry: npt.ArrayLike, rho: npt.ArrayLike, T: npt.ArrayLike
) -> FloatArray:
    """Specific attenuation of dry air, gamma_o [dB/km] (P.676-13 Annex 1 eqs. 1-8).

    The 44 oxygen lines of Table 1 plus the non-resonant Debye spectrum of oxygen and the
    pressure-induced nitrogen absorption.

    Parameters
    ----------
    f : array_like
        Frequency [Hz].
    p_dry : array_like
        Dry air pressure [Pa] (total pressure minus the water-vapour partial pressure).
    rho : array_like
        Water-vapour density [kg/m^3] (it broadens the oxygen lines).
    T : array_like
        Temperature [K].
    """
    f, p, e, theta = _ghz_hpa(f, p_dry, rho, T)
    f0, a1, a2, a3, a4, a5, a6 = _OX.T
    S = a1 * 1e-7 * p * theta**3 * np.exp(a2 * (1.0 - theta))  # eq. 3
    df = a3 * 1e-4 * (p * theta ** (0.8 - a4) + 1.1 * e * theta)  # eq. 6a
    df = np.sqrt(df**2 + 2.25e-6)  # eq. 6b: Zeeman splitting
    delta = (a5 + a6 * theta) * 1e-4 * (p + e) * theta**0.8  # eq. 7
    F = (f / f0) * (
        (df - delta * (f0 - f)) / ((f0 - f) ** 2 + df**2) + (df - delta * (f0 + f)) / ((f0 + f) ** 2 + df**2)
    )  # eq. 5
    f, p, e, theta = f[..., 0], p[..., 0], e[..., 0], theta[..., 0]
    d = 5.6e-4 * (p + e) * theta**0.8  # eq. 9
    N_D = (
        f * p * theta**2 * (6.14e-5 / (d * (1.0 + (f / d) ** 2)) + 1.4e-12 * p * theta**1.5 / (1.0 + 1.9e-5 * f**1.5))
    )  # eq. 8
    return 0.1820 * f * ((S * F).sum(axis=-1) + N_D)  # eqs. 1-2


def water_vapour_specific_attenuation_db_km(
    f: npt.ArrayLike, p_dry: npt.ArrayLike, rho: npt.ArrayLike, T: npt.ArrayLike
) -> FloatArray:
    """Specific attenuation of water vapour, gamma_w [dB/km] (P.676-13 Annex 1 eqs. 1-6).

    The 35 lines of Table 2, the last (1780 GHz) standing for the water-vapour continuum.
    Arguments as in `oxygen_specific_attenuation_db_km`.
    """
    f, p, e, theta = _ghz_hpa(f, p_dry, rho, T)
    f0, b1, b2, b3, b4, b5, b6 = _WV.T
    S = b1 * 1e-1 * e * theta**3.5 * np.exp(b2 * (1.0 - theta))  # eq. 3
    df = b3 * 1e-4 * (p * theta**b4 + b5 * e * theta**b6)  # eq. 6a
    df = 0.535 * df + np.sqrt(0.217 * df**2 + 2.1316e-12 * f0**2 / theta)  # eq. 6b: Doppler
    F = (f / f0) * (df / ((f0 - f) ** 2 + df**2) + df / ((f0 + f) ** 2 + df**2))  # eq. 5, delta = 0
    return 0.1820 * f[..., 0] * (S * F).sum(axis=-1)


def gas_specific_attenuation_db_km(
    f: npt.ArrayLike, p_dry: npt.ArrayLike, rho: npt.ArrayLike, T: npt.ArrayLike
) -> FloatArray:
    """Total gaseous specific attenuation gamma_o + gamma_w [dB/km]; arguments as above."""
    return oxygen_specific_attenuation_db_km(f, p_dry, rho, T) + water_vapour_specific_attenuation_db_km(
        f, p_dry, rho, T
    )


def double_debye(
    f_ghz: FloatLike,
    eps_s: FloatLike,
    eps_1: FloatLike,
    eps_inf: FloatLike,
    f_1: FloatLike,
    f_2: FloatLike,
) -> ComplexLike:
    """eps' + i eps'' (eps'' >= 0) of two Debye relaxations, P.840-8 eqs. 4-5 and P.527-6
    eqs. (6)-(7): eps_s static, eps_1 between them, eps_inf high-frequency, relaxation
    frequencies f_1, f_2 [GHz]; f_ghz [GHz]. Arrays broadcast."""
    eps_r = (eps_s - eps_1) / (1.0 + (f_ghz / f_1) ** 2) + (eps_1 - eps_inf) / (1.0 + (f_ghz / f_2) ** 2) + eps_inf
    eps_i = f_ghz * (eps_s - eps_1) / (f_1 * (1.0 + (f_ghz / f_1) ** 2)) + f_ghz * (eps_1 - eps_inf) / (
        f_2 * (1.0 + (f_ghz / f_2) ** 2)
    )
    return eps_r + 1j * eps_i


def water_permittivity(f: npt.ArrayLike, T: npt.ArrayLike) -> ComplexLike:
    """Relative permittivity of liquid water eps' + i eps'' (eps'' >= 0), P.840-8 eqs. 4-10.

    The double-Debye model of Liebe et al. (1991), valid to 1000 GHz.

    Parameters
    ----------
    f : array_like
        Frequency [Hz].
    T : array_like
        Water temperature [K].
    """
    f = np.asarray(f, dtype=np.float64) / 1e9
    theta = 300.0 / np.asarray(T, dtype=np.float64)  # eq. 9
    eps0 = 77.66 + 103.3 * (theta - 1.0)  # eq. 6
    eps1 = 0.0671 * eps0  # eq. 7
    eps2 = 3.52  # eq. 8
    fp = 20.20 - 146.0 * (theta - 1.0) + 316.0 * (theta - 1.0) ** 2  # eq. 10 [GHz]
    fs = 39.8 * fp  # eq. 11 [GHz]
    return double_debye(f, eps0, eps1, eps2, fp, fs)


def p527_water_permittivity(f: npt.ArrayLike, T: npt.ArrayLike, salinity: npt.ArrayLike = 0.0) -> ComplexLike:
    """Relative permittivity eps' + i eps'' (eps'' >= 0) of pure or saline water, P.527-6 sec. 5.1.

    Pure water (sec. 5.1.1, eqs. (6)-(13)) is Liebe et al. (1991)'s double Debye as P.840's, but
    with eps_inf = 3.52 - 7.52 theta (P.840-8 holds it at 3.52) and 146.4 for 146.0 in f_1; sea
    water (sec. 5.1.2, eqs. (14)-(27)) scales its parameters by Meissner and Wentz's salinity terms
    and adds the ionic conductivity of Stogryn et al. (1995), 18 sigma / f. Salinity 0 gives pure
    water exactly. The Recommendation states -4 to 40 C, salinity to 40 g/kg, to 1000 GHz.

    One coefficient differs from the Recommendation's print: eq. (18)'s t^3 term is -3.5594e-7, as
    in Meissner and Wentz's own code (Remote Sensing Systems' ocean emissivity model, coefficient
    -0.35594E-06), where P.527-6 prints +3.5594e-7 after Meissner and Wentz (2004)'s table. With
    the printed sign salt would raise the first relaxation frequency 1.7 times at 30 C (35 g/kg)
    and sea water's eps' at 35 GHz above pure water's (38.4 against 25.0), against Klein and Swift
    (1977) at L band and Stogryn et al. (1995) (tests/scene/test_materials_reference.py).

    Parameters
    ----------
    f : array_like
        Frequency [Hz].
    T : array_like
        Water temperature [K].
    salinity : array_like
        Salinity [g/kg] (per mil).
    """
    f = np.asarray(f, dtype=np.float64) / 1e9
    t = np.asarray(T, dtype=np.float64) - 273.15  # [C]
    s = np.asarray(salinity, dtype=np.float64)
    theta = 300.0 / (t + 273.15) - 1.0  # eq. (11)
    eps_s = 77.66 + 103.3 * theta  # eq. (8)
    eps_1 = 0.0671 * eps_s  # eq. (9)
    eps_inf = 3.52 - 7.52 * theta  # eq. (10)
    f_1 = 20.20 - 146.4 * theta + 316.0 * theta**2  # eq. (12) [GHz]
    f_2 = 39.8 * f_1  # eq. (13) [GHz]
    eps_ss = eps_s * np.exp(-3.33330e-3 * s + 4.74868e-6 * s**2)  # eq. (17)
    f_1s = f_1 * (
        1.0 + s * (2.3232e-3 - 7.9208e-5 * t + 3.6764e-6 * t**2 - 3.5594e-7 * t**3 + 8.9795e-9 * t**4)
    )  # eq. (18), the t^3 sign corrected (docstring)
    eps_1s = eps_1 * np.exp(-6.28908e-3 * s + 1.76032e-4 * s**2 - 9.22144e-5 * t * s)  # eq. (19)
    f_2s = f_2 * (1.0 + s * (-1.99723e-2 + 1.81176e-4 * t))  # eq. (20)
    eps_infs = eps_inf * (1.0 + s * (-2.04265e-3 + 1.57883e-4 * t))  # eq. (21)
    sigma_35 = 2.903602 + 8.607e-2 * t + 4.738817e-4 * t**2 - 2.991e-6 * t**3 + 4.3047e-9 * t**4  # eq. (23)
    r_15 = s * (37.5109 + 5.45216 * s + 1.4409e-2 * s**2) / (1004.75 + 182.283 * s + s**2)  # eq. (24)
    alpha_0 = (6.9431 + 3.2841 * s - 9.9486e-2 * s**2) / (84.850 + 69.024 * s + s**2)  # eq. (26)
    alpha_1 = 49.843 - 0.2276 * s + 0.198e-2 * s**2  # eq. (27)
    r_t15 = 1.0 + alpha_0 * (t - 15.0) / (alpha_1 + t)  # eq. (25)
    sigma_sw = sigma_35 * r_15 * r_t15  # eq. (22) [S/m]
    return double_debye(f, eps_ss, eps_1s, eps_infs, f_1s, f_2s) + 1j * 18.0 * sigma_sw / f  # eqs. (15)-(16)


def liquid_water_kl(f: npt.ArrayLike, T: npt.ArrayLike) -> FloatArray:
    """Cloud/fog liquid-water attenuation coefficient K_l [(dB/km)/(g/m^3)] (P.840-8 eq. 2).

    Rayleigh absorption by droplets << wavelength: gamma_c = K_l * M with M the liquid water
    content [g/m^3]. Strongly temperature dependent (at 95 GHz 4.60 at 0 C, 4.08 at 15 C).

    Parameters
    ----------
    f : array_like
        Frequency [Hz].
    T : array_like
        Temperature of the droplets [K].
    """
    eps = water_permittivity(f, T)
    eta = (2.0 + eps.real) / eps.imag  # eq. 3
    return 0.819 * (np.asarray(f, dtype=np.float64) / 1e9) / (eps.imag * (1.0 + eta**2))


def _p838_fit(table: tuple, x: FloatArray, log_k: bool) -> FloatArray:
    a, b, c, m, c0 = table
    s = sum(aj * np.exp(-(((x - bj) / cj) ** 2)) for aj, bj, cj in zip(a, b, c, strict=True))
    y = s + m * x + c0
    return 10.0**y if log_k else y


def rain_coefficients(f: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """P.838-3 coefficients ``(k_H, alpha_H, k_V, alpha_V)`` at frequency f [Hz] (eqs. 2-3).

    k is in (dB/km)/(mm/h)^alpha; alpha is dimensionless. Valid 1-1000 GHz.
    """
    x = np.log10(np.asarray(f, dtype=np.float64) / 1e9)
    return (
        _p838_fit(p838.K_H, x, True),
        _p838_fit(p838.ALPHA_H, x, False),
        _p838_fit(p838.K_V, x, True),
        _p838_fit(p838.ALPHA_V, x, False),
    )


def rain_specific_attenuation_db_km(
    rain_rate_mm_h: npt.ArrayLike, f: npt.ArrayLike, elevation: npt.ArrayLike = 0.0, tilt: npt.ArrayLike = np.pi / 4
) -> FloatArray:
    """Rain specific attenuation (extinction) gamma_R = k R^alpha [dB/km] (P.838-3 eqs. 1, 4, 5).

    Parameters
    ----------
    rain_rate_mm_h : array_like
        Rain rate R [mm/h].
    f : array_like
        Frequency [Hz].
    elevation : array_like
        Path elevation angle [rad].
    tilt : array_like
        Polarization tilt angle relative to the horizontal [rad]: 0 horizontal, pi/2 vertical;
        the default pi/4 (also circular polarization) gives the mean of H and V, which is what
        an unpolarized brightness sees.
    """
    kH, aH, kV, aV = rain_coefficients(f)
    w = np.cos(elevation) ** 2 * np.cos(2.0 * np.asarray(tilt))
    k = 0.5 * (kH + kV + (kH - kV) * w)  # eq. 4
    alpha = 0.5 * (kH * aH + kV * aV + (kH * aH - kV * aV) * w) / k  # eq. 5
    return k * np.asarray(rain_rate_mm_h, dtype=np.float64) ** alpha


def _rain_table(values: object) -> RegularGridInterpolator:
    """Bilinear interpolator in (log f [GHz], log R [mm/h]) on the Mie tables' grid."""
    from scipy.interpolate import RegularGridInterpolator

    return RegularGridInterpolator(
        (
            np.log(np.array(rain_albedo.FREQUENCY_GHZ, float)),
            np.log(np.array(rain_albedo.RAIN_RATE_MM_H, float)),
        ),
        np.array(values, dtype=np.float64),
    )


_TABLES: dict[
    str, RegularGridInterpolator
] = {}  # the interpolators, made on first use (scipy.interpolate: ~0.3 s to import)


def _table(name: str) -> RegularGridInterpolator:
    if name not in _TABLES:
        _TABLES[name] = _rain_table(rain_albedo.ALBEDO if name == "albedo" else rain_asymmetry.ASYMMETRY)
    return _TABLES[name]


def _rain_lookup(table: RegularGridInterpolator, f: npt.ArrayLike, rain_rate_mm_h: npt.ArrayLike) -> FloatArray:
    lf, lr = np.broadcast_arrays(
        np.log(np.asarray(f, dtype=np.float64) / 1e9), np.log(np.maximum(rain_rate_mm_h, 1e-12))
    )
    lo = [g[0] for g in table.grid]
    hi = [g[-1] for g in table.grid]
    pts = np.stack([np.clip(lf, lo[0], hi[0]), np.clip(lr, lo[1], hi[1])], axis=-1)
    return table(pts)


def rain_single_scattering_albedo(f: npt.ArrayLike, rain_rate_mm_h: npt.ArrayLike) -> FloatArray:
    """Single-scattering albedo of rain omega = scattering / extinction (Mie, Marshall-Palmer).

    Bilinear in (log f, log R) in the table of `pmmw.atmosphere.data.rain_albedo` (1-1000 GHz,
    0.5-200 mm/h; clamped to its edges outside). About 0.37 at 35 GHz and 0.50 at 95 GHz for
    10 mm/h.

    Parameters
    ----------
    f : array_like
        Frequency [Hz].
    rain_rate_mm_h : array_like
        Rain rate [mm/h].
    """
    return _rain_lookup(_table("albedo"), f, rain_rate_mm_h)


def rain_asymmetry_parameter(f: npt.ArrayLike, rain_rate_mm_h: npt.ArrayLike) -> FloatArray:
    """Asymmetry parameter of rain g = <cos Theta> of its scattering (Mie, Marshall-Palmer) [-].

    Bilinear in (log f, log R) in the table of `pmmw.atmosphere.data.rain_asymmetry`, same
    grid and clamping as `rain_single_scattering_albedo`. About -0.03 at 35 GHz and 0.27 at
    95 GHz for 10 mm/h.

    Parameters
    ----------
    f : array_like
        Frequency [Hz].
    rain_rate_mm_h : array_like
        Rain rate [mm/h].
    """
    return _rain_lookup(_table("asymmetry"), f, rain_rate_mm_h)


def rain_absorption_fraction(f: npt.ArrayLike, rain_rate_mm_h: npt.ArrayLike) -> FloatArray:
    """Fraction 1 - omega of rain extinction that is absorption [-]."""
    return 1.0 - rain_single_scattering_albedo(f, rain_rate_mm_h)


def refractivity(p: npt.ArrayLike, rho: npt.ArrayLike, T: npt.ArrayLike) -> FloatArray:
    """Radio refractivity N = (n - 1) 1e6 (P.453-14 eq. 6, ``N = 77.6/T (P + 4810 e/T)``).

    Parameters
    ----------
    p : array_like
        Total pressure [Pa].
    rho : array_like
        Water-vapour density [kg/m^3].
    T : array_like
        Temperature [K].
    """
    T = np.asarray(T, dtype=np.float64)
    e = water_vapour_pressure(rho, T) / 100.0
    return 77.6 / T * (np.asarray(p) / 100.0 + 4810.0 * e / T)


# --- P.835-6 reference atmospheres ----------------------------------------------------------
# Formulas in km, K, hPa, g/m^3 as in the Recommendation; converted at `reference_atmosphere`.


def _standard(h: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """P.835-6 sec. 1: mean annual global reference atmosphere (US Standard Atmosphere 1976)."""
    hp = 6356.766 * h / (6356.766 + h)  # geopotential height [km'] (eq. 1a)
    g = 34.1632
    T = np.select(
        [hp <= 11, hp <= 20, hp <= 32, hp <= 47, hp <= 51, hp <= 71, hp <= 84.852, h <= 91],
        [
            288.15 - 6.5 * hp,
            216.65 + 0 * hp,
            216.65 + (hp - 20),
            228.65 + 2.8 * (hp - 32),
            270.65 + 0 * hp,
            270.65 - 2.8 * (hp - 51),
            214.65 - 2.0 * (hp - 71),
            186.8673 + 0 * hp,
        ],
        263.1905 - 76.3232 * np.sqrt(np.clip(1 - ((h - 91) / 19.9429) ** 2, 0, None)),
    )
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        P = np.select(
            [hp <= 11, hp <= 20, hp <= 32, hp <= 47, hp <= 51, hp <= 71, hp <= 84.852],
            [
                1013.25 * (288.15 / (288.15 - 6.5 * hp)) ** (-g / 6.5),
                226.3226 * np.exp(-g * (hp - 11) / 216.65),
                54.74980 * (216.65 / (216.65 + (hp - 20))) ** g,
                8.680422 * (228.65 / (228.65 + 2.8 * (hp - 32))) ** (g / 2.8),
                1.109106 * np.exp(-g * (hp - 47) / 270.65),
                0.6694167 * (270.65 / (270.65 - 2.8 * (hp - 51))) ** (-g / 2.8),
                0.03956649 * (214.65 / (214.65 - 2.0 * (hp - 71))) ** (-g / 2.0),
            ],
            np.exp(95.571899 - 4.011801 * h + 6.424731e-2 * h**2 - 4.789660e-4 * h**3 + 1.340543e-6 * h**4),
        )
    rho = 7.5 * np.exp(-h / 2.0)  # eq. 6, rho_0 = 7.5 g/m^3, h_0 = 2 km
    return T, P, rho


def _upper_pressure(h: FloatArray, p_poly: list[float], k_mid: float, k_top: float) -> FloatArray:
    """P.835-6 sec. 2-4 pressure: polynomial to 10 km, then exponentials (continuous)."""
    p10 = np.polyval(p_poly, 10.0)
    p72 = p10 * np.exp(-k_mid * 62.0)
    return np.select(
        [h <= 10, h <= 72],
        [np.polyval(p_poly, h), p10 * np.exp(-k_mid * (h - 10))],
        p72 * np.exp(-k_top * (h - 72)),
    )


def _low_latitude(h: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    T = np.select(
        [h < 17, h < 47, h < 52, h < 80],
        [
            300.4222 - 6.3533 * h + 0.005886 * h**2,
            194 + (h - 17) * 2.533,
            270 + 0 * h,
            270 - (h - 52) * 3.0714,
        ],
        184.0,
    )
    P = _upper_pressure(h, [3.6316, -109.0338, 1012.0306], 0.147, 0.165)
    hw = np.minimum(h, 15.0)  # no overflow of the polynomial aloft
    rho = np.where(
        h <= 15,
        19.6542 * np.exp(-0.2313 * hw - 0.1122 * hw**2 + 0.01351 * hw**3 - 0.0005923 * hw**4),
        0.0,
    )
    return T, P, rho


def _mid_latitude_summer(h: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    T = np.select(
        [h < 13, h < 17, h < 47, h < 53, h < 80],
        [
            294.9838 - 5.2159 * h - 0.07109 * h**2,
            215.15 + 0 * h,
            215.15 * np.exp((h - 17) * 0.008128),
            275 + 0 * h,
            275 + 20 * (1 - np.exp((h - 53) * 0.06)),
        ],
        175.0,
    )
    P = _upper_pressure(h, [3.8646, -111.5569, 1012.8186], 0.147, 0.165)
    hw = np.minimum(h, 15.0)  # no overflow of the polynomial aloft
    rho = np.where(h <= 15, 14.3542 * np.exp(-0.4174 * hw - 0.02290 * hw**2 + 0.001007 * hw**3), 0.0)
    return T, P, rho


def _mid_latitude_winter(h: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    T = np.select(
        [h < 10, h < 33, h < 47, h < 53, h < 80],
        [
            272.7241 - 3.6217 * h - 0.1759 * h**2,
            218 + 0 * h,
            218 + (h - 33) * 3.3571,
            265 + 0 * h,
            265 - (h - 53) * 2.0370,
        ],
        210.0,
    )
    P = _upper_pressure(h, [4.8307, -124.2954, 1018.8627], 0.147, 0.155)
    hw = np.minimum(h, 10.0)  # no overflow of the polynomial aloft
    rho = np.where(h <= 10, 3.4742 * np.exp(-0.2697 * hw - 0.03604 * hw**2 + 0.0004489 * hw**3), 0.0)
    return T, P, rho


def _high_latitude_summer(h: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    T = np.select(
        [h < 10, h < 23, h < 48, h < 53, h < 79],
        [
            286.8374 - 4.7805 * h - 0.1402 * h**2,
            225 + 0 * h,
            225 * np.exp((h - 23) * 0.008317),
            277 + 0 * h,
            277 - (h - 53) * 4.0769,
        ],
        171.0,
    )
    P = _upper_pressure(h, [3.9408, -113.2494, 1008.0278], 0.140, 0.165)
    hw = np.minimum(h, 15.0)  # no overflow of the polynomial aloft
    rho = np.where(h <= 15, 8.988 * np.exp(-0.3614 * hw - 0.005402 * hw**2 - 0.001955 * hw**3), 0.0)
    return T, P, rho


def _high_latitude_winter(h: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    T = np.select(
        [h < 8.5, h < 30, h < 50, h < 54],
        [
            257.4345 + 2.3474 * h - 1.5479 * h**2 + 0.08473 * h**3,
            217.5 + 0 * h,
            217.5 + (h - 30) * 2.125,
            260 + 0 * h,
        ],
        260 - (h - 54) * 1.667,
    )
    P = _upper_pressure(h, [4.554, -122.2411, 1010.8828], 0.147, 0.150)
    hw = np.minimum(h, 10.0)  # no overflow of the polynomial aloft
    rho = np.where(h <= 10, 1.2319 * np.exp(0.07481 * hw - 0.0981 * hw**2 + 0.00281 * hw**3), 0.0)
    return T, P, rho


_PROFILE_FUNCS = {
    "standard": _standard,
    "low_latitude": _low_latitude,
    "mid_latitude_summer": _mid_latitude_summer,
    "mid_latitude_winter": _mid_latitude_winter,
    "high_latitude_summer": _high_latitude_summer,
    "high_latitude_winter": _high_latitude_winter,
}

MIXING_RATIO_FLOOR = 2e-6  # P.835-6 sec. 1.2: constant water-vapour mixing ratio e/P aloft


def reference_atmosphere(profile: str, h: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
    """P.835-6 reference profile at altitude h above sea level.

    "standard" is the mean annual global reference atmosphere (sec. 1) with rho_0 = 7.5 g/m^3 and
    a 2 km scale height, its water vapour held at a mixing ratio of 2e-6 where the exponential
    falls below it; the others are the latitude/season references of sec. 2-4 (no water vapour
    above 15 km, or 10 km in winter). Altitudes below 0 extrapolate the lowest formula.

    Parameters
    ----------
    profile : str
        One of `PROFILES`.
    h : array_like
        Altitude above sea level [m], at most `PROFILE_TOP`.

    Returns
    -------
    T : ndarray
        Temperature [K].
    p : ndarray
        Total pressure [Pa].
    rho : ndarray
        Water-vapour density [kg/m^3].
    """
    if profile not in _PROFILE_FUNCS:
        raise ValueError(f"unknown atmosphere profile {profile!r}; known: {', '.join(PROFILES)}")
    h_km = np.asarray(h, dtype=np.float64) / 1e3
    T, P, rho = _PROFILE_FUNCS[profile](h_km)
    if profile == "standard":
        rho = np.maximum(rho, MIXING_RATIO_FLOOR * P * 216.7 / T)
    return T, P * 100.0, rho * 1e-3
