"""Unit strings at the edge: ``"95 GHz"``, ``"0.8 mm"``, ``"10 deg"``, ``"300 K"`` -> SI floats.

Inside pmmw every quantity is SI: [Hz], [m], [rad], [K], [Np/m] for power attenuation, [kg/m^3].
pint parses the strings; this module only knows which unit each kind of quantity has and what a
bare number means for it. The usual units (``GHz``, ``m``, ``deg``, ``K``, ``g/m3``, ``dB/km``...,
`_EXACT`) are converted here by pint's own factor, to the same float, without pint: importing
pint and building its registry takes about 0.3 s of every command's start on 2 cores, and a
scenario written in those units never needs it.

A unit is accepted for a kind when its pint *root units* are the kind's, not merely its
dimensionality: pint counts the radian as dimensionless, so by dimensionality ``0.5 rad``,
``0.5 percent`` and ``0.5 sr`` would all be "angles" (and ``1 rad/s`` a frequency). By root
units only radian-based units (``rad``, ``mrad``, ``deg``, ``arcmin``, ``arcsec``, ``turn``,
``grad``...) are angles, and only ``1/s``-based units are frequencies.

Temperatures come in two kinds. ``temperature`` is absolute: ``20 degC`` is 293.15 K (the
offset applies), and a difference unit (``delta_degC``) is refused. ``temperature_difference``
(noise, error goals, tolerances) takes kelvin, ``delta_degC`` or ``delta_degF``; an offset unit
(``degC``, ``degF``) is refused, since "2 degC" read as a difference (2 K) or as an absolute
temperature (275.15 K) are both plausible and far apart.

Attenuation is power attenuation: ``P(z) = P(0) exp(-alpha z)`` with alpha in [Np/m]. Its unit
strings are a level unit over a length (``dB/km``, ``dB/m``, ``Np/m``, ``Np/km``); pint's own
``dB`` and ``Np`` are logarithmic units that cannot be divided by a length, so they are read as
multiplicative units of a dimension of their own, with 1 dB = ln(10)/10 Np exactly as power
ratios go (10 log10 r = 10/ln(10) * ln r). ``Np`` here is the power (opacity) neper, the unit of
``sky.zenith_opacity``, not the field-amplitude neper of ISO 80000 (which is twice as large).
"""

from __future__ import annotations

import math
import numbers
import re
import sys
from functools import lru_cache
from types import ModuleType
from typing import TYPE_CHECKING

from pmmw.errors import UserError

if TYPE_CHECKING:  # the type checker's view of the pint that `ureg` imports without Dask
    from pathlib import Path

    import pint


def _import_pint() -> ModuleType:
    """Import pint without Dask: pint looks for Dask when it is imported (``pint.compat``) and
    imports it (with Jinja2) when installed, about 0.3 s of every command's start on a 2-core
    machine, for Dask arrays of quantities that pmmw never makes. Dask itself is imported as
    usual later (``--executor dask``)."""
    hidden = "dask" not in sys.modules
    if hidden:
        sys.modules["dask"] = None  # type: ignore[assignment]  # importlib.util.find_spec("dask") is then None
    try:
        import pint
    finally:
        if hidden and sys.modules.get("dask", 0) is None:
            del sys.modules["dask"]
    return pint


# private names for the multiplicative level units of attenuation (see the module docstring)
_NEPER = "pmmw_power_neper"
_DECIBEL = "pmmw_power_decibel"
_NEPER_PER_DB = math.log(10.0) / 10.0  # power: 1 dB = ln(10)/10 Np


@lru_cache(maxsize=1)
def ureg() -> pint.UnitRegistry:
    """pint's unit registry with pmmw's level units, made (and pint imported) on first use."""
    reg: pint.UnitRegistry = _import_pint().UnitRegistry(autoconvert_offset_to_baseunit=True)
    reg.define(f"{_NEPER} = [pmmw_power_level]")
    reg.define(f"{_DECIBEL} = {_NEPER_PER_DB!r} * {_NEPER}")
    return reg


_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")
_LEVEL = re.compile(r"(?<![A-Za-z_])(?:(db|decibels?)|(np|nepers?))(?![A-Za-z_0-9])", re.IGNORECASE)


def _unit_text(unit: str, kind: str) -> str:
    """Accept the usual shorthand for powers of units: ``g/m3`` -> ``g/m**3``; attenuation
    levels (``dB``, ``Np``) -> this registry's multiplicative level units."""
    unit = re.sub(r"([A-Za-z])\^?(\d)", r"\1**\2", unit)
    if unit.startswith("/"):
        unit = "1" + unit
    if kind == "attenuation":
        unit = _LEVEL.sub(lambda m: _DECIBEL if m.group(1) else _NEPER, unit)
    return unit


TEMPERATURE_MAX = 1e6  # [K] hotter than any source a passive imager sees (the sun is ~7000 K at 95 GHz)

# kind -> (internal unit, unit a bare number is taken in (None: a unit is required), example, noun)
_KINDS: dict[str, tuple[str, str | None, str, str]] = {
    "frequency": ("Hz", None, "'95 GHz'", "frequency"),
    "length": ("m", "m", "'0.8 mm' or '600 m'", "length"),
    "angle": ("rad", "deg", "'10 deg', '0.5 rad' or '600 mrad'", "angle"),
    "temperature": ("K", "K", "'300 K' or '20 degC'", "temperature"),
    "temperature_difference": ("K", "K", "'2 K' or '2 delta_degC'", "temperature difference"),
    "density": ("kg/m**3", "g/m**3", "'0.3 g/m3'", "mass density"),
    "rate": ("m/s", "mm/h", "'10 mm/h'", "rain rate"),
    "attenuation": (f"{_NEPER}/m", f"{_DECIBEL}/km", "'0.9 dB/km' or '0.2 Np/km'", "attenuation"),
    "time": ("s", "s", "'10 ms' or '2 us'", "duration"),
}

_DEG = math.pi / 180.0  # pint's degree in radians
_MM_PER_H = 1e-3 / 3600.0  # pint's mm/h in m/s
_DB_PER_KM = _NEPER_PER_DB * 1e-3  # this registry's dB/km in Np/m (as pint forms it: ln(10) / 10 x 1e-3)

#: kind -> {unit as written (``""``: a bare number): its factor to the kind's internal unit}, for
#: the units that pint converts by one multiplication (no offset): ``parse_quantity`` multiplies
#: by the factor itself, which is pint's own to the bit (tests/config/test_units.py compares each
#: factor and the values parsed both ways), so pint is imported only for the other units.
_EXACT: dict[str, dict[str, float]] = {
    "frequency": {"Hz": 1.0, "kHz": 1e3, "MHz": 1e6, "GHz": 1e9, "THz": 1e12},
    "length": {"": 1.0, "nm": 1e-9, "um": 1e-6, "mm": 1e-3, "cm": 1e-2, "m": 1.0, "km": 1e3},
    "angle": {"": _DEG, "deg": _DEG, "rad": 1.0, "mrad": 1e-3},
    "temperature": {"": 1.0, "K": 1.0},
    "temperature_difference": {"": 1.0, "K": 1.0, "mK": 1e-3},
    "density": {"": 1e-3, "g/m3": 1e-3, "kg/m3": 1.0},
    "rate": {"": _MM_PER_H, "mm/h": _MM_PER_H, "m/s": 1.0},
    "attenuation": {"": _DB_PER_KM, "dB/km": _DB_PER_KM, "dB/m": _NEPER_PER_DB, "Np/km": 1e-3, "Np/m": 1.0},
    "time": {"": 1.0, "s": 1.0, "ms": 1e-3, "us": 1e-6},
}

# units a misspelt one is compared with, case-insensitively ('95 Ghz' -> did you mean 'GHz'?)
_COMMON_UNITS = (
    "Hz",
    "kHz",
    "MHz",
    "GHz",
    "THz",
    "nm",
    "um",
    "mm",
    "cm",
    "m",
    "km",
    "deg",
    "rad",
    "mrad",
    "K",
    "mK",
    "degC",
    "degF",
    "g/m3",
    "kg/m3",
    "mm/h",
    "dB/km",
    "Np/km",
    "dB/m",
    "s",
    "ms",
    "us",
)


def _case_hint(text: str) -> str:
    """' (did you mean 'GHz'? ...)' when ``text`` is a common unit in the wrong case, else ''."""
    near = [u for u in _COMMON_UNITS if u.lower() == text.replace(" ", "").lower() and u != text]
    return f" (did you mean {near[0]!r}? units are case-sensitive: m is milli, M is mega)" if near else ""


def _a(noun: str) -> str:
    return ("an " if noun[:1] in "aeiou" else "a ") + noun


def parse_quantity(
    value: object, kind: str, *, file: str | Path | None = None, key: str | None = None, unit: str | None = None
) -> float:
    """Parse a number or unit string into a float in the kind's internal (SI) unit.

    Parameters
    ----------
    value : str, int or float
        e.g. ``"95 GHz"``, ``"0.8 mm"``, ``"0.5 rad"``, ``"20 degC"``, ``10`` (a bare number
        takes the kind's default unit: deg, m, K, g/m^3, mm/h, dB/km; a frequency needs a unit,
        except 0).
    kind : str
        One of ``frequency`` [Hz], ``length`` [m], ``angle`` [rad], ``temperature`` [K]
        (absolute), ``temperature_difference`` [K], ``density`` [kg/m^3], ``rate`` [m/s],
        ``attenuation`` [Np/m of power].
    file, key : optional
        Where the value came from, for the error message.
    unit : str, optional
        Return the value in this pint unit of the kind instead (e.g. ``deg``, ``mm/h``).

    Returns
    -------
    float
        The value in the internal unit (or ``unit``).

    Raises
    ------
    UserError
        Unreadable, of another kind, a bare number for a frequency, or not finite.
    """
    try:
        internal, bare_unit, example, noun = _KINDS[kind]
    except KeyError:  # programming error, not user error
        raise ValueError(f"unknown quantity kind {kind!r}") from None

    def fail(why: str) -> UserError:
        return UserError(f"{value!r} {why}; expected e.g. {example}", file, key)

    if isinstance(value, numbers.Real) and not isinstance(value, (bool, int, float)):
        value = float(value)  # a numpy scalar stands for the Python number (np.bool_ is no Real)
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise UserError(f"expected {_a(noun)} such as {example}, got {value!r}", file, key)
    if isinstance(value, str):
        m = _NUMBER.match(value)
        if not m:
            raise fail(f"is not {_a(noun)} (a number and a unit)")
        number, text = float(m.group(1)), m.group(2)
    else:
        number, text = float(value), ""
    factor = _EXACT[kind].get(text) if unit is None else None
    if factor is not None:
        if not math.isfinite(number):
            raise UserError(f"{value!r} is not a finite {noun}", file, key)
        return _checked(number * factor, value, kind, noun, file, key)
    reg = ureg()
    target = reg.Unit(_unit_text(unit, kind)) if unit is not None else reg.Unit(internal)
    if not text:
        if bare_unit is None and number != 0.0:  # zero is zero in any unit
            raise UserError(f"a bare number is ambiguous for {_a(noun)}: give a unit, e.g. {example}", file, key)
        units = reg.Unit(bare_unit or internal)
    else:
        try:
            units = reg.parse_units(_unit_text(text, kind))
        except Exception:  # pint raises several types for unknown or malformed units
            raise fail(f"has an unknown unit {text!r}{_case_hint(text)}") from None
    if not math.isfinite(number):
        raise UserError(f"{value!r} is not a finite {noun}", file, key)

    # same root units as the kind, so that dimensionless pint units are told apart
    try:
        root = reg.get_root_units(units)[1]
    except Exception:  # pint's logarithmic units (dB, Np) have no root units outside attenuation
        raise fail(f"is not {_a(noun)}") from None
    if root != reg.get_root_units(target)[1]:
        hint = ""
        if kind == "frequency" and "radian" in str(root):
            hint = " (an angular frequency: give a frequency in Hz)"
        elif kind == "attenuation" and root == reg.get_root_units("1/m")[1]:
            hint = " (give the level unit, dB or Np, over a length)"
        else:
            hint = _case_hint(text)
        raise fail(f"is not {_a(noun)}{hint}")
    q = reg.Quantity(number, units)
    if kind == "temperature" and any(name.startswith("delta_") for name, _ in q.unit_items()):
        raise UserError(
            f"{value!r} is a temperature difference; give an absolute temperature, e.g. {example}", file, key
        )
    if kind == "temperature_difference" and reg.Quantity(0.0, units).to(target).magnitude != 0.0:
        raise UserError(
            f"{value!r} is on an offset scale, ambiguous for a temperature difference; "
            f"give kelvin or delta_degC (2 K = 2 delta_degC), e.g. {example}",
            file,
            key,
        )
    return _checked(float(q.to(target).magnitude), value, kind, noun, file, key)


def _checked(
    out: float, value: object, kind: str, noun: str, file: str | Path | None = None, key: str | None = None
) -> float:
    """``out``, the parsed ``value`` in its unit, if it is finite and in the kind's range."""
    if not math.isfinite(out):
        raise UserError(f"{value!r} is not a finite {noun}", file, key)
    if kind == "temperature" and not 0.0 <= out <= TEMPERATURE_MAX:
        raise UserError(
            f"{value!r} is {'below absolute zero' if out < 0.0 else 'hotter than pmmw takes'}; "
            f"temperatures are 0 K to {TEMPERATURE_MAX:g} K",
            file,
            key,
        )
    if kind == "attenuation" and out < 0.0:
        raise UserError(f"attenuation must be >= 0, got {value!r}", file, key)
    return out
