"""ITU-R permittivity models of building materials (P.2040-4 Table 3) and vegetation (P.527-6 sec. 5.3).

Convention as in `pmmw.scene.dielectric`: time dependence exp(-i w t), eps = eps' + i eps'',
eps'' >= 0 is loss; frequency in Hz at the interface, in GHz inside the fits (suffix ``_ghz``).
Both Recommendations write eps' - i eps''; the values here are their conjugates.

P.2040 (Recommendation ITU-R P.2040-4, 09/2025, sec. 2.1.4 eqs. (58)-(59) and Table 3): each row of
Table 3 fits a material over one frequency range by

    eps' = a f^b,   sigma = c f^d [S/m],   f in GHz,
    eps'' = sigma / (2 pi f eps0) (= 17.98 sigma / f_GHz, eq. (9b)).

Edition 4 keeps every row of editions 2 (09/2021) and 3 (08/2023) and adds 100-450 GHz rows and
four materials (clear acrylic, vinyl tile, carpet tile, asphalt concrete). Several rows of one
material overlap (e.g. plasterboard 110-330 and 100-400 GHz, from different measurement sets); where
f lies in several, the row of narrowest range is used (the more specific fit; on a tie the one
listed first). Between two rows of a material (a gap, e.g. concrete 100-110 GHz), the value is
interpolated linearly in log f, eps' linearly and sigma log-linearly, between the two rows' values
at their facing edges, and flagged; outside every row, the row whose range is nearest in log f is
extrapolated with its power law, and flagged. The Recommendation calls the ranges indicative of the
measurements except for the three ground rows, which it states for 1-10 GHz only.

P.527 (Recommendation ITU-R P.527-6, 09/2021, sec. 5.3): vegetation of gravimetric moisture M_g
(water mass / wet mass), above freezing (sec. 5.3.1, Ulaby and El-Rayes 1987's dual dispersion
with P.527-6's pure water) and at or below 0 C (sec. 5.3.2); equation numbers as MathWorks'
``earthSurfacePermittivity`` (R2020a and later) transcribes them.
"""

from __future__ import annotations

import math

from pmmw.constants import EPS0

# ---------------------------------------------------------------------------------------------
# ITU-R P.2040-4 Table 3: material -> rows (a, b, c, d, f_lo [GHz], f_hi [GHz]), in the table's
# order. Rows shared with P.2040-2/-3 agree digit for digit in three transcriptions (see the tests);
# the rows first added in P.2040-4 rest on one transcription (Sionna RT, NVlabs/sionna-rt PR #70).
P2040_ROWS: dict[str, tuple[tuple[float, float, float, float, float, float], ...]] = {
    "concrete": ((5.24, 0.0, 0.0462, 0.7822, 1.0, 100.0), (5.17, 0.0, 0.0145, 1.0900, 110.0, 330.0)),
    "brick": ((3.91, 0.0, 0.0238, 0.16, 1.0, 40.0), (4.15, 0.0, 0.0006, 1.5712, 110.0, 330.0)),
    "plasterboard": (
        (2.73, 0.0, 0.0085, 0.9395, 1.0, 100.0),
        (2.56, 0.0, 0.0001, 1.7799, 110.0, 330.0),
        (2.65, 0.0, 0.0002, 1.598, 100.0, 400.0),
    ),
    "wood": (
        (1.99, 0.0, 0.0047, 1.0718, 0.001, 100.0),
        (1.82, 0.0, 0.0040, 1.0761, 110.0, 330.0),
        (2.1183, 0.0, 0.0055, 1.1113, 100.0, 400.0),
    ),
    "glass": (
        (6.31, 0.0, 0.0036, 1.3394, 0.1, 100.0),
        (5.79, 0.0, 0.0004, 1.658, 220.0, 450.0),
        (6.5767, 0.0, 0.0012, 1.4697, 100.0, 400.0),
    ),
    "clear_acrylic": ((2.58, 0.0, 0.0001, 1.6524, 110.0, 330.0),),
    "ceiling_board": (
        (1.48, 0.0, 0.0011, 1.0750, 1.0, 100.0),
        (1.52, 0.0, 0.0029, 1.029, 220.0, 450.0),
        (1.2567, 0.0, 0.00013, 1.454, 100.0, 400.0),
    ),
    "chipboard": ((2.58, 0.0, 0.0217, 0.7800, 1.0, 100.0), (2.16, 0.0, 0.0023, 1.359, 100.0, 200.0)),
    "plywood": (
        (2.71, 0.0, 0.33, 0.0, 1.0, 40.0),
        (1.94, 0.0, 0.0067, 0.9982, 110.0, 330.0),
        (2.17, 0.0, 0.0063, 1.045, 100.0, 400.0),
    ),
    "marble": (
        (7.074, 0.0, 0.0055, 0.9262, 1.0, 60.0),
        (7.94, 0.0, 0.0001, 1.7330, 110.0, 330.0),
        (8.62, 0.0, 0.0027, 1.15, 100.0, 400.0),
    ),
    "floorboard": (
        (3.66, 0.0, 0.0044, 1.3515, 50.0, 100.0),
        (5.27, 0.0, 2.22e-17, 7.3413, 220.0, 300.0),
        (5.27, 0.0, 0.0003, 2.0298, 300.0, 400.0),
        (5.27, 0.0, 49.8726, 0.0, 400.0, 450.0),
        (3.1575, 0.0, 0.001675, 1.32775, 100.0, 400.0),
    ),
    "vinyl_tile": ((3.62, 0.0, 0.0051, 0.8422, 1.0, 40.0),),
    "carpet_tile": ((2.08, 0.0, 0.0009, 0.8200, 1.0, 40.0),),
    "asphalt_concrete": ((4.83, 0.0, 0.0108, 1.3969, 1.0, 40.0),),
    # Not building materials, kept for completeness: a metal (use the `conductor` model for a real
    # one) and the three ground rows, which the Recommendation states for 1-10 GHz only.
    "metal": ((1.0, 0.0, 1e7, 0.0, 1.0, 100.0),),
    "very_dry_ground": ((3.0, 0.0, 0.00015, 2.52, 1.0, 10.0),),
    "medium_dry_ground": ((15.0, -0.1, 0.035, 1.63, 1.0, 10.0),),
    "wet_ground": ((30.0, -0.4, 0.15, 1.30, 1.0, 10.0),),
}

P2040_BUILDING_MATERIALS = tuple(
    m for m in P2040_ROWS if m not in ("metal", "very_dry_ground", "medium_dry_ground", "wet_ground")
)
P2040_HARD_LIMITED = ("very_dry_ground", "medium_dry_ground", "wet_ground")  # "1-10 GHz only" in Table 3
P2040_EDITION = "ITU-R P.2040-4 (09/2025), Table 3"


def _row_text(row: tuple[float, ...]) -> str:
    return f"{row[4]:g}-{row[5]:g} GHz"


def _row_values(row: tuple[float, ...], f_ghz: float) -> tuple[float, float]:
    """eps' and sigma [S/m] of one Table 3 row at f_ghz [GHz] (P.2040-4 eqs. (58)-(59))."""
    a, b, c, d = row[:4]
    return a * f_ghz**b, c * f_ghz**d


def _eps(eps_r: float, sigma: float, f_hz: float) -> complex:
    """eps' + i eps'' from eps' and sigma [S/m] at f_hz [Hz] (P.2040-4 eq. (9b))."""
    return complex(eps_r, sigma / (2.0 * math.pi * f_hz * EPS0))


def _rows(material: str) -> tuple[tuple[float, ...], ...]:
    try:
        return P2040_ROWS[material]
    except KeyError:
        raise KeyError(f"unknown ITU-R P.2040 material {material!r}; known: {', '.join(P2040_ROWS)}") from None


def p2040_valid_ranges(material: str) -> tuple[tuple[float, float], ...]:
    """The frequency ranges [Hz] of the Table 3 rows of ``material``, in the table's order.

    Parameters
    ----------
    material : str
        A key of `P2040_ROWS`, e.g. ``'concrete'``.

    Returns
    -------
    tuple of (float, float)
        (f_lo, f_hi) [Hz] per row; rows may overlap and leave gaps.
    """
    return tuple((row[4] * 1e9, row[5] * 1e9) for row in _rows(material))


def p2040_permittivity(f_hz: float, material: str) -> tuple[complex, str]:
    """Relative permittivity eps' + i eps'' of a P.2040-4 Table 3 material at one frequency.

    Parameters
    ----------
    f_hz : float
        Frequency [Hz], > 0.
    material : str
        A key of `P2040_ROWS`.

    Returns
    -------
    eps : complex
        eps' + i eps'', eps'' = sigma / (2 pi f eps0) >= 0.
    status : str
        ``'in row 1-100 GHz'`` inside a row (the narrowest one where rows overlap);
        ``'interpolated between rows 1-40 GHz and 110-330 GHz'`` in a gap between two rows of the
        material: eps' linear and log(sigma) linear in log f between the two rows' values at the
        gap's edges (so continuous at both edges); ``'extrapolated from row 1-10 GHz'`` outside
        every row: the row nearest in log f, its power law evaluated at f. Anything but
        ``'in row ...'`` deserves a warning; for the ground rows the Recommendation states
        1-10 GHz only, and the status says so.
    """
    rows = _rows(material)
    f_hz = float(f_hz)
    if not (math.isfinite(f_hz) and f_hz > 0.0):
        raise ValueError(f"frequency must be a positive finite number of Hz, got {f_hz!r}")
    f_ghz = f_hz / 1e9
    inside = [r for r in rows if r[4] <= f_ghz <= r[5]]
    if inside:
        row = min(inside, key=lambda r: math.log(r[5] / r[4]))  # min() keeps the first on a tie
        return _eps(*_row_values(row, f_ghz), f_hz), f"in row {_row_text(row)}"
    below = [r for r in rows if r[5] < f_ghz]
    above = [r for r in rows if r[4] > f_ghz]
    if below and above:
        lo = max(below, key=lambda r: r[5])  # the row ending nearest below f
        hi = min(above, key=lambda r: r[4])  # the row starting nearest above f
        f0, f1 = lo[5], hi[4]
        t = math.log(f_ghz / f0) / math.log(f1 / f0)
        e0, s0 = _row_values(lo, f0)
        e1, s1 = _row_values(hi, f1)
        eps_r = (1.0 - t) * e0 + t * e1
        sigma = math.exp((1.0 - t) * math.log(s0) + t * math.log(s1))
        return _eps(eps_r, sigma, f_hz), f"interpolated between rows {_row_text(lo)} and {_row_text(hi)}"
    row = max(below, key=lambda r: r[5]) if below else min(above, key=lambda r: r[4])
    status = f"extrapolated from row {_row_text(row)}"
    if material in P2040_HARD_LIMITED:
        status += " (the Recommendation states the ground rows for 1-10 GHz only)"
    return _eps(*_row_values(row, f_ghz), f_hz), status


# ---------------------------------------------------------------------------------------------
# ITU-R P.527-6 sec. 5.3: vegetation.
# Validity: Ulaby and El-Rayes (1987) measured 0.2-20 GHz and fitted M_g 0.05-0.7 (above freezing);
# MathWorks' transcription accepts M_g 0-0.7 and T >= -20 C; the pure-water model it calls is stated
# for -4 to 40 C. Outside these the value is still computed (the caller warns).
P527_VEGETATION_F_RANGE = (0.2e9, 20e9)  # [Hz] the measurements behind both fits
P527_VEGETATION_MOISTURE_RANGE = (0.05, 0.7)  # gravimetric moisture M_g [1]
P527_VEGETATION_T_RANGE = (253.15, 313.15)  # [K]: -20 C (below-freezing fit) to 40 C (pure water)
# Where the fits were found physical here (eps' >= 1, eps'' >= 0 at 1-450 GHz; tests): above 0 C
# for M_g >= 0.1; frozen from -20 C to T_f = -6.5 C for M_g >= 0.2. Between T_f and 0 C the frozen
# fit's volume fractions grow as exp(0.72 Delta) and eps exceeds pure water's (73 + 44i at 0 C,
# 10 GHz, M_g 0.5, against 9.7 + 5.6i just above 0 C): a judgement from the numbers, not a range
# the Recommendation states (its text was not available here).
P527_VEGETATION_T_RANGE_FROZEN_PHYSICAL = (253.15, 266.65)  # [K]
P527_VEGETATION_MOISTURE_MIN_LOSSY = {"thawed": 0.1, "frozen": 0.2}  # M_g below which eps'' < 0 occurs
P527_VEGETATION_T_FREEZE = 273.15  # [K]: at or below, sec. 5.3.2; above, sec. 5.3.1
P527_VEGETATION_T_F = -6.5  # [C] the reference temperature T_f of sec. 5.3.2


def _p527_f1(T: float) -> float:
    """Relaxation frequency f_1 [GHz] of pure water, P.527-6 eqs. (11)-(12); T [K]."""
    theta = 300.0 / T - 1.0
    return 20.20 - 146.4 * theta + 316.0 * theta**2


def _vegetation_above(f_ghz: float, T: float, mg: float) -> complex:
    """P.527-6 sec. 5.3.1, eqs. (72)-(77), as eps' + i eps''."""
    from pmmw.atmosphere.itu import p527_water_permittivity

    eps_dv = 1.7 - 0.74 * mg + 6.16 * mg**2  # eq. (75): dry vegetation
    v_fw = mg * (0.55 * mg - 0.076)  # eq. (76): free-water volume fraction
    v_bw = 4.64 * mg**2 / (1.0 + 7.36 * mg**2)  # eq. (77): bound-water volume fraction
    eps_pw = complex(p527_water_permittivity(f_ghz * 1e9, T, 0.0))  # sec. 5.1.1, eps'' >= 0
    f_1 = _p527_f1(T)
    s = math.sqrt(f_ghz / (0.02 * f_1))  # bound water: 55 / (1 + sqrt(i f / (0.01 f_1)))
    den = 1.0 + 2.0 * s + f_ghz / (0.01 * f_1)
    eps_r = eps_dv + v_fw * eps_pw.real + v_bw * (2.9 + 55.0 * (1.0 + s) / den)  # eq. (73)
    eps_i = v_fw * (eps_pw.imag + 22.86 / f_ghz) + v_bw * 55.0 * s / den  # eq. (74); 22.86 = 18 x 1.27 S/m
    return complex(eps_r, eps_i)


def _vegetation_below(f_ghz: float, T: float, mg: float) -> complex:
    """P.527-6 sec. 5.3.2, eqs. (78)-(89), as eps' + i eps''."""
    delta = (T - 273.15) - P527_VEGETATION_T_F  # [C]
    c1 = f_ghz / 1.2582
    c2 = 0.2054
    c3 = 0.4108
    den = 1.0 + 2.0 * c1**c2 * math.cos(c2 * math.pi / 2.0) + c1**c3
    x1 = (1.0 + c1**c2 * math.cos(c2 * math.pi / 2.0)) / den  # bound water, Cole-Cole
    y1 = c1**c2 * math.sin(c2 * math.pi / 2.0) / den
    a_ice = 0.001 - 0.012 * mg + 0.0082 * mg**2
    b_ice = 0.036 - 0.2389 * mg + 0.1435 * mg**2
    c_ice = -0.0538 + 0.4616 * mg - 0.3398 * mg**2
    v_ice = a_ice * delta**2 + b_ice * delta + c_ice
    eps_dv = 6.76 - 10.24 * mg + 6.19 * mg**2
    v_fw = (-0.106 + 0.6591 * mg - 0.610 * mg**2) * math.exp((0.06 + 0.6883 * mg + 0.0001 * mg**2) * delta)
    v_bw = (-0.16 + 1.1876 * mg - 0.387 * mg**2) * math.exp((0.721 - 1.2733 * mg + 0.8139 * mg**2) * delta)
    c4 = f_ghz / 9.0
    c5 = 82.2 / (1.0 + c4**2)  # free water, Debye at 9 GHz
    eps_r = eps_dv + v_fw * (4.9 + c5) + v_bw * (8.092 + 14.2067 * x1) + 3.15 * v_ice  # eq. (78)
    eps_i = v_fw * (c4 * c5 + 11.394 / f_ghz) + 14.2067 * v_bw * y1  # eq. (79)
    return complex(eps_r, eps_i)


def p527_vegetation_permittivity(f_hz: float, T_kelvin: float, gravimetric_moisture: float) -> complex:
    """Relative permittivity eps' + i eps'' of vegetation, ITU-R P.527-6 sec. 5.3.

    Parameters
    ----------
    f_hz : float
        Frequency [Hz], > 0.
    T_kelvin : float
        Temperature [K]; above 273.15 K sec. 5.3.1 (with P.527-6's pure water,
        `pmmw.atmosphere.itu.p527_water_permittivity`), at or below it sec. 5.3.2. The two fits
        do not meet at 0 C: the frozen fit grows without physical bound between T_f = -6.5 C and
        0 C (see `P527_VEGETATION_T_RANGE_FROZEN_PHYSICAL`), so eps jumps by a factor of about 7 at
        0 C (M_g 0.5, 10 GHz).
    gravimetric_moisture : float
        M_g, water mass over wet mass [1].

    Returns
    -------
    complex
        eps' + i eps''. Stated ranges: `P527_VEGETATION_F_RANGE`, `P527_VEGETATION_MOISTURE_RANGE`,
        `P527_VEGETATION_T_RANGE`; outside them the value is computed all the same. Above freezing
        the free-water fraction M_g (0.55 M_g - 0.076) is negative below M_g = 0.138, and at
        millimetre waves eps'' then turns negative (a gain) below about M_g = 0.09 (frozen: below
        about 0.2): the caller must reject or clamp it.
    """
    f_ghz = float(f_hz) / 1e9
    T = float(T_kelvin)
    mg = float(gravimetric_moisture)
    if T > P527_VEGETATION_T_FREEZE:
        return _vegetation_above(f_ghz, T, mg)
    return _vegetation_below(f_ghz, T, mg)
