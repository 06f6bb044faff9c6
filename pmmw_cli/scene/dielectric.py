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
        f_text = f"{f0 / 1e9:g}-{f1 / 1e9:g} GHz" if f0 >= 1e9 else f"{f0:g} Hz-{f1 / 1e9:g} GHz"
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


MODELS = {
    "water": ModelSpec("water", _water, (1e9, 1e12), (263.0, 373.0), 293.15, (),
                       "Liebe, Hufford and Manabe 1991 double-Debye model as ITU-R P.840-8 eqs. 4-10"),
    "ice": ModelSpec("ice", _ice, (1e7, 3e12), (20.0, 273.15), 263.15, (),
                     "Maetzler 2006 (Hufford 1991, Mishima et al. 1983)"),
    "conductor": ModelSpec("conductor", _conductor, (1e6, 1e12), (0.0, 1e4), 293.15, ("conductivity",),
                           "eps = 1 + i sigma / (eps0 omega) (Drude metal well below its collision frequency)"),
    "skin_dry": ModelSpec("skin_dry", _skin_dry, (10.0, 100e9), (298.15, 313.15), 310.15, (),
                          "Gabriel, Lau and Gabriel 1996, four-term Cole-Cole, Table 1 'skin (dry)', at 37 C"),
    "skin_wet": ModelSpec("skin_wet", _skin_wet, (10.0, 100e9), (298.15, 313.15), 310.15, (),
                          "Gabriel, Lau and Gabriel 1996, four-term Cole-Cole, Table 1 'skin (wet)', at 37 C"),
}


def _siemens_per_metre(v, file, key) -> float:
    """A conductivity: a number [S/m] or a string '3.77e7 S/m' (YAML reads 3.77e7 as text)."""
    from pmmw_cli.errors import UserError

    x = None
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        x = float(v)
    elif isinstance(v, str):
        text = v.strip().removesuffix("S/m").strip()
        try:
            x = float(text)
        except ValueError:
            x = None
    if x is None or not (math.isfinite(x) and x > 0):
        raise UserError(f"expected a conductivity > 0 in S/m, e.g. '3.77e7 S/m', got {v!r}", file, key)
    return x


def make_dielectric(spec, *, file=None, key=None) -> DielectricModel:
    """A `DielectricModel` from a material's ``model:`` mapping, e.g. ``{name: conductor,
    conductivity: 3.5e7}`` (conductivity in S/m); errors name the key."""
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
        if k not in ms.params:
            allowed = ", ".join(ms.params) or "none"
            raise UserError(f"unknown parameter {k!r} of model {name} (parameters: {allowed})", file, f"{key}.{k}")
        params[k] = _siemens_per_metre(v, file, f"{key}.{k}")
    missing = [p for p in ms.params if p not in params]
    if missing:
        raise UserError(f"model {name} needs {', '.join(missing)} (e.g. conductivity: 3.5e7 for aluminium, in S/m)",
                        file, key)
    return DielectricModel(ms, params)
