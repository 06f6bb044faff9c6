"""Unit strings at the edge: ``"95 GHz"``, ``"0.8 mm"``, ``"10 deg"``, ``"300 K"`` -> SI floats.

Inside pmmw every quantity is SI: [Hz], [m], [rad], [K], [Np/m] for power attenuation, [kg/m^3].
pint parses the strings; this module only knows which dimension each kind of quantity has and
what a bare number means for it.
"""

from __future__ import annotations

import math
import re
from functools import lru_cache

import pint

from pmmw_cli.errors import UserError


@lru_cache(maxsize=1)
def ureg() -> pint.UnitRegistry:
    return pint.UnitRegistry(autoconvert_offset_to_baseunit=True)


_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*)$")


def _normalise(text: str) -> str:
    """Accept the usual shorthand for powers of units: ``g/m3`` -> ``g/m**3``."""
    m = _NUMBER.match(text)
    if not m:
        return text
    number, unit = m.groups()
    unit = re.sub(r"([A-Za-z])\^?(\d)", r"\1**\2", unit)
    return f"{number} {unit}".strip()


# kind -> (SI unit for pint, unit a bare number is taken in, or None if a unit is required)
_KINDS: dict[str, tuple[str, str | None]] = {
    "frequency": ("Hz", None),
    "length": ("m", "m"),
    "angle": ("rad", "deg"),
    "temperature": ("K", "K"),
    "density": ("kg/m**3", "g/m**3"),
    "rate": ("m/s", "mm/h"),
}

_DB_PER = {"db/km": 1e-3, "db/m": 1.0}
_NEPER_PER_DB = math.log(10.0) / 10.0  # power: 1 dB = ln(10)/10 Np


def parse_quantity(value, kind: str, *, file=None, key: str | None = None) -> float:
    """Parse a number or unit string into an SI float.

    Parameters
    ----------
    value : str, int or float
        e.g. ``"95 GHz"``, ``"0.8 mm"``, ``10`` (bare numbers take the kind's default unit).
    kind : str
        One of ``frequency`` [Hz], ``length`` [m], ``angle`` [rad], ``temperature`` [K],
        ``density`` [kg/m^3], ``rate`` [m/s], ``attenuation`` [Np/m of power].
    file, key : optional
        Where the value came from, for the error message.

    Returns
    -------
    float
        The value in SI units.
    """
    if kind == "attenuation":
        return _parse_attenuation(value, file=file, key=key)
    try:
        si_unit, bare_unit = _KINDS[kind]
    except KeyError:  # programming error, not user error
        raise ValueError(f"unknown quantity kind {kind!r}") from None
    if isinstance(value, bool):
        raise UserError(f"expected a {kind} such as {_example(kind)}, got {value!r}", file, key)
    if isinstance(value, (int, float)):
        if bare_unit is None:
            raise UserError(f"a bare number is ambiguous for a {kind}: give a unit, e.g. {_example(kind)}", file, key)
        q = ureg().Quantity(float(value), bare_unit)
    elif isinstance(value, str):
        try:
            q = ureg().Quantity(_normalise(value))
        except Exception:
            raise UserError(f"cannot read {value!r} as a {kind}; expected e.g. {_example(kind)}", file, key) from None
        if isinstance(q, (int, float)) or q.dimensionless:
            if bare_unit is None:
                raise UserError(f"{value!r} has no unit; expected a {kind} such as {_example(kind)}", file, key)
            q = ureg().Quantity(float(q.magnitude if hasattr(q, "magnitude") else q), bare_unit)
    else:
        raise UserError(f"expected a {kind} such as {_example(kind)}, got {type(value).__name__}", file, key)
    try:
        out = float(q.to(si_unit).magnitude)
    except pint.DimensionalityError:
        raise UserError(f"{value!r} is not a {kind}; expected e.g. {_example(kind)}", file, key) from None
    if not math.isfinite(out):
        raise UserError(f"{value!r} is not a finite {kind}", file, key)
    return out


def _parse_attenuation(value, *, file, key) -> float:
    """``"0.9 dB/km"`` -> power attenuation coefficient [Np/m]; bare numbers are dB/km."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        db, per = float(value), "db/km"
    elif isinstance(value, str):
        parts = value.strip().split()
        try:
            db = float(parts[0])
            per = "".join(parts[1:]).lower() or "db/km"
        except (ValueError, IndexError):
            raise UserError(f"cannot read {value!r} as an attenuation; expected e.g. '0.9 dB/km'", file, key) from None
        if per not in _DB_PER:
            raise UserError(f"unknown attenuation unit in {value!r}; use dB/km or dB/m", file, key)
    else:
        raise UserError(f"expected an attenuation such as '0.9 dB/km', got {value!r}", file, key)
    if not math.isfinite(db) or db < 0:
        raise UserError(f"attenuation must be finite and >= 0, got {value!r}", file, key)
    return db * _DB_PER[per] * _NEPER_PER_DB


def _example(kind: str) -> str:
    return {
        "frequency": "'95 GHz'",
        "length": "'0.8 mm' or '600 m'",
        "angle": "'10 deg'",
        "temperature": "'300 K'",
        "density": "'0.3 g/m3'",
        "rate": "'10 mm/h'",
    }.get(kind, "a number with a unit")
