"""Physical permittivity models for material entries (``model: {name: water}`` in the database).

A tabulated entry (``eps: {35 GHz: ..., 95 GHz: ...}``) holds measured values at a few
frequencies; a model entry computes eps' + i eps'' at any frequency of its valid range and at the
material's own temperature. Each model states its source and its range; outside it the value is
still computed and `Material.eps_at` warns.

Registry (`MODELS`, chosen by ``model.name``):

* ``water``: liquid water, the double-Debye model of Liebe, Hufford and Manabe (1991) as ITU-R
  P.840-8 eqs. 4-10 give it (the same code as the atmosphere's fog and cloud,
  `pmmw.atmosphere.itu.water_permittivity`); 1-1000 GHz, 263-373 K.
* ``pure_water``, ``sea_water``: liquid water by ITU-R P.527-6 sec. 5.1
  (`pmmw.atmosphere.itu.p527_water_permittivity`): pure water (sec. 5.1.1), and saline water
  of ``salinity`` [g/kg] (sec. 5.1.2, default 35 g/kg, the open ocean's); the Recommendation
  states -4 to 40 C, 0-40 g/kg, to 1000 GHz.
* ``ice``: pure ice, Maetzler (2006) (Hufford 1991 with the Mishima et al. 1983 correction):
  eps' = 3.1884 + 9.1e-4 (T - 273.15), eps'' = alpha / f + beta f with f in GHz; 0.01-3000 GHz,
  20-273.15 K.
* ``conductor``: a metal of conductivity sigma [S/m] (``conductivity``), eps = 1 + i sigma /
  (eps0 omega): its Fresnel reflection gives the small emissivity of a real metal (Hagen-Rubens,
  e = sqrt(8 eps0 omega / sigma) at normal incidence) instead of a perfect mirror's zero. Valid
  while omega is far below the metal's collision frequency (~1e13 /s): to 1000 GHz. Use it with
  ``kind: opaque`` (reflection, the rest absorbed within a skin depth).
* ``skin_dry``, ``skin_wet``: human skin, the four-term Cole-Cole model of Gabriel, Lau and
  Gabriel (1996) with the 'skin (dry)' and 'skin (wet)' parameters of their Table 1
  (`GABRIEL_1996`): eps = eps_inf + sum_n d_eps_n / (1 + (i omega tau_n)^(1 - alpha_n)) +
  sigma_i / (i eps0 omega), in their exp(+i w t) form, conjugated here. Stated for 10 Hz-100 GHz;
  above 20 GHz the fit rests on survey data (their own measurements stop at 20 GHz), and Sasaki,
  Wake and Watanabe (2014) measured epidermis and dermis above it at 20-100 GHz. The tissue is at
  body temperature (37 C): eps does not follow the material's temperature, which only sets its
  emission; 298-313 K (living skin) is the stated range.
* ``leaves``: fresh leaves, Maetzler (1994): eps = 0.522 (1 - 1.32 md) eps_sw + 0.51 + 3.84 md,
  md the dry-matter mass fraction (``dry_matter``; gravimetric moisture 1 - md), eps_sw the leaf
  sap as saline water (``salinity`` [g/kg], default 10) at the leaf's temperature, here by ITU-R
  P.527-6 sec. 5.1.2 (`pmmw.atmosphere.itu.p527_water_permittivity`). Stated for 1-100 GHz
  (Maetzler's measurements); extrapolated above, with a warning. The formula's water term
  changes sign at md = 1/1.32, so md is limited to 0-0.75.
* ``soil``: mineral soil, ITU-R P.527-6 sec. 5.2 (`_soil`): the Dobson et al. (1985) mixing model
  with Peplinski et al. (1995)'s conductivities, free water by P.527-6's pure water; ``sand``,
  ``clay`` [%] (silt the rest), volumetric ``moisture`` [1], ``bulk_density`` [g/cm^3] (default
  P.527-6 eq. (57)), ``particle_density`` [g/cm^3] (default 2.66). The mixing exponents were
  fitted at 1.4-18 GHz (Dobson et al.) and the conductivities at 0.3-1.3 GHz (Peplinski et al.);
  the Recommendation applies the model to 1000 GHz (the limit of MathWorks'
  ``earthSurfacePermittivity``, an implementation of P.527-6), and so does pmmw: at millimetre
  waves the free water's double Debye carries the frequency dependence, the conductivity terms
  fall as 1/f.
* ``p2040``: a building material of ITU-R P.2040-4 Table 3 (``material``: concrete, brick, glass,
  ...; `pmmw.scene.itu_materials`): each row's power laws inside its range; between rows
  interpolated, outside every row extrapolated, both warned.
* ``vegetation``: ITU-R P.527-6 sec. 5.3 by ``gravimetric_moisture`` (0.1-0.7; below 0.1 the fit
  gives a gain at millimetre waves), above and at or below 0 C (between -6.5 and 0 C the frozen
  fit is unbounded: warned); measured at 0.2-20 GHz, applied by the Recommendation to 1000 GHz.

* ``debye``: a sum of Debye relaxations with ionic conduction, with the parameters and the valid
  range the entry states (a published fit entered as it is printed): eps = eps_inf + sum_k d_eps_k
  / (1 - i omega tau_k) + i sigma / (eps0 omega) (exp(-i w t); Debye 1929, as the double-Debye
  fits of water and tissue at millimetre and terahertz waves are written). ``eps_inf`` [1],
  ``terms`` (a list of ``[d_eps, tau]``, tau with its unit: '8 ps'), optional ``conductivity``
  [S/m], and ``valid`` (``[lo, hi]``, the fit's stated frequency range, e.g. ``[10 GHz, 1 THz]``;
  outside it the value is still computed and warned). eps does not follow the temperature.

Time dependence exp(-i w t) as everywhere in pmmw: eps'' >= 0 is loss.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from pmmw.constants import EPS0  # [F/m]

if TYPE_CHECKING:
    from pathlib import Path


@dataclass(frozen=True)
class ModelSpec:
    """One registered model: its function eps(f [Hz], T [K], **params), ranges and source."""

    name: str
    fn: Callable[..., complex] = field(
        repr=False, compare=False
    )  # repr: the scenario hash holds repr(material), no address
    f_range: tuple[float, float]  # [Hz]
    t_range: tuple[float, float]  # [K]
    t_ref: float  # [K] temperature when the material gives none
    params: tuple[str, ...]
    source: str
    optional: tuple[str, ...] = ()  # parameters with defaults in `fn`
    parsers: dict = field(default_factory=dict, repr=False, compare=False)  # name -> parse(v, file, key)
    example: str = ""  # a complete ``model:`` mapping, for error messages
    check: Callable[[dict, object, str | None], None] | None = field(
        default=None, repr=False, compare=False
    )  # check(params, file, key): cross-parameter rules
    outside: Callable[[float, float, dict], str | None] | None = field(
        default=None, repr=False, compare=False
    )  # outside(f, T, params) -> reason or None
    params_text: Callable[[dict], str] | None = field(
        default=None, repr=False, compare=False
    )  # params_text(params) -> their text
    intervals: Callable[[dict], tuple[tuple[float, float], ...]] | None = field(
        default=None, repr=False, compare=False
    )  # intervals(params) -> the stated frequency ranges [Hz] when the parameters set them
    intervals_words: tuple[str, str] = ("", "")  # the text before and after the intervals' list

    def edges(self, params: dict) -> tuple[float, ...]:
        """Frequencies [Hz] where `outside` may change besides `f_range`'s: the intervals' ends."""
        return tuple(f for row in self.intervals(params) for f in row) if self.intervals is not None else ()

    def temperatures(self) -> str:
        """The text of the stated temperature range."""
        t0, t1 = self.t_range
        return "at any temperature" if t0 <= 0.0 and t1 >= 1e4 else f"{t0:g}-{t1:g} K"

    def ranges(self, params: dict) -> str:
        """The text of the stated frequency range for these parameters."""
        if self.intervals is None:
            f0, f1 = self.f_range
            if f0 >= 1e8:
                return f"{f0 / 1e9:g}-{f1 / 1e9:g} GHz"
            scale, unit = (1e6, "MHz") if f0 >= 1e6 else (1e3, "kHz") if f0 >= 1e3 else (1.0, "Hz")
            return f"{f0 / scale:g} {unit}-{f1 / 1e9:g} GHz"
        before, after = self.intervals_words
        rows = ", ".join(f"{lo / 1e9:g}-{hi / 1e9:g} GHz" for lo, hi in self.intervals(params))
        return f"{before}{rows}{after}"


@dataclass(frozen=True)
class DielectricModel:
    """A model bound to a material's parameters."""

    spec: ModelSpec
    params: dict = field(default_factory=dict)

    def eps(self, f: float, temperature: float) -> complex:
        """eps' + i eps'' at f [Hz] and temperature [K]."""
        return complex(self.spec.fn(float(f), float(temperature), **self.params))

    def in_range(self, f: float, temperature: float) -> bool:
        """Whether f [Hz] and temperature [K] lie in the model's stated validity."""
        return self.outside(f, temperature) is None

    def outside(self, f: float, temperature: float) -> str | None:
        """None inside the model's stated validity, else what is done there (for the warning)."""
        if self.spec.outside is not None:
            reason = self.spec.outside(float(f), float(temperature), self.params)
            if reason is not None:
                return reason
        (f0, f1), (t0, t1) = self.spec.f_range, self.spec.t_range
        if f0 <= f <= f1 and t0 <= temperature <= t1:
            return None
        return "the model is extrapolated"

    def describe(self) -> str:
        extra = ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}" for k, v in self.params.items())
        if self.spec.params_text is not None:
            extra = self.spec.params_text(self.params)
        f_text, t_text = self.spec.ranges(self.params), self.spec.temperatures()
        return (
            f"model {self.spec.name}{' (' + extra + ')' if extra else ''}: {self.spec.source}; valid {f_text}, {t_text}"
        )


def _water(f, T):
    from pmmw.atmosphere.itu import water_permittivity

    return complex(water_permittivity(f, T))


def _p527_water(f, T, salinity=0.0):
    from pmmw.atmosphere.itu import p527_water_permittivity

    return complex(p527_water_permittivity(f, T, salinity))


def _sea_water(f, T, salinity=35.0):
    return _p527_water(f, T, salinity)


def _p2040(f, T, material):
    from pmmw.scene.itu_materials import p2040_permittivity

    return p2040_permittivity(f, material)[0]


def _p2040_outside(f, T, params):
    from pmmw.scene.itu_materials import p2040_permittivity

    status = p2040_permittivity(f, params["material"])[1]
    return None if status.startswith("in row") else f"ITU-R P.2040-4's value is {status}"


def _p2040_intervals(params):
    from pmmw.scene.itu_materials import p2040_valid_ranges

    return tuple(sorted(p2040_valid_ranges(params["material"])))


def _p2040_material(v, file, key):
    from pmmw.errors import UserError
    from pmmw.scene.itu_materials import P2040_BUILDING_MATERIALS

    if v not in P2040_BUILDING_MATERIALS:
        raise UserError(f"unknown ITU-R P.2040 material {v!r}; known: {', '.join(P2040_BUILDING_MATERIALS)}", file, key)
    return str(v)


def _vegetation(f, T, gravimetric_moisture):
    from pmmw.scene.itu_materials import p527_vegetation_permittivity

    eps = p527_vegetation_permittivity(f, T, gravimetric_moisture)
    if eps.imag < 0.0:  # the fit's free-water fraction turns negative for dry vegetation
        from pmmw.errors import warn

        warn(
            f"ITU-R P.527-6's vegetation fit gives a gain (eps'' {eps.imag:.3g}) at {f / 1e9:g} GHz, {T:g} K for "
            f"gravimetric moisture {gravimetric_moisture:g}; taken as lossless"
        )
        eps = complex(eps.real, 0.0)
    return eps


def _vegetation_outside(f, T, params):
    from pmmw.scene.itu_materials import (
        P527_VEGETATION_T_FREEZE,
        P527_VEGETATION_T_RANGE_FROZEN_PHYSICAL,
    )

    t_hi = P527_VEGETATION_T_RANGE_FROZEN_PHYSICAL[1]
    if t_hi < T <= P527_VEGETATION_T_FREEZE:
        return (
            f"{T:g} K lies between -6.5 and 0 C, where P.527-6's frozen-vegetation fit grows without bound; "
            "the value is computed all the same"
        )
    return None


def _ice(f, T):
    """Maetzler (2006), Thermal Microwave Radiation sec. 5.3 (Hufford 1991, Mishima et al. 1983)."""
    f_ghz = f / 1e9
    theta = 300.0 / T - 1.0
    alpha = (0.00504 + 0.0062 * theta) * math.exp(-22.1 * theta)
    x = math.exp(335.0 / T)
    beta = (0.0207 / T) * x / (x - 1.0) ** 2 + 1.16e-11 * f_ghz**2 + math.exp(-9.963 + 0.0372 * (T - 273.15))
    return complex(3.1884 + 9.1e-4 * (T - 273.15), alpha / f_ghz + beta * f_ghz)


def _conductor(f, T, conductivity):
    return complex(1.0, conductivity / (EPS0 * 2.0 * math.pi * f))


# Gabriel, Lau and Gabriel 1996, Table 1 (digits as the IFAC-CNR tabulation of it gives them):
# eps_inf, then (d_eps [1], tau [s], alpha [1]) of the four dispersions, then sigma_i [S/m].
GABRIEL_1996 = {
    "skin_dry": (
        4.0,
        ((32.0, 7.234e-12, 0.0), (1100.0, 32.481e-9, 0.20), (0.0, 159.155e-6, 0.20), (0.0, 15.915e-3, 0.20)),
        0.0002,
    ),
    "skin_wet": (
        4.0,
        ((39.0, 7.958e-12, 0.10), (280.0, 79.577e-9, 0.0), (3.0e4, 1.592e-6, 0.16), (3.0e4, 1.592e-3, 0.20)),
        0.0004,
    ),
}


def _cole_cole(f, eps_inf, terms, sigma_i):
    """Gabriel et al. 1996's sum of Cole-Cole dispersions plus ionic conduction, written for
    exp(+i w t) (eps' - i eps''), returned conjugated to pmmw's exp(-i w t) (eps' + i eps'')."""
    omega = 2.0 * math.pi * f
    eps = complex(eps_inf) + sigma_i / (1j * omega * EPS0)
    for d_eps, tau, alpha in terms:
        eps += d_eps / (1.0 + (1j * omega * tau) ** (1.0 - alpha))
    return eps.conjugate()


def _skin_dry(f, T):
    return _cole_cole(f, *GABRIEL_1996["skin_dry"])


def _skin_wet(f, T):
    return _cole_cole(f, *GABRIEL_1996["skin_wet"])


def _debye(f, T, eps_inf, terms, valid, conductivity=0.0):
    """eps_inf + sum_k d_eps_k / (1 - i omega tau_k) + i sigma / (eps0 omega): the Debye form in
    pmmw's exp(-i w t) (eps'' >= 0 is loss)."""
    omega = 2.0 * math.pi * f
    eps = complex(eps_inf) + 1j * conductivity / (EPS0 * omega)
    for d_eps, tau in terms:
        eps += d_eps / (1.0 - 1j * omega * tau)
    return eps


def _debye_outside(f, T, params):
    lo, hi = params["valid"]
    return None if lo <= f <= hi else "the fit is extrapolated"


def _debye_text(params):
    terms = " + ".join(f"{d:g} at tau {tau * 1e12:g} ps" for d, tau in params["terms"])
    sigma = params.get("conductivity", 0.0)
    return f"eps_inf {params['eps_inf']:g}, relaxations {terms}" + (f", conductivity {sigma:g} S/m" if sigma else "")


_SECONDS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "ps": 1e-12, "fs": 1e-15}


def _time(v, file, key):
    """A relaxation time [s]: a bare number in seconds or text with its unit ('8 ps')."""
    from pmmw.errors import UserError

    x = None
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        x = float(v)
    elif isinstance(v, str):
        parts = v.split()
        if len(parts) == 2 and parts[1] in _SECONDS:
            try:
                x = float(parts[0]) * _SECONDS[parts[1]]
            except ValueError:
                x = None
    if x is None or not (math.isfinite(x) and x > 0.0):
        raise UserError(
            f"expected a relaxation time above 0 with its unit ({', '.join(_SECONDS)}), e.g. '8 ps', got {v!r}",
            file,
            key,
        )
    return x


def _debye_terms(v, file, key):
    """``[[d_eps, tau], ...]`` -> a tuple of (d_eps [1], tau [s]) pairs."""
    from pmmw.errors import UserError

    if not isinstance(v, (list, tuple)) or not v:
        raise UserError(
            f"expected a list of [d_eps, tau] pairs, e.g. [[10.0, 8 ps], [1.0, 0.2 ps]], got {v!r}", file, key
        )
    terms = []
    for i, term in enumerate(v):
        if not isinstance(term, (list, tuple)) or len(term) != 2:
            raise UserError(f"expected a pair [d_eps, tau], e.g. [10.0, 8 ps], got {term!r}", file, f"{key}.{i}")
        d_eps = _number(0.0, math.inf, "", "10.0")(term[0], file, f"{key}.{i}.0")
        terms.append((d_eps, _time(term[1], file, f"{key}.{i}.1")))
    return tuple(terms)


def _frequency_range(v, file, key):
    """``[lo, hi]`` with units -> (lo, hi) [Hz], lo < hi."""
    from pmmw.errors import UserError
    from pmmw.units import parse_quantity

    if not isinstance(v, (list, tuple)) or len(v) != 2:
        raise UserError(f"expected the fit's range [lo, hi], e.g. [10 GHz, 1 THz], got {v!r}", file, key)
    lo, hi = (parse_quantity(x, "frequency", file=file, key=f"{key}.{i}") for i, x in enumerate(v))
    if not 0.0 < lo < hi:
        raise UserError(f"expected 0 < lo < hi, got {v!r}", file, key)
    return (lo, hi)


def _leaves(f, T, dry_matter, salinity=10.0):
    """Maetzler (1994): fresh leaves of dry-matter fraction md from their sap, saline water."""
    from pmmw.atmosphere.itu import p527_water_permittivity

    eps_sw = complex(p527_water_permittivity(f, T, salinity))
    return 0.522 * (1.0 - 1.32 * dry_matter) * eps_sw + 0.51 + 3.84 * dry_matter


def p527_bulk_density(sand: float, clay: float) -> float:
    """Soil bulk density [g/cm^3] from its texture [%], ITU-R P.527-6 eq. (57). A constituent under
    1 % is left out (its logarithm would diverge); silt is the rest."""
    silt = 100.0 - sand - clay
    return 1.07256 + sum(c * math.log(p) for c, p in ((0.078886, sand), (0.038753, clay), (0.032732, silt)) if p >= 1.0)


def p527_conductivities(sand: float, clay: float, rho_b: float) -> tuple[float, float]:
    """The effective conductivities [S/m] of P.527-6 sec. 5.2: sigma_1 (Peplinski et al. 1995,
    fitted at 0.3-1.3 GHz) and sigma_2 (Dobson et al. 1985, 1.4-18 GHz, as refitted by Peplinski
    et al.); sand, clay [%], rho_b [g/cm^3]."""
    sigma_1 = 0.0467 + 0.2204 * rho_b - 0.004111 * sand - 0.006614 * clay
    sigma_2 = -1.645 + 1.939 * rho_b - 0.0225622 * sand + 0.01594 * clay
    return sigma_1, sigma_2


def _soil(f, T, sand, clay, moisture, bulk_density=None, particle_density=2.66):
    """ITU-R P.527-6 sec. 5.2, eqs. (58)-(70), in P.527's eps' - i eps'' written as eps' + i eps''.

    The Recommendation's conductivity terms can leave free water unphysical where they dominate:
    a negative loss conductivity sigma_eff'' (the regression's sigma_2 is negative for sandy,
    loose soils; a warning says so) is taken as 0, and eps_fw' is kept >= 1 (dry soils below
    a few GHz). The sign of sigma_eff' in eps_fw' is the Recommendation's, as MathWorks' and an
    independent P.527-4 implementation transcribe it; it falls as 1/f^2, to -0.12 in eps_fw' (about
    20) at 35 GHz for a loam at mv 0.05.
    """
    from pmmw.atmosphere.itu import p527_water_permittivity

    f_ghz = f / 1e9
    rho_s = particle_density
    rho_b = p527_bulk_density(sand, clay) if bulk_density is None else bulk_density
    mv = moisture
    alpha = 0.65  # eq. (59)
    beta_r = 1.2748 - 0.00519 * sand - 0.00152 * clay  # eq. (60)
    beta_i = 1.33797 - 0.00603 * sand - 0.00166 * clay  # eq. (61)
    eps_sm = (1.01 + 0.44 * rho_s) ** 2 - 0.062  # eq. (62): the solid particles
    dry = 1.0 + (rho_b / rho_s) * (eps_sm**alpha - 1.0)
    sigma_1, sigma_2 = p527_conductivities(sand, clay, rho_b)
    x = f_ghz / 1.35
    sigma_eff_r = x * (sigma_1 - sigma_2) / (1.0 + x**2)  # eq. (67)
    sigma_eff_i = sigma_2 + (sigma_1 - sigma_2) / (1.0 + x**2)  # eq. (68)
    if sigma_eff_i < 0.0:
        from pmmw.errors import warn

        warn(
            f"ITU-R P.527-6's effective conductivity of soil with sand {sand:g} %, clay {clay:g} %, bulk density "
            f"{rho_b:.3g} g/cm3 is negative (sigma_2 {sigma_2:.3g} S/m: Dobson's regression outside its data); the "
            "soil's conduction loss is taken as 0"
        )
        sigma_eff_i = 0.0
    eps_pw = complex(p527_water_permittivity(f, T))
    # eqs. (69)-(70), eps_fw = eps_pw + 18 (rho_s - rho_b) / (f rho_s mv) sigma_eff, enter eqs. (63)-(64)
    # as mv^(beta/alpha) eps_fw: written so, nothing divides by mv (beta/alpha > 1 for every texture)
    c = 18.0 * (rho_s - rho_b) / (f_ghz * rho_s)
    a_r, a_i = mv ** (beta_r / alpha), mv ** (beta_i / alpha)
    w_r = max(
        a_r * eps_pw.real + c * sigma_eff_r * mv ** (beta_r / alpha - 1.0), a_r
    )  # mv^(beta'/alpha) max(eps_fw', 1)
    w_i = a_i * eps_pw.imag + c * sigma_eff_i * mv ** (beta_i / alpha - 1.0)  # mv^(beta''/alpha) eps_fw''
    eps_r = (dry + w_r**alpha - mv) ** (1.0 / alpha)  # eq. (63)
    eps_i = w_i  # eq. (64): (mv^beta'' eps_fw''^alpha)^(1/alpha)
    return complex(eps_r, eps_i)


def _number(lo, hi, unit, example, *, above=False):
    """A parser of a number in [lo, hi] (above ``lo`` with ``above``), given bare or as text with
    its unit ('40 %', '1.5 g/cm3', '3.77e7 S/m'; YAML reads 3.77e7 as text)."""

    def parse(v, file, key):
        from pmmw.errors import UserError

        x = None
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            x = float(v)
        elif isinstance(v, str):
            try:
                x = float(v.strip().removesuffix(unit).strip() if unit else v)
            except ValueError:
                x = None
        if x is None or not (math.isfinite(x) and (x > lo if above else x >= lo) and x <= hi):
            u = f" {unit}" if unit else ""
            span = f"above {lo:g}{u}" if math.isinf(hi) else f"from {lo:g} to {hi:g}{u}"
            raise UserError(f"expected a number {span}, e.g. {example}, got {v!r}", file, key)
        return x

    return parse


_siemens_per_metre = _number(0.0, math.inf, "S/m", "'3.77e7 S/m'", above=True)  # a conductivity


def _check_soil(params, file, key):
    from pmmw.errors import UserError

    sand, clay = params["sand"], params["clay"]
    if sand + clay > 100.0:
        raise UserError(f"sand {sand:g} % and clay {clay:g} % add up to more than 100 %", file, key)
    rho_s = params.get("particle_density", 2.66)
    rho_b = params.get("bulk_density", p527_bulk_density(sand, clay))
    if rho_b >= rho_s:
        raise UserError(
            f"bulk density {rho_b:g} g/cm3 must be below the particle density {rho_s:g} g/cm3 (no pore space left)",
            file,
            key,
        )


_PERCENT = _number(0.0, 100.0, "%", "'40 %'")
_DENSITY = _number(0.5, 3.0, "g/cm3", "'1.5 g/cm3'")


MODELS = {
    "water": ModelSpec(
        "water",
        _water,
        (1e9, 1e12),
        (263.0, 373.0),
        293.15,
        (),
        "Liebe, Hufford and Manabe 1991 double-Debye model as ITU-R P.840-8 eqs. 4-10",
    ),
    "pure_water": ModelSpec(
        "pure_water",
        _p527_water,
        (1e9, 1e12),
        (269.15, 313.15),
        293.15,
        (),
        "ITU-R P.527-6 sec. 5.1.1 (Liebe, Hufford and Manabe 1991 double Debye)",
    ),
    "sea_water": ModelSpec(
        "sea_water",
        _sea_water,
        (1e9, 1e12),
        (269.15, 313.15),
        293.15,
        (),
        "ITU-R P.527-6 sec. 5.1.2 (Meissner and Wentz 2004 salinity terms, Stogryn et al. 1995 conductivity)",
        optional=("salinity",),
        parsers={"salinity": _number(0.0, 40.0, "g/kg", "'35 g/kg'")},
        example="{name: sea_water, salinity: 35 g/kg}",
    ),
    "ice": ModelSpec(
        "ice", _ice, (1e7, 3e12), (20.0, 273.15), 263.15, (), "Maetzler 2006 (Hufford 1991, Mishima et al. 1983)"
    ),
    "conductor": ModelSpec(
        "conductor",
        _conductor,
        (1e6, 1e12),
        (0.0, 1e4),
        293.15,
        ("conductivity",),
        "eps = 1 + i sigma / (eps0 omega) (Drude metal well below its collision frequency)",
        parsers={"conductivity": _siemens_per_metre},
        example="{name: conductor, conductivity: 3.5e7 S/m} for aluminium",
    ),
    "skin_dry": ModelSpec(
        "skin_dry",
        _skin_dry,
        (10.0, 100e9),
        (298.15, 313.15),
        310.15,
        (),
        "Gabriel, Lau and Gabriel 1996, four-term Cole-Cole, Table 1 'skin (dry)', at 37 C",
    ),
    "skin_wet": ModelSpec(
        "skin_wet",
        _skin_wet,
        (10.0, 100e9),
        (298.15, 313.15),
        310.15,
        (),
        "Gabriel, Lau and Gabriel 1996, four-term Cole-Cole, Table 1 'skin (wet)', at 37 C",
    ),
    "debye": ModelSpec(
        "debye",
        _debye,
        (0.0, math.inf),
        (0.0, 1e4),
        293.15,
        ("eps_inf", "terms", "valid"),
        "a sum of Debye relaxations (Debye 1929) with the entry's published parameters",
        optional=("conductivity",),
        parsers={
            "eps_inf": _number(1.0, math.inf, "", "2.0"),
            "terms": _debye_terms,
            "valid": _frequency_range,
            "conductivity": _number(0.0, math.inf, "S/m", "'0.5 S/m'"),
        },
        example="{name: debye, eps_inf: 2.0, terms: [[10.0, 8 ps]], valid: [10 GHz, 1 THz]}",
        outside=_debye_outside,
        intervals=lambda params: (tuple(params["valid"]),),
        intervals_words=("", " (the entry's stated range)"),
        params_text=_debye_text,
    ),
    "leaves": ModelSpec(
        "leaves",
        _leaves,
        (1e9, 100e9),
        (273.15, 313.15),
        293.15,
        ("dry_matter",),
        "Maetzler 1994 leaf model with ITU-R P.527-6 saline water as the sap",
        optional=("salinity",),
        parsers={"dry_matter": _number(0.0, 0.75, "", "0.35"), "salinity": _number(0.0, 40.0, "g/kg", "'10 g/kg'")},
        example="{name: leaves, dry_matter: 0.35, salinity: 10}",
    ),
    "p2040": ModelSpec(
        "p2040",
        _p2040,
        (1e6, 450e9),
        (0.0, 1e4),
        293.15,
        ("material",),
        "ITU-R P.2040-4 (2025) Table 3: eps' = a f^b, sigma = c f^d (f in GHz), per row",
        parsers={"material": _p2040_material},
        example="{name: p2040, material: concrete}",
        outside=_p2040_outside,
        intervals=_p2040_intervals,
        intervals_words=("the rows ", ""),
    ),
    "vegetation": ModelSpec(
        "vegetation",
        _vegetation,
        (0.2e9, 1e12),
        (253.15, 313.15),
        293.15,
        ("gravimetric_moisture",),
        "ITU-R P.527-6 sec. 5.3 (Ulaby and El-Rayes 1987 above 0 C, with P.527-6's pure water; "
        "sec. 5.3.2's fit at or below 0 C), applied by the Recommendation to 1000 GHz; its "
        "fits rest on 0.2-20 GHz measurements",
        parsers={"gravimetric_moisture": _number(0.1, 0.7, "", "0.5")},
        example="{name: vegetation, gravimetric_moisture: 0.5}",
        outside=_vegetation_outside,
    ),
    "soil": ModelSpec(
        "soil",
        _soil,
        (0.3e9, 1e12),
        (273.15, 313.15),
        293.15,
        ("sand", "clay", "moisture"),
        "ITU-R P.527-6 sec. 5.2 (Dobson et al. 1985 mixing, Peplinski et al. 1995 conductivities), "
        "applied by the Recommendation to 1000 GHz; its fits rest on 0.3-18 GHz measurements",
        optional=("bulk_density", "particle_density"),
        parsers={
            "sand": _PERCENT,
            "clay": _PERCENT,
            "moisture": _number(0.0, 0.6, "", "0.2"),
            "bulk_density": _DENSITY,
            "particle_density": _DENSITY,
        },
        example="{name: soil, sand: 40, clay: 20, moisture: 0.2}",
        check=_check_soil,
    ),
}


def make_dielectric(spec: object, *, file: str | Path | None = None, key: str | None = None) -> DielectricModel:
    """A `DielectricModel` from a material's ``model:`` mapping, e.g. ``{name: conductor,
    conductivity: 3.5e7}`` (conductivity in S/m) or ``{name: soil, sand: 40, clay: 20, moisture:
    0.2}``; errors name the key."""
    from pmmw.errors import UserError

    if isinstance(spec, str):
        spec = {"name": spec}
    if not isinstance(spec, dict) or "name" not in spec:
        raise UserError(f"expected {{name: one of {', '.join(MODELS)}, ...parameters}}, got {spec!r}", file, key)
    name = spec["name"]
    if name not in MODELS:
        raise UserError(f"unknown permittivity model {name!r}; known: {', '.join(MODELS)}", file, f"{key}.name")
    ms = MODELS[name]
    params = {}
    for k, v in spec.items():
        if k == "name":
            continue
        if k not in ms.params + ms.optional:
            allowed = ", ".join(ms.params + ms.optional) or "none"
            raise UserError(f"unknown parameter {k!r} of model {name} (parameters: {allowed})", file, f"{key}.{k}")
        params[k] = ms.parsers[k](v, file, f"{key}.{k}")
    missing = [p for p in ms.params if p not in params]
    if missing:
        raise UserError(f"model {name} needs {', '.join(missing)} (e.g. {ms.example})", file, key)
    if ms.check is not None:
        ms.check(params, file, key)
    return DielectricModel(ms, params)
