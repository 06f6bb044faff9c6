"""The material database: ``materials/*.yaml`` plus a scenario's ``materials:`` overrides.

An entry (the same schema in the database files and in a scenario's ``materials:`` map)::

    concrete:
      name: Concrete
      eps: {35 GHz: [5.5, 0.5], 95 GHz: [2.49, 6.8e-2]}   # [eps', eps''] per frequency
      temperature: 300 K          # optional physical temperature
      kind: dielectric            # dielectric (default) | metal | blackbody | opaque | thin
      source: "Murakowski 2014 Table A.1, refs [19, 15]"
      coating:                    # optional, outermost layer first
        - {material: denim, thickness: 0.8 mm, temperature: 300 K}
      thickness: 1 mm             # only for kind thin (the sheet's own thickness)
      roughness: {model: ggx, alpha: 0.3}   # optional microfacet roughness of the surface
      bump: {model: gaussian, rms: 3 mm, correlation: 3 cm, size: 1 m}   # optional bump map
      extrapolate: hold           # beyond the table: hold (default) | trend

``eps: [eps', eps'']`` (no frequencies) is one value for every frequency. eps = eps' + i eps'',
eps'' >= 0 lossy (``docs/ARCHITECTURE.md``). ``metal`` and ``blackbody`` have no ``eps``
(Murakowski 2014 sec. 2.2.9); every other kind needs one. Between tabulated frequencies eps' and eps''
are interpolated linearly in frequency; outside the table the nearest tabulated value is used
(``extrapolate: hold``) or, with ``extrapolate: trend``, eps' and eps'' each continue the power law
a f^b through the table's two end rows (the form in which ITU-R P.2040 writes every material), and
either way a warning names the material and its range.

``roughness:`` is a microfacet model of the surface (`pmmw.physics.roughness.make_model`:
``ashikhmin_shirley``, ``blinn_phong``, ``ggx``, ``beckmann``, ``blender_gloss``); without it the
surface is smooth. Coating layers without their own ``roughness:`` follow the facets of the
surface they lie on (coherent, conformal films). ``bump:`` perturbs the macro normal with a height
map (`pmmw.scene.bump`): an image file or a Gaussian random surface.

Everything is validated at load time and every problem is reported with its file and dotted key
path (``materials.runway.eps."95 GHz"``); problems are collected across entries and raised
together (`pmmw.errors.UserErrors`).
"""

from __future__ import annotations

import bisect
import difflib
import math
import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Iterable, Literal, Optional, get_args

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, StrictStr, ValidationError

from pmmw.errors import UserError, UserErrors, warn
from pmmw.io.records import key_path, problem, unknown_key
from pmmw.io.yamlio import read_yaml
from pmmw.physics.roughness import make_model
from pmmw.scene.bump import make_bump
from pmmw.scene.dielectric import make_dielectric
from pmmw.units import parse_quantity

if TYPE_CHECKING:
    from pmmw.physics.roughness import MicrofacetModel
    from pmmw.scene.bump import BumpMap
    from pmmw.scene.dielectric import DielectricModel

Kind = Literal["dielectric", "metal", "blackbody", "opaque", "thin"]
KINDS: tuple[str, ...] = get_args(Kind)
_NO_EPS_KINDS = ("metal", "blackbody")
# lower_snake_case, optionally in one named set: ``water``, ``murakowski2014.water``
_ID_RE = re.compile(r"^(?:[a-z][a-z0-9]*\.)?[a-z][a-z0-9]*(?:_[a-z0-9]+)*$")
_ENTRY_KEYS = (
    "name",
    "eps",
    "model",
    "temperature",
    "kind",
    "source",
    "coating",
    "thickness",
    "roughness",
    "bump",
    "same_as",
    "extrapolate",
)
_LAYER_KEYS = ("material", "thickness", "temperature", "roughness")
_EPS_EXAMPLE = "[eps', eps''] or {35 GHz: [eps', eps''], 95 GHz: [eps', eps'']}"
_LAYER_EXAMPLE = "{material: ID, thickness: '0.8 mm', temperature: '300 K'}"
FREQ_REL_TOL = 1e-9  # frequencies closer than this (relative) are the same frequency
Extrapolate = Literal["hold", "trend"]
EXTRAPOLATE: tuple[str, ...] = get_args(Extrapolate)
# [-] steepest power law `extrapolate: trend` continues: a f^b steeper than this between two rows is
# a resonance or rows too close together, not a trend (ITU-R P.2040-4's steepest, the floorboard's
# eps'' in its 220-300 GHz row, goes as f^6.3)
TREND_EXPONENT_MAX = 10.0


# ----------------------------------------------------------------------------------------------
# Public data types
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CoatingLayer:
    """One coherent layer of a coating (Murakowski 2014 sec. 2.2.3).

    Attributes
    ----------
    material : str
        Database id of the layer's material (a kind with a permittivity, itself uncoated).
    thickness : float
        [m].
    temperature : float or None
        [K]; None -> the layer material's temperature (and if that is None too, the caller's
        default, e.g. the coated material's temperature).
    roughness : MicrofacetModel or None
        Roughness of the layer's own top surface; None: the layer is a coherent film following
        the facets of the surface below it.
    """

    material: str
    thickness: float
    temperature: float | None
    roughness: MicrofacetModel | None = None

    def temperature_over(self, material: Material, below: float) -> float:
        """The layer's temperature [K]: its own, else its material's (``material``, the layer's
        database entry), else ``below``, the temperature of the surface it lies on."""
        if self.temperature is not None:
            return self.temperature
        return material.temperature if material.temperature is not None else below


@dataclass(frozen=True)
class Material:
    """One resolved material.

    Attributes
    ----------
    id, name : str
    kind : str
        One of `KINDS`.
    freqs : tuple of float
        Tabulated frequencies [Hz], ascending. Empty for metal/blackbody, and for a dielectric
        given one frequency-independent ``eps: [eps', eps'']`` (then `eps` has one value).
    eps : tuple of complex
        eps' + 1j eps'' at each of `freqs` (or the single frequency-independent value).
    temperature : float or None
        Physical temperature [K]; None -> the scenario decides.
    coating : tuple of CoatingLayer
        Outermost layer first.
    thickness : float or None
        The sheet's own thickness [m] (kind ``thin`` only).
    roughness : MicrofacetModel or None
        Microfacet roughness of the surface (`pmmw.physics.roughness`); None: smooth.
    bump : BumpMap or None
        Height map perturbing the surface's macro normal (`pmmw.scene.bump`).
    model : DielectricModel or None
        A physical permittivity model (`pmmw.scene.dielectric`) instead of a table: eps at
        any frequency and at the material's temperature.
    source : str
        Where the numbers come from.
    origin : str
        File the entry came from (the scenario file for an override), for error messages.
    extrapolate : str
        A table beyond its first and last rows: ``hold`` the end row's value, or continue the
        ``trend`` (`_trend`); warned either way.
    """

    id: str
    name: str
    kind: str
    freqs: tuple[float, ...]
    eps: tuple[complex, ...]
    temperature: float | None
    coating: tuple[CoatingLayer, ...] = ()
    thickness: float | None = None
    roughness: MicrofacetModel | None = None
    bump: BumpMap | None = None
    model: DielectricModel | None = None
    source: str = ""
    origin: str = ""
    extrapolate: str = "hold"

    def has_eps(self) -> bool:
        """Whether the entry gives a permittivity (a table, a constant or a model)."""
        return bool(self.eps) or self.model is not None

    def model_temperature(self, temperature: float | None = None) -> float:
        """The temperature [K] a model is evaluated at: the one asked, else the material's, else
        the model's reference temperature. ValueError for a material without a model when neither
        temperature is given."""
        if temperature is not None:
            return temperature
        if self.temperature is not None:
            return self.temperature
        if self.model is None:
            raise ValueError(f"material {self.id!r} has no model (and so no reference temperature)")
        return self.model.spec.t_ref

    def eps_at(self, f: float, temperature: float | None = None) -> complex:
        """Relative permittivity at frequency `f` [Hz].

        Linear interpolation of eps' and eps'' in frequency between tabulated points; outside
        the tabulated range the nearest tabulated value (or, with ``extrapolate: trend``, the
        power law through the two end rows, `_trend`), with a warning (once per material)
        naming the material and its range. A frequency-independent entry returns its value.
        A model entry (`model`) is evaluated at `temperature` [K] (default: the material's own,
        else the model's reference temperature), with a warning outside the model's range.

        Raises
        ------
        ValueError
            For ``metal`` and ``blackbody`` (no permittivity), or a frequency that is not
            finite and positive. Callers never ask in those cases.
        """
        value, outside = self._lookup(f, temperature)
        if outside and self.model is not None:
            t = self.model_temperature(temperature)
            warn(
                f"material {self.id!r}: {f / 1e9:g} GHz at {t:g} K is outside the {self.model.describe()}; "
                f"{self.outside_note(f, temperature)}"
            )
        elif outside:
            warn(
                f"material {self.id!r}: {f / 1e9:g} GHz is outside its table ({_range_text(self.freqs)}); "
                f"{self.outside_note(f, temperature)}"
            )
        return value

    def outside_note(self, f: float, temperature: float | None = None) -> str:
        """What is done at f [Hz] (and a model's temperature [K]) outside the stated range: a
        table's nearest value, a model extrapolated, a P.2040 gap interpolated between its rows."""
        if self.model is not None:
            return self.model.outside(f, self.model_temperature(temperature)) or "inside the model's range"
        if self.extrapolate == "trend" and len(self.freqs) >= 2:
            (f1, e1), (f2, e2) = self._end_rows(f)
            b_re, b_im = _exponent(f1, e1.real, f2, e2.real), _exponent(f1, e1.imag, f2, e2.imag)
            return (
                f"extrapolated by the power law through its rows at {_fmt_f(f1)} and {_fmt_f(f2)} "
                f"(eps' as f^{b_re:.3g}, eps'' as f^{b_im:.3g}; extrapolate: trend)"
            )
        return "the nearest tabulated value is used"

    def range_edges(self) -> tuple[float, ...]:
        """Frequencies [Hz] where the entry's stated range may begin or end: a table's first and
        last rows, a model's range and its `ModelSpec.intervals` (a published fit's own ``valid``,
        ITU-R P.2040's rows). Between two of them
        whether a frequency is inside is the same everywhere (`stated_band`)."""
        if self.model is None:
            return (self.freqs[0], self.freqs[-1]) if self.freqs else ()
        spec = self.model.spec
        return tuple(spec.f_range) + spec.edges(self.model.params)

    def _end_rows(self, f: float) -> tuple[tuple[float, complex], tuple[float, complex]]:
        """The table's end row on f's side (f [Hz] outside the table) and the row next to it."""
        i, j = (0, 1) if f < self.freqs[0] else (-1, -2)
        return (self.freqs[i], self.eps[i]), (self.freqs[j], self.eps[j])

    def _lookup(self, f: float, temperature: float | None = None) -> tuple[complex, bool]:
        """(eps at f [Hz] and temperature [K] (a model's; default the material's), whether f or the
        temperature lies outside the table's or the model's range) without warning."""
        if self.kind in _NO_EPS_KINDS or not self.has_eps():
            raise ValueError(f"material {self.id!r} is of kind {self.kind!r} and has no permittivity")
        f = float(f)
        if not (math.isfinite(f) and f > 0):
            raise ValueError(f"frequency must be finite and > 0 Hz, got {f!r}")
        if self.model is not None:
            t = self.model_temperature(temperature)
            return self.model.eps(f, t), not self.model.in_range(f, t)
        if not self.freqs:
            return complex(self.eps[0]), False
        fs = self.freqs
        lo, hi = fs[0], fs[-1]
        if f < lo * (1 - FREQ_REL_TOL) or f > hi * (1 + FREQ_REL_TOL):
            if self.extrapolate != "trend" or len(fs) < 2:
                return complex(self.eps[0] if f < lo else self.eps[-1]), True
            (f1, e1), (f2, e2) = self._end_rows(f)
            return complex(_trend(f, f1, e1.real, f2, e2.real), _trend(f, f1, e1.imag, f2, e2.imag)), True
        j = bisect.bisect_left(fs, f)  # fs[j - 1] < f <= fs[j]: a table of any length in log time
        for k in (j - 1, j):  # exact hits (and single-frequency tables)
            if 0 <= k < len(fs) and abs(f - fs[k]) <= FREQ_REL_TOL * fs[k]:
                return complex(self.eps[k]), False
        pair, (e0, e1) = fs[j - 1 : j + 1], self.eps[j - 1 : j + 1]  # np.interp's own formula on its segment
        return complex(
            float(np.interp(f, pair, [e0.real, e1.real])), float(np.interp(f, pair, [e0.imag, e1.imag]))
        ), False


def _exponent(f1: float, v1: float, f2: float, v2: float) -> float:
    """b of the power law v = a f^b through (f1, v1) and (f2, v2); 0 (the value held) where either
    value is not positive (no power law passes through zero)."""
    if not (v1 > 0.0 and v2 > 0.0):
        return 0.0
    return math.log(v2 / v1) / math.log(f2 / f1)


def _trend(f: float, f1: float, v1: float, f2: float, v2: float) -> float:
    """The power law a f^b through the end row (f1, v1) and the row next to it (f2, v2), at f [Hz]
    beyond f1: v1 (f / f1)^b. The exponent is bounded by `TREND_EXPONENT_MAX` when the entry is
    built, so the value stays finite for every frequency a scenario accepts."""
    return v1 * math.exp(_exponent(f1, v1, f2, v2) * math.log(f / f1))


def stated_band(
    db: MaterialDB, material_ids: Iterable[str], t_default: float, f_range: tuple[float, float]
) -> tuple[list[tuple[float, float]], dict[str, list[tuple[float, float]]]]:
    """Where in ``f_range`` [Hz] a scene's materials are all inside their stated ranges.

    Each material of ``material_ids`` with a permittivity, at its own temperature (else
    ``t_default`` [K]), and each of its coating layers at theirs (`CoatingLayer.temperature_over`),
    as the renderer takes them (`pmmw.surface.media.build_media`). Whether a frequency is inside can
    change only at a material's `Material.range_edges`, so each edge and one frequency between each
    two neighbours (their geometric mean) decide it; a log grid of 64 points is added for models
    whose range the edges do not name.

    Returns
    -------
    (band, limits)
        ``band``: the closed intervals (f_lo, f_hi) [Hz] where every material is inside (a single
        frequency as (f, f); empty: nowhere); ``limits``: per material (a coating layer as
        ``'coated: layer'``) whose own inside set is not the whole ``f_range``, its intervals.
    """
    lo, hi = f_range
    uses: dict[str, tuple[Material, float]] = {}
    for mid in material_ids:
        m = db.get(mid)
        t_m = m.temperature if m.temperature is not None else t_default
        if m.kind not in _NO_EPS_KINDS and m.has_eps():
            uses[mid] = (m, t_m)
        for layer in m.coating:
            lm = db.get(layer.material)
            if lm.kind not in _NO_EPS_KINDS and lm.has_eps():
                uses[f"{mid}: {layer.material}"] = (lm, layer.temperature_over(lm, t_m))
    edges = {float(lo), float(hi), *map(float, np.geomspace(lo, hi, 64))}  # plain floats: reports are YAML
    for m, _ in uses.values():
        edges |= {float(f) for f in m.range_edges() if lo <= f <= hi}
    edges_sorted = sorted(edges)
    points = [edges_sorted[0]]
    for a, b in zip(edges_sorted, edges_sorted[1:]):
        points += [math.sqrt(a * b), b]

    def intervals(inside: list[bool]) -> list[tuple[float, float]]:
        out: list[tuple[float, float]] = []
        start = None
        for k, ok in enumerate(inside):
            if ok and start is None:
                start = k
            if start is not None and (not ok or k == len(inside) - 1):
                end = k if ok else k - 1
                out.append((points[start], points[end]))
                start = None
        return out

    each = {name: [not m._lookup(f, t)[1] for f in points] for name, (m, t) in uses.items()}
    band = intervals([all(col) for col in zip(*each.values())] if each else [True] * len(points))
    limits = {name: intervals(ok) for name, ok in each.items() if not all(ok)}
    return band, limits


def band_text(intervals: list[tuple[float, float]]) -> str:
    """``[(35e9, 95e9)]`` -> ``'35-95 GHz'``; a single frequency ``'35 GHz'``; several joined by
    commas; none ``'nowhere'``."""
    if not intervals:
        return "nowhere"
    parts = [f"{a / 1e9:.4g}" if a == b else f"{a / 1e9:.4g}-{b / 1e9:.4g}" for a, b in intervals]
    return ", ".join(parts) + " GHz"


# ----------------------------------------------------------------------------------------------
# Key paths
# ----------------------------------------------------------------------------------------------

_PLAIN_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def _join(base: str | None, *parts: object) -> str:
    """Dotted key path (`pmmw.io.records.key_path`): ``_join("materials", "runway", "eps", "95 GHz", 1)``
    -> ``materials.runway.eps."95 GHz"[1]``."""
    return key_path(parts, base)


# ----------------------------------------------------------------------------------------------
# Entry schema (pydantic v2): structure here, numbers through `parse_quantity`
# ----------------------------------------------------------------------------------------------


class _Problems(ValueError):
    """Problems found inside one field, each with a key path relative to that field."""

    def __init__(self, problems: list[tuple[tuple, str]]) -> None:
        super().__init__("; ".join(m for _, m in problems))
        self.problems = problems


def _temperature(value):
    if value is None:
        return None
    try:
        t = parse_quantity(value, "temperature")
    except UserError as e:
        raise ValueError(e.message) from None
    if not t > 0:
        raise ValueError(f"temperature must be > 0 K, got {value!r}")
    return t


def _length(value):
    if value is None:
        return None
    try:
        d = parse_quantity(value, "length")
    except UserError as e:
        raise ValueError(e.message) from None
    if not d >= 0:
        raise ValueError(f"thickness must be >= 0, got {value!r}")
    return d


def _number(x: object) -> float:
    """A finite real number; YAML 1.1 reads ``7e-3`` (no dot) as a string, so accept those."""
    if isinstance(x, bool):
        raise ValueError
    if isinstance(x, (int, float)):
        v = float(x)
    elif isinstance(x, str):
        v = float(x.strip())
    else:
        raise ValueError
    if not math.isfinite(v):
        raise ValueError
    return v


def _eps_pair(value: object, path: tuple, problems: list) -> complex | None:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        problems.append((path, f"expected [eps', eps''] (two numbers), got {value!r}"))
        return None
    out = []
    for i, x in enumerate(value):
        try:
            out.append(_number(x))
        except (ValueError, TypeError):
            problems.append((path + (i,), f"expected a finite number, got {x!r}"))
    if len(out) != 2:
        return None
    re_, im_ = out
    if im_ < 0:
        problems.append((path + (1,), f"eps'' must be >= 0 (eps = eps' + i eps'', eps'' > 0 is lossy), got {im_:g}"))
        return None
    if re_ == 0 and im_ == 0:
        problems.append((path, "eps = 0 is not a medium"))
        return None
    return complex(re_, im_)


def _eps(value):
    """``[a, b]`` or ``{freq: [a, b], ...}`` -> (freqs, eps) ascending in frequency."""
    if value is None:
        return None
    problems: list[tuple[tuple, str]] = []
    if isinstance(value, (list, tuple)):
        e = _eps_pair(value, (), problems)
        if problems:
            raise _Problems(problems)
        return ((), (e,))
    if not isinstance(value, dict):
        raise ValueError(f"expected {_EPS_EXAMPLE}, got {value!r}")
    if not value:
        raise ValueError(f"empty permittivity table; expected {_EPS_EXAMPLE}")
    rows: list[tuple[float, int, Any, tuple, complex]] = []
    for k, v in value.items():
        path = (str(k),)
        f = None
        try:
            f = parse_quantity(k, "frequency")
            if not f > 0:
                problems.append((path, f"frequency must be > 0, got {k!r}"))
                f = None
        except UserError as err:
            problems.append((path, err.message))
        e = _eps_pair(v, path, problems)
        if f is not None and e is not None:
            rows.append((f, len(rows), k, path, e))
    # the same frequency twice (to FREQ_REL_TOL): neighbours once sorted, so a long table costs n log n
    table: dict[float, complex] = {}
    kept: tuple[float, Any] | None = None
    twice = []
    for f, i, k, path, e in sorted(rows, key=lambda r: (r[0], r[1])):
        if kept is not None and abs(f - kept[0]) <= FREQ_REL_TOL * f:
            twice.append((i, path, f"frequency {k!r} given twice (also as {kept[1]!r})"))
            continue
        kept = (f, k)
        table[f] = e
    problems += [(path, message) for _, path, message in sorted(twice, key=lambda t: t[0])]
    if problems:
        raise _Problems(problems)
    freqs = tuple(table)  # inserted in ascending order
    return (freqs, tuple(table[f] for f in freqs))


_Temperature = Annotated[Any, BeforeValidator(_temperature)]
_Length = Annotated[Any, BeforeValidator(_length)]
_Eps = Annotated[Any, BeforeValidator(_eps)]


class _LayerIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    material: StrictStr
    thickness: _Length
    temperature: _Temperature = None
    roughness: Any = None  # checked by roughness.make_model (key paths of its own)


class _EntryIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: Optional[StrictStr] = None
    eps: _Eps = None
    temperature: _Temperature = None
    kind: Optional[Kind] = None
    source: Optional[StrictStr] = None
    coating: Optional[list[_LayerIn]] = None
    thickness: _Length = None
    roughness: Any = None  # checked by roughness.make_model
    bump: Any = None  # checked by bump.make_bump
    model: Any = None  # checked by dielectric.make_dielectric
    same_as: Optional[StrictStr] = None  # another id whose fields this entry takes (resolved by _same_as)
    extrapolate: Optional[Extrapolate] = None  # a table beyond its ends: hold (default) | trend


def _suggest(word: object, choices: Iterable[str], n: int = 5) -> str:
    close = difflib.get_close_matches(str(word), list(choices), n=n, cutoff=0.6)
    return f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""


def _pydantic_errors(ex: ValidationError, file: str | Path, base_key: str) -> list[UserError]:
    """pydantic's problems with one entry, in `pmmw.io.records`' wording but for the entry's own
    messages (`_wording`); a field's several problems (`_Problems`) each with its own key."""
    out = []
    for er in ex.errors():
        err = er.get("ctx", {}).get("error") if er["type"] == "value_error" else None
        if isinstance(err, _Problems):
            out += [UserError(m, file, _join(base_key, *er["loc"], *p)) for p, m in err.problems]
        else:
            out.append(problem(er, file, _EntryIn, prefix=base_key, wording=_wording))
    return out


def _wording(er: Mapping[str, Any], loc: list) -> str | None:
    """The material entry's own messages: the keys of an entry or a coating layer, what a layer
    looks like, the kinds; None: the common wording."""
    typ = er["type"]
    in_layer = len(loc) >= 2 and loc[0] == "coating"
    if typ == "extra_forbidden":
        allowed = _LAYER_KEYS if in_layer else _ENTRY_KEYS
        what = "coating layer" if in_layer else "material"
        return unknown_key(loc[-1], allowed, what)
    if typ == "missing":
        return f"missing required key {loc[-1]!r}" + (f" (a coating layer is {_LAYER_EXAMPLE})" if in_layer else "")
    if typ in ("model_type", "model_attributes_type", "dict_type"):
        if in_layer:
            return f"expected a coating layer {_LAYER_EXAMPLE}, got {er.get('input')!r}"
        return f"expected a mapping of material fields ({', '.join(_ENTRY_KEYS)}), got {er.get('input')!r}"
    if typ == "list_type":
        return "expected a list of layers, outermost first, e.g. [{material: denim, thickness: 0.8 mm}]"
    if typ == "literal_error":
        got = er.get("input")
        if loc and loc[-1] == "extrapolate":
            return (
                f"unknown extrapolate {got!r}{_suggest(got, EXTRAPOLATE, 1)} (expected hold: the end row's "
                "value, or trend: the power law through the two end rows)"
            )
        return f"unknown kind {got!r}{_suggest(got, KINDS, 1)} (expected one of {', '.join(KINDS)})"
    if typ == "string_type":
        return f"expected a string, got {er.get('input')!r}"
    return None


def _parse_entry(mid: str, raw: object, file: str | Path, base_key: str) -> tuple[dict | None, list[UserError]]:
    """Validate one raw entry -> the fields it sets (SI values), or None and the errors."""
    if raw is None:
        raw = {}
    try:
        m = _EntryIn.model_validate(raw)
    except ValidationError as ex:
        return None, _pydantic_errors(ex, file, base_key)
    fields = {k: getattr(m, k) for k in m.model_fields_set}
    errors: list[UserError] = []

    def checked(make, spec, key):
        if spec is None:
            return None
        try:
            return make(spec, file=file, key=key)
        except UserErrors as ex:
            errors.extend(ex.errors)
        except UserError as ex:
            errors.append(ex)
        return None

    if "roughness" in fields:
        fields["roughness"] = checked(make_model, m.roughness, _join(base_key, "roughness"))
    if "bump" in fields:
        fields["bump"] = checked(make_bump, m.bump, _join(base_key, "bump"))
    if "model" in fields:
        fields["model"] = checked(make_dielectric, m.model, _join(base_key, "model"))
    if "coating" in fields:
        fields["coating"] = tuple(
            CoatingLayer(
                layer.material,
                float(layer.thickness),
                layer.temperature,
                checked(make_model, layer.roughness, _join(base_key, "coating", i, "roughness")),
            )
            for i, layer in enumerate(m.coating or [])
        )
    return (None, errors) if errors else (fields, [])


def _build(mid: str, fields: dict, origin: str, base_key: str) -> tuple[Material | None, list[UserError]]:
    """Apply defaults and the per-entry rules to validated fields."""
    errors = []
    kind = fields.get("kind") or "dielectric"
    eps = fields.get("eps")
    thickness = fields.get("thickness")
    freqs: tuple = ()
    values: tuple = ()
    if kind in _NO_EPS_KINDS:
        if eps is not None:
            errors.append(
                UserError(
                    f"a {kind} has no permittivity (Murakowski 2014 sec. 2.2.9): remove `eps`, or use kind dielectric or opaque",
                    origin,
                    _join(base_key, "eps"),
                )
            )
    elif eps is not None and fields.get("model") is not None:
        errors.append(
            UserError("give `eps` (a table) or `model` (a physical model), not both", origin, _join(base_key, "model"))
        )
    elif eps is None and fields.get("model") is None:
        errors.append(
            UserError(f"kind {kind} needs `eps` ({_EPS_EXAMPLE}) or `model` (e.g. {{name: water}})", origin, base_key)
        )
    elif eps is not None:
        freqs, values = eps
    if kind == "thin" and thickness is None:
        errors.append(
            UserError("kind thin needs `thickness` (the sheet's own thickness, e.g. 0.1 mm)", origin, base_key)
        )
    if kind == "thin":
        errors += [
            UserError(
                "a thin sheet's coating layers cannot be rough (the sheet is traced as one coherent "
                "stack): remove the layer's roughness",
                origin,
                _join(base_key, "coating", i, "roughness"),
            )
            for i, layer in enumerate(fields.get("coating") or ())
            if layer.roughness is not None
        ]
    errors += _extrapolate_errors(fields.get("extrapolate"), kind, eps, fields.get("model"), origin, base_key)
    if kind != "thin" and thickness is not None:
        errors.append(
            UserError(
                "`thickness` is only for kind thin (the sheet's own thickness); layers on a surface go in `coating`",
                origin,
                _join(base_key, "thickness"),
            )
        )
    if errors:
        return None, errors
    mat = Material(
        id=mid,
        name=fields.get("name") or mid.replace("_", " ").capitalize(),
        kind=kind,
        freqs=tuple(float(f) for f in freqs),
        eps=tuple(complex(e) for e in values),
        temperature=fields.get("temperature"),
        coating=tuple(fields.get("coating") or ()),
        thickness=thickness,
        roughness=fields.get("roughness"),
        bump=fields.get("bump"),
        model=fields.get("model"),
        source=fields.get("source") or "",
        origin=str(origin),
        extrapolate=fields.get("extrapolate") or "hold",
    )
    return mat, []


def _extrapolate_errors(
    how: str | None, kind: str, eps: tuple | None, model: object, origin: str, base_key: str
) -> list[UserError]:
    """What is wrong with an entry's ``extrapolate``: it is for a table of at least two rows (and
    ``trend`` only where the two end rows' power laws are no steeper than `TREND_EXPONENT_MAX`)."""
    if how is None:
        return []
    key = _join(base_key, "extrapolate")
    if kind in _NO_EPS_KINDS or model is not None:
        what = f"a {kind} has none" if kind in _NO_EPS_KINDS else "a model extrapolates by its own formula"
        return [UserError(f"`extrapolate` is for a permittivity table; {what}: remove it", origin, key)]
    if eps is None:
        return []  # the missing eps is reported already
    freqs, values = eps
    if len(freqs) < 2:
        return [
            UserError(
                "`extrapolate` needs a table of at least two frequencies (one value holds at every "
                "frequency): remove it, or give eps per frequency",
                origin,
                key,
            )
        ]
    if how != "trend":
        return []
    ends = [((freqs[0], values[0]), (freqs[1], values[1]))]
    if len(freqs) > 2:  # a table of two rows has one pair for both ends
        ends.append(((freqs[-1], values[-1]), (freqs[-2], values[-2])))
    errors = []
    for (f1, e1), (f2, e2) in ends:
        for part, v1, v2 in (("eps'", e1.real, e2.real), ("eps''", e1.imag, e2.imag)):
            b = _exponent(f1, v1, f2, v2)
            if abs(b) > TREND_EXPONENT_MAX:
                errors.append(
                    UserError(
                        f"extrapolate: trend would continue {part} as f^{b:.3g} (its rows at {_fmt_f(f1)} and "
                        f"{_fmt_f(f2)}); steeper than f^{TREND_EXPONENT_MAX:g} is a resonance or rows too "
                        "close together, not a trend: use hold, or give rows further apart",
                        origin,
                        key,
                    )
                )
    return errors


def _check_id(mid: object, file: str | Path, base_key: str) -> list[UserError]:
    if not isinstance(mid, str):
        return [UserError(f"a material id must be a string, got {mid!r}", file, base_key)]
    if not _ID_RE.match(mid):
        return [
            UserError(
                f"material id {mid!r} must be lower_snake_case, optionally in a named set (e.g. "
                "moist_soil, murakowski2014.water)",
                file,
                base_key,
            )
        ]
    return []


def _same_as(
    mid: str, fields: dict, known: dict[str, dict], file: str | Path, base_key: str
) -> tuple[dict | None, list[UserError]]:
    """The fields of an entry with ``same_as: OTHER``: OTHER's fields, then the entry's own on top
    (e.g. a `name`, a `temperature`); the source says where the values come from. `known` maps ids
    to their resolved fields. Entries without ``same_as`` are returned as they are."""
    target = fields.get("same_as")
    if target is None:
        return fields, []
    if target not in known:
        return None, [
            UserError(
                f"unknown material {target!r} in same_as{_suggest(target, known, 3)}", file, _join(base_key, "same_as")
            )
        ]
    own = {k: v for k, v in fields.items() if k != "same_as"}
    merged = _merged({k: v for k, v in known[target].items() if k != "same_as"}, own)
    if "source" not in own:
        base = known[target].get("source") or ""
        merged["source"] = f"as {target}: {base}" if base else f"as {target}"
    return merged, []


def _merged(base: dict, own: dict) -> dict:
    """An entry's fields over those it starts from (an override over the database's entry, a
    ``same_as`` entry over its target), less what the result cannot have unless given again: a
    new kind without a permittivity drops eps and extrapolate, another kind than thin its
    thickness; a new eps of one value or one row drops an inherited extrapolate (it is for a table
    of two rows or more)."""
    merged = {**base, **own}
    kind = merged.get("kind") or "dielectric"
    if "kind" in own:
        if kind in _NO_EPS_KINDS:
            for key in ("eps", "extrapolate"):
                if key not in own:
                    merged.pop(key, None)
        if kind != "thin" and "thickness" not in own:
            merged.pop("thickness", None)
    eps = own.get("eps")
    if eps is not None and len(eps[0]) < 2 and "extrapolate" not in own:
        merged.pop("extrapolate", None)
    return merged


def _same_as_order(ids: Iterable, target: Callable[[Any], object]) -> tuple[list, list]:
    """``ids`` in an order where each comes after the id its ``same_as`` names (``target(id)``:
    that id when it is among ``ids`` and another, else None), whatever order they are given in:
    a database's entries across its files, a scenario's ``materials:`` map. Returns (that order,
    the ids whose same_as goes round in a circle)."""
    pending: list = list(ids)
    order: list = []
    while pending:
        ready = [m for m in pending if target(m) not in pending]
        if not ready:
            return order, pending
        order += ready
        pending = [m for m in pending if m not in ready]
    return order, []


def _circles(
    circles: Iterable, same_as: Callable[[Any], object], file_of: Callable[[Any], Any], key_of: Callable[[Any], Any]
) -> list[UserError]:
    """One error per entry of a same_as circle, at its ``same_as`` key."""
    return [
        UserError(f"same_as {same_as(mid)!r} goes round in a circle", file_of(mid), _join(key_of(mid), "same_as"))
        for mid in circles
    ]


def _raise(errors: list[UserError]) -> None:
    if len(errors) == 1:
        raise errors[0]
    if errors:
        raise UserErrors(errors)


def _read_yaml(path: Path) -> Any:
    return read_yaml(path, "material database file")


# ----------------------------------------------------------------------------------------------
# The database
# ----------------------------------------------------------------------------------------------


def default_materials_dir() -> Path:
    """``$PMMW_MATERIALS`` if set, else ``<repo root>/materials``."""
    env = os.environ.get("PMMW_MATERIALS")
    if env:
        return Path(env).expanduser()
    return Path(__file__).resolve().parents[2] / "materials"


def _database_files(paths: str | os.PathLike[str] | Iterable[str | os.PathLike[str]] | None) -> list[Path]:
    if paths is None:
        d = default_materials_dir()
        if not d.is_dir():
            raise UserError("material database folder not found (set PMMW_MATERIALS to override)", d)
        paths = [d]
    elif isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    files: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found = sorted([*p.glob("*.yaml"), *p.glob("*.yml")])
            if not found:
                raise UserError("no *.yaml material files in this folder", p)
            files += found
        elif p.is_file():
            files.append(p)
        else:
            raise UserError("material database file not found", p)
    return files


# Ids a user may look for that have no entry because no printed source was found
# (docs/materials.md, "Not found"): the error says so instead of only "unknown".
UNSOURCED = {
    "cotton": "cotton fabric",
    "wool": "wool fabric",
    "nylon_fabric": "nylon fabric",
    "abs": "ABS plastic",
    "polycarbonate": "polycarbonate",
}


class MaterialDB:
    """The material database: immutable; `with_overrides` returns a new one.

    Use `MaterialDB.load()` (every ``*.yaml`` in `default_materials_dir()`), then
    ``db.with_overrides(scenario_materials, file=scenario_path)``, then ``db.get(id)``.
    """

    def __init__(self, materials: dict[str, Material], fields: dict[str, dict], keys: dict[str, str]) -> None:
        self._materials = dict(materials)
        self._fields = {k: dict(v) for k, v in fields.items()}  # validated SI fields, for overrides
        self._keys = dict(keys)  # id -> key path of the entry in its origin file

    # -- construction ------------------------------------------------------------------------

    @classmethod
    def load(cls, paths: str | os.PathLike[str] | Iterable[str | os.PathLike[str]] | None = None) -> MaterialDB:
        """Read and validate database files.

        Parameters
        ----------
        paths : path or list of paths, optional
            Files, or folders whose ``*.yaml`` files are read (sorted by name). None ->
            every ``*.yaml`` in `default_materials_dir()`.

        Raises
        ------
        UserError or UserErrors
            Malformed YAML (file and line), an invalid entry (file and key path), the same id
            in two files (naming both), a coating naming an unknown or unusable material.
        """
        errors: list[UserError] = []
        materials: dict[str, Material] = {}
        fields: dict[str, dict] = {}
        keys: dict[str, str] = {}
        where: dict[str, Path] = {}
        for path in _database_files(paths):
            try:
                data = _read_yaml(path)
            except UserError as e:
                errors.append(e)
                continue
            if data is None:
                continue
            if not isinstance(data, dict):
                errors.append(UserError(f"expected a mapping of material id -> entry, got {type(data).__name__}", path))
                continue
            for mid, raw in data.items():
                base_key = _join(None, mid if isinstance(mid, str) else str(mid))
                id_errors = _check_id(mid, path, base_key)
                if id_errors:
                    errors += id_errors
                    continue
                if mid in where:
                    errors.append(
                        UserError(
                            f"material id {mid!r} is defined twice: in {where[mid]} and in {path}", path, base_key
                        )
                    )
                    continue
                where[mid] = path
                f, errs = _parse_entry(mid, raw, path, base_key)
                if f is None:  # None exactly when there are errors (so too below)
                    errors += errs
                    continue
                fields[mid], keys[mid] = f, base_key
        # entries with same_as, in any file order: each after the entry it names
        linked = sorted(mid for mid, f in fields.items() if f.get("same_as") is not None)
        order, circles = _same_as_order(
            linked, lambda m: fields[m]["same_as"] if fields[m]["same_as"] in linked else None
        )
        errors += _circles(circles, lambda m: fields[m]["same_as"], where.get, keys.get)
        for mid in circles:
            del fields[mid]
        for mid in order:
            f, errs = _same_as(mid, fields[mid], fields, where[mid], keys[mid])
            if f is None:
                errors += errs
                del fields[mid]
            else:
                fields[mid] = f
        for mid in list(fields):
            mat, errs = _build(mid, fields[mid], str(where[mid]), keys[mid])
            if mat is None:
                errors += errs
                del fields[mid]
                continue
            materials[mid] = mat
        keys = {mid: keys[mid] for mid in materials}
        db = cls(materials, fields, keys)
        errors += db._problems()
        _raise(errors)
        return db

    def with_overrides(self, raw: dict | None, *, file: str | Path, key_prefix: str = "materials") -> MaterialDB:
        """A new database with a scenario's ``materials:`` map applied.

        An existing id with some fields replaces just those fields (a given ``eps`` replaces
        the whole table; a given ``coating`` the whole stack; ``null`` unsets a field). A new id
        is a new material under the same rules as the database files.

        Parameters
        ----------
        raw : dict or None
            The scenario's ``materials:`` mapping (id -> entry), as read from YAML.
        file : str or Path
            The scenario file, for error messages (and the overridden materials' `origin`).
        key_prefix : str
            Key path of `raw` inside `file`.
        """
        if raw is None:
            return self
        if not isinstance(raw, dict):
            raise UserError(
                f"expected a mapping of material id -> entry (fields as in materials/*.yaml), got {type(raw).__name__}",
                file,
                key_prefix or None,
            )
        errors: list[UserError] = []
        materials = dict(self._materials)
        fields = {k: dict(v) for k, v in self._fields.items()}
        keys = dict(self._keys)

        def named(mid: object) -> object:
            entry = raw[mid]
            return entry.get("same_as") if isinstance(entry, Mapping) else None

        order, circles = _same_as_order(
            raw, lambda m: t if isinstance(t := named(m), str) and t != m and t in raw else None
        )
        errors += _circles(circles, named, lambda m: file, lambda m: _join(key_prefix, m))
        for mid in order:
            entry = raw[mid]
            base_key = _join(key_prefix, mid if isinstance(mid, str) else str(mid))
            id_errors = _check_id(mid, file, base_key)
            if id_errors and mid not in self._materials:
                errors += id_errors
                continue
            new, errs = _parse_entry(mid, entry, file, base_key)
            # None exactly when there are errors (so too below); a same_as entry replaces the whole entry
            whole = new is not None and new.get("same_as") is not None
            if new is not None and whole:
                new, errs = _same_as(mid, new, fields, file, base_key)
            if new is None:
                errors += errs
                continue
            if whole:
                new["source"] = f"{new['source']} (in {file})"
            elif mid in self._materials:
                merged = _merged(self._fields[mid], new)
                base_source = self._materials[mid].source
                changed = ", ".join(k for k in _ENTRY_KEYS if k in new and k not in ("source", "name"))
                if "source" not in new and changed:
                    merged["source"] = (
                        f"{base_source}; {changed} overridden in {file}"
                        if base_source
                        else f"{changed} overridden in {file}"
                    )
                new = merged
            mat, errs = _build(mid, new, str(file), base_key)
            if mat is None:
                errors += errs
                continue
            materials[mid], fields[mid], keys[mid] = mat, new, base_key
        _raise(errors)
        db = MaterialDB(materials, fields, keys)
        _raise(db._problems())
        return db

    # -- queries -------------------------------------------------------------------------------

    def get(self, mid: str, *, file: str | Path | None = None, key: str | None = None) -> Material:
        """The material `mid`; an unknown id is a UserError (at `file`, `key`) with close matches."""
        try:
            return self._materials[mid]
        except (KeyError, TypeError):
            pass
        if str(mid).lower() in UNSOURCED:
            raise UserError(
                f"no material {mid!r}: no printed measurement of {UNSOURCED[str(mid).lower()]} at 35-300 GHz was found "
                "(docs/materials.md, 'Not found'); a scenario's `materials:` map can define it with its source",
                file,
                key,
            )
        close = difflib.get_close_matches(str(mid), list(self._materials), n=5, cutoff=0.6)
        hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
        raise UserError(
            f"unknown material {mid!r}{hint} (`pmmw materials list` shows every id; a scenario's "
            "`materials:` map can define new ones)",
            file,
            key,
        )

    def ids(self) -> list[str]:
        """Every id, in load order (files by name, entries in file order; new overrides last)."""
        return list(self._materials)

    def __contains__(self, mid: object) -> bool:
        return mid in self._materials

    def __len__(self) -> int:
        return len(self._materials)

    def check(self) -> None:
        """Cross-entry rules: every coating layer names an existing, uncoated material with a
        permittivity. Raises UserError/UserErrors naming the file and key of each problem."""
        _raise(self._problems())

    def _problems(self) -> list[UserError]:
        errors = []
        for mid, mat in self._materials.items():
            base_key = self._keys.get(mid, mid)
            for i, layer in enumerate(mat.coating):
                key = _join(base_key, "coating", i, "material")
                other = self._materials.get(layer.material)
                if other is None:
                    close = difflib.get_close_matches(layer.material, list(self._materials), n=5, cutoff=0.6)
                    hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
                    errors.append(UserError(f"unknown coating material {layer.material!r}{hint}", mat.origin, key))
                elif other.kind in _NO_EPS_KINDS:
                    errors.append(
                        UserError(
                            f"coating layer material {layer.material!r} is a {other.kind}: a layer needs a permittivity "
                            "(a metal or blackbody can be coated, but not be a coating layer)",
                            mat.origin,
                            key,
                        )
                    )
                elif other.coating:
                    errors.append(
                        UserError(
                            f"coating layer material {layer.material!r} has a coating of its own; nested coatings are "
                            "not supported: list all the layers here, outermost first",
                            mat.origin,
                            key,
                        )
                    )
        return errors


# ----------------------------------------------------------------------------------------------
# Text for `pmmw materials list|show`
# ----------------------------------------------------------------------------------------------


def _fmt_f(f: float) -> str:
    return f"{f / 1e9:g} GHz"


def _fmt_eps(e: complex, compact: bool = False) -> str:
    sep = "+" if compact else " + "
    return f"{e.real:.4g}{sep}{e.imag:.3g}j"


def _fmt_t(t: float | None) -> str:
    return f"{t:g} K" if t is not None else "-"


def _fmt_len(d: float) -> str:
    return f"{d * 1e3:g} mm" if d < 1 else f"{d:g} m"


def _range_text(freqs: tuple[float, ...]) -> str:
    if len(freqs) == 1:
        return f"at {_fmt_f(freqs[0])}"
    return f"from {_fmt_f(freqs[0])} to {_fmt_f(freqs[-1])}"


def _eps_cell(mat: Material, f: float | None) -> tuple[str, bool]:
    """(text, clamped) for the list's eps column."""
    if mat.kind == "metal":
        return "perfect conductor", False
    if mat.kind == "blackbody":
        return "perfect absorber", False
    if f is None:
        if mat.model is not None:
            return f"model {mat.model.spec.name}", False
        if not mat.freqs:
            return f"{_fmt_eps(mat.eps[0], True)} (all f)", False
        return ", ".join(f"{f_ / 1e9:g} GHz: {_fmt_eps(e, True)}" for f_, e in zip(mat.freqs, mat.eps)), False
    value, clamped = mat._lookup(f)
    return _fmt_eps(value, True) + ("*" if clamped else ""), clamped


def _shorten(text: str, n: int) -> str:
    text = " ".join(text.split())
    return text if len(text) <= n else text[: n - 3].rstrip() + "..."


def format_material_table(db: MaterialDB, f: float | None = None) -> str:
    """The whole database as aligned columns: id, kind, eps (at `f` [Hz], or the table), T,
    source (shortened; ``pmmw materials show ID`` gives it in full)."""
    eps_head = f"eps at {_fmt_f(f)}" if f is not None else "eps"
    rows = [("id", "kind", eps_head, "T", "source")]
    any_clamped = False
    for mid in db.ids():
        mat = db.get(mid)
        cell, clamped = _eps_cell(mat, f)
        any_clamped |= clamped
        kind = mat.kind + (" +coating" if mat.coating else "")
        rows.append((mid, kind, cell, _fmt_t(mat.temperature), _shorten(mat.source, 72)))
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    lines = []
    for r in rows:
        lines.append("  ".join(c.ljust(w) for c, w in zip(r[:4], widths)) + "  " + r[4])
    lines.insert(1, "  ".join("-" * w for w in widths) + "  " + "-" * 6)
    if any_clamped and f is not None:  # only a frequency clamps
        lines.append(
            f"* {_fmt_f(f)} is outside the entry's stated range (a table's nearest value, a model "
            "extrapolated or interpolated): `pmmw materials show ID` says which"
        )
    lines.append("T '-': the scenario's temperature applies")
    return "\n".join(line.rstrip() for line in lines)


def format_material(db: MaterialDB, mid: str, f: float | None = None) -> str:
    """One material in full: kind, permittivity table (and the value at `f` [Hz]), temperature,
    coating, thickness, source and file. Unknown `mid` -> UserError with close matches."""
    mat = db.get(mid)
    lines = [f"{mat.id}: {mat.name}"]

    def row(label: str, value: str) -> None:
        lines.append(f"  {label + ':' if label else '':<16}{value}")

    row("kind", mat.kind)
    if mat.kind == "metal":
        row("eps", "- (perfect conductor: r_s = -1, r_p = 1)")
    elif mat.kind == "blackbody":
        row("eps", "- (perfect absorber)")
    elif mat.model is not None:
        row("eps", f"{mat.model.describe()}; at {mat.model_temperature():g} K:")
        for f_ in (35e9, 95e9, 140e9, 220e9, 300e9):
            value, outside = mat._lookup(f_)
            why = f"  (outside the range: {mat.outside_note(f_)})" if outside else ""
            row("", f"{_fmt_f(f_):>8}  {_fmt_eps(value)}{why}")
    elif not mat.freqs:
        row("eps", f"{_fmt_eps(mat.eps[0])} at every frequency")
    else:
        for i, (f_, e) in enumerate(zip(mat.freqs, mat.eps)):
            row("eps" if i == 0 else "", f"{_fmt_f(f_):>8}  {_fmt_eps(e)}")
        beyond = {"hold": "the end row's value", "trend": "the power law through the two end rows"}
        if len(mat.freqs) >= 2:  # a one-row table holds its value (`extrapolate` is refused there)
            text = f"{mat.extrapolate} (outside the table, {_range_text(mat.freqs)}: {beyond[mat.extrapolate]}, warned)"
            row("extrapolate", text)
    if f is not None and mat.kind not in _NO_EPS_KINDS:
        value, clamped = mat._lookup(f)
        how = ""
        if clamped and mat.model is not None:
            how = f" (outside the model's range: {mat.outside_note(f)})"
        elif clamped:
            how = f" (outside the table, tabulated {_range_text(mat.freqs)}: {mat.outside_note(f)})"
        elif mat.freqs and not any(abs(f - g) <= FREQ_REL_TOL * g for g in mat.freqs):
            how = " (interpolated linearly)"
        row(f"eps at {_fmt_f(f)}", f"{_fmt_eps(value)}{how}")
    row(
        "temperature",
        _fmt_t(mat.temperature) + ("" if mat.temperature is not None else " (the scenario's temperature applies)"),
    )
    if mat.thickness is not None:
        row("thickness", f"{_fmt_len(mat.thickness)} (the sheet's own)")
    row("roughness", repr(mat.roughness) if mat.roughness is not None else "smooth")
    if mat.bump is not None:
        row("bump", repr(mat.bump))
    if mat.coating:
        row("coating", "outermost layer first")
        for i, layer in enumerate(mat.coating, 1):
            t = _fmt_t(layer.temperature) if layer.temperature is not None else "the layer material's T"
            rough = f", rough top: {layer.roughness!r}" if layer.roughness is not None else ""
            row("", f"{i}. {layer.material}, {_fmt_len(layer.thickness)}, {t}{rough}")
    row("source", " ".join(mat.source.split()) or "-")
    row("file", mat.origin or "-")
    return "\n".join(lines)


def plot_materials(
    db: MaterialDB,
    ids: list[str],
    path: str | os.PathLike[str],
    temperature: float | None = None,
    f_range: tuple[float, float] = (10e9, 1000e9),
) -> Path:
    """eps' and eps'' of materials against frequency [GHz] (log axes), 35-300 GHz shaded: a model
    as a curve (at ``temperature`` [K], else the material's), a table as its points (circles)
    joined by the interpolation, and its extension outside the table (the nearest value, or the
    trend) dashed."""
    from pmmw.io.preview import save_figure, subplots

    fig, (a1, a2) = subplots(1, 2, figsize=(10.0, 4.2), dpi=110)
    fs = np.geomspace(*f_range, 200)
    for i, mid in enumerate(ids):
        mat = db.get(mid, key="--compare" if i else "ID")
        colour = f"C{i}"
        if not mat.has_eps() or mat.kind in _NO_EPS_KINDS:
            continue
        if mat.model is not None:
            e = np.array([mat._lookup(f, temperature)[0] for f in fs])
            t_used = mat.model_temperature(temperature)
            label = f"{mid} (model {mat.model.spec.name}, {t_used:g} K)"
            inside = np.array([mat.model.in_range(f, t_used) for f in fs])
            for ax, part in ((a1, e.real), (a2, e.imag)):
                ax.plot(fs[inside] / 1e9, part[inside], "-", color=colour, label=label)
                ax.plot(fs[~inside] / 1e9, part[~inside], ":", color=colour)
            continue
        if not mat.freqs:
            e0 = complex(mat.eps[0])
            for ax, v in ((a1, e0.real), (a2, e0.imag)):
                ax.axhline(v, color=colour, ls="--", label=f"{mid} (one value at every frequency)")
            continue
        e = np.array([mat._lookup(f)[0] for f in fs])
        inside = (fs >= mat.freqs[0] * (1 - FREQ_REL_TOL)) & (fs <= mat.freqs[-1] * (1 + FREQ_REL_TOL))
        tf = np.array(mat.freqs) / 1e9
        te = np.array(mat.eps)
        below, above = fs < mat.freqs[0], fs > mat.freqs[-1]
        for ax, part, tp in ((a1, e.real, te.real), (a2, e.imag, te.imag)):
            ax.plot(fs[inside] / 1e9, part[inside], "-", color=colour, lw=1)
            for side in (below, above):
                ax.plot(fs[side] / 1e9, part[side], "--", color=colour, lw=0.8)
            beyond = "nearest value" if mat.extrapolate == "hold" else "power-law trend"
            ax.plot(tf, tp, "o", color=colour, label=f"{mid} (table; dashed: {beyond}, warned)")
    for ax, name in ((a1, "eps'"), (a2, "eps'' (loss)")):
        ax.axvspan(35, 300, color="0.9", zorder=0)
        ax.set_xscale("log")
        ax.set_yscale("log" if ax is a2 else "linear")
        ax.set_xlabel("frequency [GHz]")
        ax.set_ylabel(name)
        ax.grid(True, which="both", alpha=0.3)
    a1.legend(fontsize=7)
    fig.suptitle(f"Permittivity of {', '.join(ids)} (shaded: 35-300 GHz)", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)
