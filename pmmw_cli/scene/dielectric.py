"""Physical permittivity models for material entries (``model: {name: water}`` in the database).

A tabulated entry (``eps: {35 GHz: ..., 95 GHz: ...}``) holds measured values at a few
frequencies; a model entry computes eps' + i eps'' at any frequency of its valid range and at the
material's own temperature. Each model states its source and its range; outside it the value is
still computed and `Material.eps_at` warns.

Registry (`MODELS`, chosen by ``model.name``):

* ``water``: liquid water, the double-Debye model of Liebe, Hufford and Manabe (1991) as ITU-R
  P.840-8 eqs. 4-10 give it (the same code as the atmosphere's fog and cloud,
  `pmmw_cli.atmosphere.itu.water_permittivity`); 1-1000 GHz, 263-373 K.
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
  P.527-6 sec. 5.1.2 (`pmmw_cli.atmosphere.itu.p527_water_permittivity`). Stated for 1-100 GHz
  (Maetzler's measurements); extrapolated above, with a warning. The formula's water term
  changes sign at md = 1/1.32, so md is limited to 0-0.75.
* ``soil``: mineral soil, ITU-R P.527-6 sec. 5.2 (`_soil`): the Dobson et al. (1985) mixing model
  with Peplinski et al. (1995)'s conductivities, free water by P.527-6's pure water; ``sand``,
  ``clay`` [%] (silt the rest), volumetric ``moisture`` [1], ``bulk_density`` [g/cm^3] (default
  P.527-6 eq. (57)), ``particle_density`` [g/cm^3] (default 2.66). The mixing exponents were
  fitted at 1.4-18 GHz (Dobson et al.) and the conductivities at 0.3-1.3 GHz (Peplinski et al.):
  stated 0.3-18 GHz, so at 35-300 GHz the model is extrapolated, with a warning.

Time dependence exp(-i w t) as everywhere in pmmw: eps'' >= 0 is loss.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

EPS0 = 8.8541878128e-12  # [F/m]


@dataclass(frozen=True)
class ModelSpec:
    """One registered model: its function eps(f [Hz], T [K], **params), ranges and source."""

    name: str
    fn: object = field(repr=False, compare=False)  # repr: the scenario hash holds repr(material), no address
    f_range: tuple[float, float]  # [Hz]
    t_range: tuple[float, float]  # [K]
    t_ref: float  # [K] temperature when the material gives none
    params: tuple[str, ...]
    source: str
    optional: tuple[str, ...] = ()  # parameters with defaults in `fn`
    parsers: dict = field(default_factory=dict, repr=False, compare=False)  # name -> parse(v, file, key)
    example: str = ""  # a complete ``model:`` mapping, for error messages
    check: object = field(default=None, repr=False, compare=False)  # check(params, file, key): cross-parameter rules


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
        (f0, f1), (t0, t1) = self.spec.f_range, self.spec.t_range
        return f0 <= f <= f1 and t0 <= temperature <= t1

    def describe(self) -> str:
        extra = ", ".join(f"{k} {v:g}" for k, v in self.params.items())
        (f0, f1), (t0, t1) = self.spec.f_range, self.spec.t_range
        f_text = f"{f0 / 1e9:g}-{f1 / 1e9:g} GHz" if f0 >= 1e8 else f"{f0:g} Hz-{f1 / 1e9:g} GHz"
        return (f"model {self.spec.name}{' (' + extra + ')' if extra else ''}: {self.spec.source}; valid "
                f"{f_text}, {t0:g}-{t1:g} K")


def _water(f, T):
    from pmmw_cli.atmosphere.itu import water_permittivity

    return complex(water_permittivity(f, T))


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
    "skin_dry": (4.0, ((32.0, 7.234e-12, 0.0), (1100.0, 32.481e-9, 0.20), (0.0, 159.155e-6, 0.20),
                       (0.0, 15.915e-3, 0.20)), 0.0002),
    "skin_wet": (4.0, ((39.0, 7.958e-12, 0.10), (280.0, 79.577e-9, 0.0), (3.0e4, 1.592e-6, 0.16),
                       (3.0e4, 1.592e-3, 0.20)), 0.0004),
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


def _leaves(f, T, dry_matter, salinity=10.0):
    """Maetzler (1994): fresh leaves of dry-matter fraction md from their sap, saline water."""
    from pmmw_cli.atmosphere.itu import p527_water_permittivity

    eps_sw = complex(p527_water_permittivity(f, T, salinity))
    return 0.522 * (1.0 - 1.32 * dry_matter) * eps_sw + 0.51 + 3.84 * dry_matter


def p527_bulk_density(sand, clay):
    """Soil bulk density [g/cm^3] from its texture [%], ITU-R P.527-6 eq. (57). A constituent under
    1 % is left out (its logarithm would diverge); silt is the rest."""
    silt = 100.0 - sand - clay
    return 1.07256 + sum(c * math.log(p) for c, p in ((0.078886, sand), (0.038753, clay), (0.032732, silt)) if p >= 1.0)


def p527_conductivities(sand, clay, rho_b):
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
    loose soils; `make_dielectric` warns) is taken as 0, and eps_fw' is kept >= 1 (dry soils below
    a few GHz). The sign of sigma_eff' in eps_fw' is the Recommendation's, as MathWorks' and an
    independent P.527-4 implementation transcribe it; it falls as 1/f^2, to -0.12 in eps_fw' (about
    20) at 35 GHz for a loam at mv 0.05.
    """
    from pmmw_cli.atmosphere.itu import p527_water_permittivity

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
    sigma_eff_i = max(sigma_2 + (sigma_1 - sigma_2) / (1.0 + x**2), 0.0)  # eq. (68)
    eps_pw = complex(p527_water_permittivity(f, T))
    # eqs. (69)-(70), eps_fw = eps_pw + 18 (rho_s - rho_b) / (f rho_s mv) sigma_eff, enter eqs. (63)-(64)
    # as mv^(beta/alpha) eps_fw: written so, nothing divides by mv (beta/alpha > 1 for every texture)
    c = 18.0 * (rho_s - rho_b) / (f_ghz * rho_s)
    a_r, a_i = mv ** (beta_r / alpha), mv ** (beta_i / alpha)
    w_r = max(a_r * eps_pw.real + c * sigma_eff_r * mv ** (beta_r / alpha - 1.0), a_r)  # mv^(beta'/alpha) max(eps_fw', 1)
    w_i = a_i * eps_pw.imag + c * sigma_eff_i * mv ** (beta_i / alpha - 1.0)  # mv^(beta''/alpha) eps_fw''
    eps_r = (dry + w_r**alpha - mv) ** (1.0 / alpha)  # eq. (63)
    eps_i = w_i  # eq. (64): (mv^beta'' eps_fw''^alpha)^(1/alpha)
    return complex(eps_r, eps_i)


def _number(lo, hi, unit, example, *, above=False):
    """A parser of a number in [lo, hi] (above ``lo`` with ``above``), given bare or as text with
    its unit ('40 %', '1.5 g/cm3', '3.77e7 S/m'; YAML reads 3.77e7 as text)."""

    def parse(v, file, key):
        from pmmw_cli.errors import UserError

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
    from pmmw_cli.errors import UserError, warn

    sand, clay = params["sand"], params["clay"]
    if sand + clay > 100.0:
        raise UserError(f"sand {sand:g} % and clay {clay:g} % add up to more than 100 %", file, key)
    rho_s = params.get("particle_density", 2.66)
    rho_b = params.get("bulk_density", p527_bulk_density(sand, clay))
    if rho_b >= rho_s:
        raise UserError(f"bulk density {rho_b:g} g/cm3 must be below the particle density {rho_s:g} g/cm3 "
                        "(no pore space left)", file, key)
    sigma_2 = p527_conductivities(sand, clay, rho_b)[1]
    if sigma_2 < 0.0:
        where = f"{file}: {key}: " if file else ""
        warn(f"{where}ITU-R P.527-6's effective conductivity sigma_2 of soil with sand {sand:g} %, clay {clay:g} %, "
             f"bulk density {rho_b:.3g} g/cm3 is negative ({sigma_2:.3g} S/m: Dobson's regression outside its "
             "data); above a few GHz the soil's conduction loss is taken as 0")


_PERCENT = _number(0.0, 100.0, "%", "'40 %'")
_DENSITY = _number(0.5, 3.0, "g/cm3", "'1.5 g/cm3'")


MODELS = {
    "water": ModelSpec("water", _water, (1e9, 1e12), (263.0, 373.0), 293.15, (),
                       "Liebe, Hufford and Manabe 1991 double-Debye model as ITU-R P.840-8 eqs. 4-10"),
    "ice": ModelSpec("ice", _ice, (1e7, 3e12), (20.0, 273.15), 263.15, (),
                     "Maetzler 2006 (Hufford 1991, Mishima et al. 1983)"),
    "conductor": ModelSpec("conductor", _conductor, (1e6, 1e12), (0.0, 1e4), 293.15, ("conductivity",),
                           "eps = 1 + i sigma / (eps0 omega) (Drude metal well below its collision frequency)",
                           parsers={"conductivity": _siemens_per_metre},
                           example="{name: conductor, conductivity: 3.5e7 S/m} for aluminium"),
    "skin_dry": ModelSpec("skin_dry", _skin_dry, (10.0, 100e9), (298.15, 313.15), 310.15, (),
                          "Gabriel, Lau and Gabriel 1996, four-term Cole-Cole, Table 1 'skin (dry)', at 37 C"),
    "skin_wet": ModelSpec("skin_wet", _skin_wet, (10.0, 100e9), (298.15, 313.15), 310.15, (),
                          "Gabriel, Lau and Gabriel 1996, four-term Cole-Cole, Table 1 'skin (wet)', at 37 C"),
    "leaves": ModelSpec("leaves", _leaves, (1e9, 100e9), (273.15, 313.15), 293.15, ("dry_matter",),
                        "Maetzler 1994 leaf model with ITU-R P.527-6 saline water as the sap",
                        optional=("salinity",),
                        parsers={"dry_matter": _number(0.0, 0.75, "", "0.35"),
                                 "salinity": _number(0.0, 40.0, "g/kg", "'10 g/kg'")},
                        example="{name: leaves, dry_matter: 0.35, salinity: 10}"),
    "soil": ModelSpec("soil", _soil, (0.3e9, 18e9), (273.15, 313.15), 293.15, ("sand", "clay", "moisture"),
                      "ITU-R P.527-6 sec. 5.2 (Dobson et al. 1985 mixing, Peplinski et al. 1995 conductivities), "
                      "fitted at 0.3-18 GHz",
                      optional=("bulk_density", "particle_density"),
                      parsers={"sand": _PERCENT, "clay": _PERCENT, "moisture": _number(0.0, 0.6, "", "0.2"),
                               "bulk_density": _DENSITY, "particle_density": _DENSITY},
                      example="{name: soil, sand: 40, clay: 20, moisture: 0.2}", check=_check_soil),
}


def make_dielectric(spec, *, file=None, key=None) -> DielectricModel:
    """A `DielectricModel` from a material's ``model:`` mapping, e.g. ``{name: conductor,
    conductivity: 3.5e7}`` (conductivity in S/m) or ``{name: soil, sand: 40, clay: 20, moisture:
    0.2}``; errors name the key."""
    from pmmw_cli.errors import UserError

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
