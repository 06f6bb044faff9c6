"""The typed scenario: pydantic v2 models with every quantity in SI and every input path resolved.

Unit strings are parsed here, at the edge (`pmmw.units.parse_quantity`); the rest of pmmw
only sees floats in [Hz], [m], [rad], [K], [Np/m]. Every field that takes a quantity says so in
its type, ``Annotated[float, Quantity(kind)]``, which also parses it; range checks follow as
``after`` validators on the parsed float. Unknown keys are errors (``extra="forbid"``).
Relative input paths resolve against the scenario file's folder, which the loader passes in the
validation context as ``base_dir``.

Every temperature key (``sky.temperature``, ``sky.ground_temperature``, ``atmosphere.temperature``,
``atmosphere.ground_temperature``, ``render.default_temperature`` and the materials' and their
layers' ``temperature``) takes the same range, `TEMPERATURE_RANGE`: above 0 K, at most
`pmmw.units.TEMPERATURE_MAX`. The temperatures of matter enter models that divide by them
(Liebe 1991's and ITU-R P.676's theta = 300 K / T), and no sky is colder than the cosmic
background (2.7 K): a sky that emits nothing is given as a small temperature, e.g. ``2.7 K``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal, Optional, Union, get_args

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import core_schema

from pmmw.atmosphere.model import F_MAX, F_MIN
from pmmw.errors import UserError
from pmmw.io.inputs import format_suffix, no_extension, path_problem, shown
from pmmw.units import TEMPERATURE_MAX, parse_quantity

if TYPE_CHECKING:
    from pmmw.atmosphere.model import AtmosphereLayer

MESH_SUFFIXES = (".glb", ".gltf", ".obj", ".ply", ".stl", ".off")
CHANNELS = ("I", "Q", "U", "V", "Ex2", "Ey2")
AUX = ("depth", "material", "stderr", "samples", "truncated")


class ConfigValueError(ValueError):
    """A validation failure whose message is already user-facing."""


def _q(value, kind, unit=None):
    try:
        return parse_quantity(value, kind, unit=unit)
    except UserError as e:
        raise ConfigValueError(e.message) from None


@dataclass(frozen=True)
class Quantity:
    """Field marker: a unit string or bare number of ``kind`` (see `pmmw.units`), parsed to a
    float in ``unit`` (None: the kind's SI unit). ``n``: a list of exactly n of them (a vector);
    ``many``: one value or a list, as a tuple. ``None`` passes through to the field's type."""

    kind: str
    unit: Optional[str] = None
    n: Optional[int] = None
    many: bool = False

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler) -> core_schema.CoreSchema:
        return core_schema.no_info_before_validator_function(self.parse, handler(source))

    def parse(self, value: object) -> float | tuple | None:
        if value is None:
            return None
        if self.n is not None:
            if not isinstance(value, (list, tuple)) or len(value) != self.n:
                raise ConfigValueError(f"expected a list of {self.n} numbers, got {value!r}")
            return tuple(_q(v, self.kind, self.unit) for v in value)
        if self.many:
            values = value if isinstance(value, (list, tuple)) else [value]
            return tuple(_q(v, self.kind, self.unit) for v in values)
        return _q(value, self.kind, self.unit)


Vec3 = tuple[float, float, float]
Length = Annotated[float, Quantity("length")]
Length3 = Annotated[Vec3, Quantity("length", n=3)]  # [m]


def _a(what: str) -> str:
    return ("an " if what[:1] in "aeiou" else "a ") + what


def _finite_number(value, what="number"):
    if isinstance(value, bool):
        raise ConfigValueError(f"expected {_a(what)}, got {value!r}")
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            raise ConfigValueError(f"expected {_a(what)}, got {value!r}") from None
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigValueError(f"expected a finite {what}, got {value!r}")
    return float(value)


def _integer(value):
    """Integers as YAML gives them (``16``, ``16.0``, ``'16'``); booleans are not integers."""
    if isinstance(value, bool):
        raise ConfigValueError(f"expected an integer, got {value!r}")
    return value


def _input_path(value: object, info: ValidationInfo) -> Path:
    if not isinstance(value, (str, Path)):
        raise ConfigValueError(f"expected a file path, got {value!r}")
    if not str(value).strip():
        raise ConfigValueError("expected a file path, got an empty string")
    p = Path(value).expanduser()
    base = (info.context or {}).get("base_dir")
    if not p.is_absolute() and base is not None:
        p = Path(base) / p
    why = path_problem(p)
    if why:
        raise ConfigValueError(f"{shown(p)}: {why}")
    # the folders resolved, the file's own name kept: a symbolic link's name tells the format
    p = p.parent.resolve() / p.name
    if not p.is_file():
        raise ConfigValueError(f"file not found: {p}")
    return p


_NAME_FORBIDDEN = set("/\\\0")
# what pmmw appends to a name in output names: ``_<f>GHz`` (multi-frequency outputs) and ``@``
# (sub-band tile folders); a name holding either could name another scenario's files
_NAME_MARKS = "@"
_FREQUENCY_SUFFIX = re.compile(r"_[0-9.e+-]+GHz$")
MAX_NAME = 100  # characters of `name`: output files add up to ~40 (`_300GHz_Ex2_ideal_sensor.png`,
# temporary-file suffixes) and file systems take 255 bytes per file name
MAX_SIDE = 16384  # [pixels] per image side
MAX_PIXELS = 1 << 26  # 64 Mpx (8192 x 8192)
MAX_SPP = 1 << 20
MAX_SEED = (1 << 63) - 1
TEMPERATURE_RANGE = (0.0, TEMPERATURE_MAX)  # [K] every temperature key: > 0, <= max
FREQUENCY_RANGE = (F_MIN, F_MAX)  # [Hz] the ITU-R atmosphere models' range


def frequency_problem(f: float) -> str | None:
    """Why a frequency [Hz] is refused (outside `FREQUENCY_RANGE`), or None."""
    lo, hi = FREQUENCY_RANGE
    if lo <= f <= hi:
        return None
    return (
        f"{f / 1e9:g} GHz is outside the {lo / 1e9:g}-{hi / 1e9:g} GHz that pmmw's atmosphere and material models cover"
    )


def parse_frequency(value: str | float, option: str = "--frequency") -> float:
    """A frequency given on the command line or to the Python API ('95 GHz', or a number [Hz]),
    checked against `FREQUENCY_RANGE`; errors name ``option``."""
    f = parse_quantity(value, "frequency", file=option) if isinstance(value, str) else float(value)
    why = frequency_problem(f)
    if why:
        raise UserError(why, option)
    return f


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, arbitrary_types_allowed=True)


def _decibels(value, what="level"):
    """A level in dB: a number or a string ``'10 dB'``."""
    if isinstance(value, str) and value.strip().lower().endswith("db"):
        value = value.strip()[:-2]
    return _finite_number(value, f"{what} in dB ('10 dB' or 10)")


class Receiver(_Model):
    """``imager.receiver``: the radiometer behind each pixel (`pmmw.imaging.receiver`)."""

    noise_temperature: Annotated[Optional[float], Quantity("temperature")] = None
    noise_figure: Optional[float] = None  # [dB]
    bandwidth: Annotated[Optional[float], Quantity("frequency")] = None  # pre-detection; default imager.bandwidth
    integration_time: Annotated[Optional[float], Quantity("time")] = None
    frame_rate: Annotated[Optional[float], Quantity("frequency")] = None
    receivers: int = Field(1, ge=1)
    pixels_per_receiver: Optional[int] = Field(None, ge=1)
    mode: Literal["total_power", "dicke"] = "total_power"
    gain_fluctuation: float = Field(0.0, ge=0.0, lt=1.0)
    reference_temperature: Annotated[Optional[float], Quantity("temperature")] = None

    @field_validator("receivers", "pixels_per_receiver", mode="before")
    @classmethod
    def _ints(cls, v):
        return None if v is None else _integer(v)

    @field_validator("noise_figure", mode="before")
    @classmethod
    def _nf(cls, v):
        if v is None:
            return None
        nf = _decibels(v, "noise figure")
        if not 0.0 < nf <= 30.0:
            raise ConfigValueError(f"noise figure must be > 0 and <= 30 dB, got {nf:g} dB")
        return nf

    @field_validator("gain_fluctuation", mode="before")
    @classmethod
    def _gain(cls, v):
        return _finite_number(v, "fraction dG/G")

    @field_validator("noise_temperature", "integration_time", "frame_rate", "bandwidth")
    @classmethod
    def _positive(cls, v, info):
        if v is not None and not v > 0:
            raise ConfigValueError(f"{info.field_name} must be > 0, got {v:g}")
        return v

    @model_validator(mode="after")
    def _choices(self):
        if (self.noise_temperature is None) == (self.noise_figure is None):
            raise ConfigValueError("give one of noise_temperature (e.g. '600 K') or noise_figure (e.g. '5 dB')")
        if (self.integration_time is None) == (self.frame_rate is None):
            raise ConfigValueError(
                "give one of integration_time (per pixel, e.g. '10 ms') or frame_rate "
                "(e.g. '10 Hz', with receivers and the pixels each scans)"
            )
        if self.integration_time is not None and (self.receivers != 1 or self.pixels_per_receiver is not None):
            raise ConfigValueError("receivers and pixels_per_receiver go with frame_rate, not integration_time")
        if self.reference_temperature is not None and self.mode != "dicke":
            raise ConfigValueError("reference_temperature is the Dicke reference load: it needs mode: dicke")
        return self


class Antenna(_Model):
    """``imager.antenna``: the aperture's illumination, blockage and spillover
    (`pmmw.imaging.antenna`)."""

    illumination: Literal["uniform", "gaussian", "parabolic"] = "uniform"
    edge_taper: Optional[float] = None  # [dB] below the centre, > 0; tapered illuminations only
    blockage: float = Field(0.0, ge=0.0, lt=0.9)  # central blockage diameter / aperture diameter
    spillover: Optional[float] = Field(None, ge=0.0, lt=1.0)  # fraction of the feed's power off the reflector
    spillover_temperature: Annotated[float, Quantity("temperature")] = 290.0
    # fixed: one PSF over the image (the on-axis beam); projected: each pixel's beam from the aperture
    # projected onto the plane normal to that pixel's direction (`pmmw.imaging.antenna.FieldPSF`)
    off_axis: Literal["fixed", "projected"] = "fixed"

    @field_validator("edge_taper", mode="before")
    @classmethod
    def _taper(cls, v):
        if v is None:
            return None
        t = _decibels(v, "edge taper")
        if not 0.0 < t <= 60.0:
            raise ConfigValueError(
                f"edge taper must be > 0 and <= 60 dB (the edge's level below the centre), got {t:g} dB"
            )
        return t

    @field_validator("blockage", mode="before")
    @classmethod
    def _ratio(cls, v):
        return _finite_number(v, "ratio of diameters")

    @model_validator(mode="after")
    def _taper_needed(self):
        if self.illumination == "uniform" and self.edge_taper is not None:
            raise ConfigValueError("edge_taper needs illumination: gaussian or parabolic (a uniform aperture has none)")
        if self.illumination != "uniform" and self.edge_taper is None:
            raise ConfigValueError(f"illumination {self.illumination} needs an edge_taper, e.g. '10 dB'")
        return self


class Imager(_Model):
    position: Length3
    look_at: Length3
    up: Length3 = (0.0, 0.0, 1.0)
    fov: Annotated[float, Quantity("angle")]
    resolution: tuple[int, int]
    aperture_diameter: Length = 0.0
    noise: Annotated[float, Quantity("temperature_difference")] = 0.0
    focus_distance: Annotated[Optional[float], Quantity("length")] = None
    bandwidth: Annotated[float, Quantity("frequency")] = 0.0
    band_samples: int = Field(5, ge=1, le=64)
    receiver: Optional[Receiver] = None
    antenna: Optional[Antenna] = None
    frequency: Optional[Any] = Field(default=None, exclude=True)  # alias of the top-level key

    @field_validator("band_samples", mode="before")
    @classmethod
    def _ints(cls, v):
        return _integer(v)

    @field_validator("focus_distance")
    @classmethod
    def _focus(cls, d):
        if d is not None and d <= 0:
            raise ConfigValueError(f"focus distance must be > 0, got {d:g} m")
        return d

    @field_validator("bandwidth")
    @classmethod
    def _bw(cls, b):
        if b < 0:
            raise ConfigValueError(f"bandwidth must be >= 0, got {b:g} Hz")
        return b

    @field_validator("fov")
    @classmethod
    def _fov(cls, fov):
        if not 0.0 < fov < math.pi:
            raise ConfigValueError(f"field of view must be between 0 and 180 deg, got {math.degrees(fov):g} deg")
        return fov

    @field_validator("resolution", mode="before")
    @classmethod
    def _res(cls, v):
        if (
            not isinstance(v, (list, tuple))
            or len(v) != 2
            or not all(isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in v)
        ):
            raise ConfigValueError(f"expected [width, height], two integers >= 1, got {v!r}")
        if max(v) > MAX_SIDE or v[0] * v[1] > MAX_PIXELS:
            raise ConfigValueError(
                f"{v[0]} x {v[1]} pixels is more than pmmw renders (at most {MAX_SIDE} per side "
                f"and {MAX_PIXELS // (1 << 20)} Mpx in all)"
            )
        return tuple(v)

    @field_validator("aperture_diameter")
    @classmethod
    def _aperture(cls, d):
        if d < 0:
            raise ConfigValueError(f"must be >= 0, got {d:g} m")
        return d

    @field_validator("noise")
    @classmethod
    def _noise(cls, t):
        if t < 0:
            raise ConfigValueError(f"noise must be >= 0 K, got {t:g} K")
        return t

    @model_validator(mode="after")
    def _hardware(self):
        if self.receiver is not None and self.noise > 0:
            raise ConfigValueError(
                "give imager.noise (one sigma for every pixel) or imager.receiver (the noise "
                "from the hardware), not both"
            )
        if self.receiver is not None and self.receiver.bandwidth is None and not self.bandwidth > 0:
            raise ConfigValueError("imager.receiver needs a bandwidth (pre-detection), or imager.bandwidth")
        if self.antenna is not None and not self.aperture_diameter > 0:
            raise ConfigValueError("imager.antenna needs an aperture_diameter > 0")
        return self

    @model_validator(mode="after")
    def _pose(self):
        if self.focus_distance is not None and self.aperture_diameter <= 0:
            raise ConfigValueError(
                "focus_distance needs an aperture_diameter > 0 (depth of field comes from the aperture)"
            )
        k = [b - a for a, b in zip(self.position, self.look_at)]
        nk = math.sqrt(sum(c * c for c in k))
        if nk == 0.0:
            raise ConfigValueError("look_at equals position: no viewing direction")
        up = self.up
        cross = (k[1] * up[2] - k[2] * up[1], k[2] * up[0] - k[0] * up[2], k[0] * up[1] - k[1] * up[0])
        nu = math.sqrt(sum(c * c for c in up))
        if nu == 0.0 or math.sqrt(sum(c * c for c in cross)) < 1e-9 * nk * nu:
            raise ConfigValueError("up is parallel to the viewing direction; give another up vector")
        return self


class Transform(_Model):
    translate: Length3 = (0.0, 0.0, 0.0)
    # stored in degrees: bare numbers stand as they are (no round trip through radians)
    rotate_deg: Annotated[Vec3, Quantity("angle", unit="deg", n=3)] = (0.0, 0.0, 0.0)
    scale: Union[float, tuple[float, float, float]] = 1.0

    @field_validator("scale", mode="before")
    @classmethod
    def _s(cls, v):
        vals = v if isinstance(v, (list, tuple)) else [v]
        if len(vals) not in (1, 3):
            raise ConfigValueError(f"expected a number or 3 numbers, got {v!r}")
        out = tuple(_finite_number(x, "scale factor") for x in vals)
        if any(x <= 0 for x in out):
            raise ConfigValueError(f"scale factors must be > 0, got {v!r}")
        return out[0] if len(out) == 1 else out


class SceneEntry(_Model):
    mesh: Path
    material: Optional[str] = None
    materials: Optional[dict[str, str]] = None
    transform: Transform = Transform()
    up_axis: Optional[Literal["y", "z"]] = None
    name: Optional[str] = None
    key: str = Field(default="", exclude=True)

    @field_validator("mesh", mode="before")
    @classmethod
    def _mesh(cls, v: object, info: ValidationInfo) -> Path:
        p = _input_path(v, info)
        suffix = format_suffix(p)
        if not suffix:
            raise ConfigValueError(no_extension(p, "mesh", MESH_SUFFIXES))
        if suffix not in MESH_SUFFIXES:
            raise ConfigValueError(f"unsupported mesh format {suffix!r}; use one of {', '.join(MESH_SUFFIXES)}")
        return p

    @model_validator(mode="after")
    def _one_material(self):
        if (self.material is None) == (self.materials is None):
            raise ConfigValueError("give exactly one of 'material' (one id) or 'materials' (mesh name -> id)")
        return self


Profile = Literal[
    "standard",
    "low_latitude",
    "mid_latitude_summer",
    "mid_latitude_winter",
    "high_latitude_summer",
    "high_latitude_winter",
]
PROFILES: tuple[str, ...] = get_args(Profile)


POWER_LAW_B_MAX = 2.0  # [-] largest exponent b: every ITU-R P.838-3 exponent (0.63-1.70 at 1-1000 GHz) fits
SAME_FREQUENCY_REL = 1e-6  # frequencies within this relative difference are one (the 6 digits of output names)


class PowerLawCoefficients(_Model):
    """One frequency's rain power law A = a R^b [dB/km], R the rain rate [mm/h]."""

    a: float  # [(dB/km)/(mm/h)^b]: the attenuation at 1 mm/h
    b: float  # [-]

    @field_validator("a", "b", mode="before")
    @classmethod
    def _number(cls, v):
        return _finite_number(v)

    @field_validator("a")
    @classmethod
    def _a(cls, a):
        if not a > 0.0:
            raise ConfigValueError(f"a (the attenuation in dB/km at 1 mm/h) must be > 0, got {a:g}")
        return a

    @field_validator("b")
    @classmethod
    def _b(cls, b):
        if not 0.0 < b <= POWER_LAW_B_MAX:
            raise ConfigValueError(
                f"b (the exponent of the rain rate) must be within 0 < b <= {POWER_LAW_B_MAX:g} "
                f"(ITU-R P.838's span 0.63-1.70), got {b:g}"
            )
        return b


class RainAttenuation(_Model):
    """How a rain layer's specific attenuation A [dB/km] follows from its rain rate R [mm/h].

    ``model: p838`` (the default): ITU-R P.838-3, ``k R^alpha`` with k and alpha of the
    frequency (the mean of H and V). ``model: power_law``: ``A = a R^b`` with ``coefficients``
    given per frequency, ``{95 GHz: {a: 1.06, b: 0.745}, ...}`` (Murakowski 2014 sec. 3.3.4,
    Table 3.5: Olsen et al. 1978 at 20 C); every frequency of the scenario needs an entry, and an
    entry holds across the imager's band around it. Either way the rain's Mie single-scattering
    albedo and asymmetry parameter (`pmmw.atmosphere.itu`) split the total into absorption
    and scattering.
    """

    model: Literal["p838", "power_law"] = "p838"
    coefficients: dict[str, PowerLawCoefficients] = {}  # frequency as written ('95 GHz') -> (a, b)

    @field_validator("coefficients", mode="before")
    @classmethod
    def _frequencies(cls, v):
        example = "e.g. {35 GHz: {a: 0.235, b: 1.009}, 95 GHz: {a: 1.06, b: 0.745}}"
        if not isinstance(v, dict) or not v:
            raise ConfigValueError(f"expected a mapping of frequency -> {{a: ..., b: ...}}, {example}")
        seen: dict[str, str] = {}
        for key in v:
            if not isinstance(key, str):
                raise ConfigValueError(f"key {key!r}: give a frequency with its unit, {example}")
            f = _q(key, "frequency")
            why = frequency_problem(f)
            if why:
                raise ConfigValueError(f"key {key!r}: {why}")
            label = f"{f / 1e9:.6g}"
            if label in seen:
                raise ConfigValueError(f"keys {seen[label]!r} and {key!r} are the same frequency")
            seen[label] = key
        return v

    @model_validator(mode="after")
    def _of_model(self):
        if self.model == "power_law" and not self.coefficients:
            raise ConfigValueError(
                "model: power_law needs coefficients per frequency, e.g. coefficients: {95 GHz: {a: 1.06, b: 0.745}}"
            )
        if self.model == "p838" and self.coefficients:
            raise ConfigValueError("coefficients belong to model: power_law; ITU-R P.838 (model: p838) takes none")
        return self

    def table(self) -> tuple[tuple[float, float, float], ...]:
        """``(f [Hz], a, b)`` of each entry, by frequency."""
        return tuple(sorted((parse_quantity(k, "frequency"), c.a, c.b) for k, c in self.coefficients.items()))

    def coefficients_at(self, f: float, half_band: float = 0.0) -> tuple[float, float] | None:
        """``(a, b)`` of the entry nearest f [Hz] if it lies within ``half_band`` [Hz] (and
        `SAME_FREQUENCY_REL`) of f, else None."""
        rows = [(abs(fk - f), a, b) for fk, a, b in self.table()]
        if not rows:
            return None
        d, a, b = min(rows)
        return (a, b) if d <= half_band + SAME_FREQUENCY_REL * f else None


class WeatherLayer(_Model):
    """A fog, cloud or rain slab between two heights above the ground."""

    kind: Literal["fog", "cloud", "rain"]
    base: Length
    top: Length
    liquid_water: Annotated[float, Quantity("density")] = 0.0  # [kg/m^3]
    rain_rate: Annotated[float, Quantity("rate", unit="mm/h")] = 0.0  # [mm/h], as ITU-R P.838 takes it
    attenuation: RainAttenuation = RainAttenuation()  # rain: P.838 or a power law
    # rain: the drops scatter (their Mie albedo's share of the extinction); false: they only absorb,
    # as Murakowski 2014 sec. 3.3.1 modelled rain ("we do not model ... scattering in the atmosphere")
    scattering: bool = True

    @field_validator("base", "top")
    @classmethod
    def _h(cls, z):
        if z < 0:
            raise ConfigValueError(f"heights are above the ground: must be >= 0, got {z:g} m")
        return z

    @field_validator("liquid_water")
    @classmethod
    def _lw(cls, w):
        if w < 0:
            raise ConfigValueError(f"liquid water content must be >= 0, got {w * 1e3:g} g/m3")
        return w

    @field_validator("rain_rate")
    @classmethod
    def _rr(cls, r):
        if r < 0:
            raise ConfigValueError(f"rain rate must be >= 0, got {r:g} mm/h")
        return r

    @model_validator(mode="after")
    def _consistent(self):
        if self.top <= self.base:
            raise ConfigValueError("top must be above base")
        if self.kind == "rain" and self.liquid_water:
            raise ConfigValueError("a rain layer takes rain_rate (e.g. '10 mm/h'), not liquid_water")
        if self.kind != "rain" and self.rain_rate:
            raise ConfigValueError(f"a {self.kind} layer takes liquid_water (e.g. '0.3 g/m3'), not rain_rate")
        if self.kind != "rain" and "scattering" in self.model_fields_set:
            raise ConfigValueError(
                f"scattering is a rain layer's; a {self.kind} layer's droplets only absorb (Rayleigh: ITU-R P.840)"
            )
        if self.kind != "rain" and "attenuation" in self.model_fields_set:
            raise ConfigValueError(
                f"attenuation is a rain layer's; a {self.kind} layer's follows from liquid_water (ITU-R P.840)"
            )
        return self

    def model_layer(self, f: float, half_band: float = 0.0) -> AtmosphereLayer | None:
        """This slab as the atmosphere model takes it at frequency f [Hz] (`pmmw.atmosphere.model.AtmosphereLayer`);
        None where its power law has no coefficients within ``half_band`` [Hz] of f."""
        from pmmw.atmosphere.model import AtmosphereLayer

        power_law = None
        if self.kind == "rain" and self.attenuation.model == "power_law":
            power_law = self.attenuation.coefficients_at(f, half_band)
            if power_law is None:
                return None
        return AtmosphereLayer(
            self.kind, self.base, self.top, self.liquid_water, self.rain_rate, power_law, self.scattering
        )


class AtmosphereConfig(_Model):
    """``model: layered`` (default): an ITU-R P.835 profile with gases (P.676), weather layers of
    fog/cloud (P.840) and rain (P.838); ``model: uniform``: one absorbing medium of ``loss`` at
    ``temperature`` along every path (Murakowski 2014's Blender setting, sec. 2.2.9)."""

    model: Literal["layered", "uniform"] = "layered"
    profile: Profile = "standard"
    ground_temperature: Annotated[Optional[float], Quantity("temperature")] = None
    humidity: Annotated[Optional[float], Quantity("density")] = None  # water-vapour density at the ground [kg/m^3]
    ground_altitude: Length = 0.0
    layers: tuple[WeatherLayer, ...] = ()
    loss: Annotated[Optional[float], Quantity("attenuation")] = None  # uniform: [Np/m] of power
    temperature: Annotated[Optional[float], Quantity("temperature")] = None  # uniform: [K]

    @model_validator(mode="before")
    @classmethod
    def _infer_model(cls, data):
        if isinstance(data, dict) and "model" not in data and ("loss" in data or "temperature" in data):
            data = dict(data, model="uniform")
        return data

    @field_validator("temperature", "ground_temperature")
    @classmethod
    def _t(cls, t):
        return None if t is None else _positive_temperature(t)

    @field_validator("humidity")
    @classmethod
    def _hum(cls, h):
        if h is not None and h < 0:
            raise ConfigValueError(f"humidity (water-vapour density) must be >= 0, got {h * 1e3:g} g/m3")
        return h

    @model_validator(mode="after")
    def _fields_of_model(self):
        if self.model == "uniform":
            extra = [k for k in ("ground_temperature", "humidity") if getattr(self, k) is not None]
            extra += ["layers"] if self.layers else []
            if extra:
                raise ConfigValueError(f"{', '.join(extra)} belong to the layered atmosphere, not model: uniform")
            object.__setattr__(self, "loss", self.loss if self.loss is not None else 0.0)
            object.__setattr__(self, "temperature", self.temperature if self.temperature is not None else 288.0)
        elif self.loss is not None or self.temperature is not None:
            raise ConfigValueError(
                "loss/temperature set a uniform atmosphere (model: uniform); the layered "
                "model takes profile, ground_temperature, humidity and layers"
            )
        return self

    def weather_at(self, f: float, half_band: float = 0.0, file: str | Path | None = None) -> tuple:
        """The weather layers as `pmmw.atmosphere.model.AtmosphereLayer` records at frequency f [Hz], a
        rain power law's entry taken within ``half_band`` [Hz] of f (a sub-band of the imager's band).

        Raises
        ------
        UserError
            A power law with no entry for f, named by ``file`` and the layer's key.
        """
        out = []
        for i, layer in enumerate(self.layers):
            m = layer.model_layer(f, half_band)
            if m is None:
                listed = ", ".join(layer.attenuation.coefficients)
                raise UserError(
                    f"no power-law coefficients for {f / 1e9:.6g} GHz (given for {listed}): add "
                    f"'{f / 1e9:.6g} GHz: {{a: ..., b: ...}}' or use model: p838",
                    file,
                    f"atmosphere.layers[{i}].attenuation.coefficients",
                )
            out.append(m)
        return tuple(out)


def _positive_temperature(t: float, hint: str = "") -> float:
    """``t`` [K] within `TEMPERATURE_RANGE` (the rule of every temperature key; module docstring)."""
    if not t > TEMPERATURE_RANGE[0]:
        raise ConfigValueError(f"temperature must be > 0 K, got {t:g} K{hint}")
    return t


class Sky(_Model):
    model: Optional[Literal["atmosphere", "slab", "uniform", "texture"]] = None  # None: see ScenarioConfig
    temperature: Annotated[Optional[float], Quantity("temperature")] = None
    file: Optional[Path] = None
    zenith_opacity: Optional[float] = None
    ground_temperature: Annotated[float, Quantity("temperature")] = 290.0

    @field_validator("temperature", "ground_temperature")
    @classmethod
    def _t(cls, t: Optional[float], info: ValidationInfo) -> Optional[float]:
        hint = (
            " (a sky that emits nothing: give the cosmic background, 2.7 K)" if info.field_name == "temperature" else ""
        )
        return None if t is None else _positive_temperature(t, hint)

    @model_validator(mode="before")
    @classmethod
    def _texture_shorthand(cls, data):
        if isinstance(data, dict) and "texture" in data:
            data = dict(data)
            if "file" in data:
                raise ConfigValueError("give the texture once, as 'texture' or 'file'")
            data["file"] = data.pop("texture")
            data.setdefault("model", "texture")
        return data

    @field_validator("file", mode="before")
    @classmethod
    def _file(cls, v: object, info: ValidationInfo) -> Optional[Path]:
        return None if v is None else _input_path(v, info)

    @field_validator("zenith_opacity", mode="before")
    @classmethod
    def _tau(cls, v):
        if v is None:
            return None
        tau = _finite_number(v, "opacity in nepers")
        if tau < 0:
            raise ConfigValueError(f"zenith opacity must be >= 0, got {v!r}")
        return tau

    @model_validator(mode="after")
    def _needs(self):
        if self.model == "uniform" and self.temperature is None:
            raise ConfigValueError("a uniform sky needs 'temperature', e.g. {model: uniform, temperature: 60 K}")
        if self.model == "texture" and self.file is None:
            raise ConfigValueError("a texture sky needs 'texture: path/to/sky.exr' (channels Tv, Th)")
        return self


class Render(_Model):
    spp: int = Field(16, ge=1, le=MAX_SPP)
    max_depth: int = Field(32, ge=1, le=64)
    threshold: float = 1e-3
    seed: int = Field(1, ge=0, le=MAX_SEED)
    workers: Optional[int] = Field(None, ge=1)
    tile: int = Field(64, ge=8, le=512)
    termination: Literal["roulette", "temperature"] = "roulette"
    strategy: Literal["split", "stochastic", "hybrid"] = "split"
    split_depth: int = Field(2, ge=0)
    target_error: Annotated[Optional[float], Quantity("temperature_difference")] = None
    min_spp: int = Field(4, ge=2, le=MAX_SPP)
    default_temperature: Annotated[float, Quantity("temperature")] = 290.0
    # [K] error allowed from skipping the atmosphere on short paths
    atmosphere_tolerance: Annotated[float, Quantity("temperature_difference")] = 0.01

    @field_validator("spp", "max_depth", "seed", "tile", "split_depth", "min_spp", mode="before")
    @classmethod
    def _ints(cls, v):
        return _integer(v)

    @field_validator("target_error")
    @classmethod
    def _target(cls, t):
        if t is not None and t <= 0:
            raise ConfigValueError(f"target_error must be > 0 K, got {t:g} K")
        return t

    @field_validator("atmosphere_tolerance")
    @classmethod
    def _atm_tol(cls, t):
        if t < 0:
            raise ConfigValueError(f"atmosphere_tolerance must be >= 0 K (0: never skip), got {t:g} K")
        return t

    @field_validator("threshold", mode="before")
    @classmethod
    def _thr(cls, v):
        t = _finite_number(v, "threshold")
        if not 0.0 <= t < 1.0:
            raise ConfigValueError(f"threshold must be in [0, 1), got {v!r}")
        return t

    @field_validator("workers", mode="before")
    @classmethod
    def _workers(cls, v):
        return None if v is None or v == "auto" else _integer(v)

    @field_validator("default_temperature")
    @classmethod
    def _t(cls, t):
        return _positive_temperature(t)


class Region(_Model):
    """A named region of interest, in scene units or in pixels.

    - ``center`` (a world point [m]) with a ``radius``: a bare number is pixels (of the image
      ``output.regions_resolution`` describes), a length (``0.3 m``) is metres around the point
      (projected at its distance), an angle (``0.5 deg``) is the angle it subtends;
    - ``bounds``: a world box ``[[x0, y0, z0], [x1, y1, z1]]`` [m] (what ``pmmw validate`` prints
      as an object's ``bounds_m``), the rectangle of the image its corners project into;
    - ``box``: ``[x0, y0, x1, y1]`` pixels, x1/y1 exclusive.
    """

    center: Annotated[Optional[Vec3], Quantity("length", n=3)] = None  # [m]
    radius: float = Field(2.0, gt=0)  # [pixels], [m] or [rad]: radius_unit
    radius_unit: Literal["px", "m", "rad"] = "px"
    box: Optional[tuple[int, int, int, int]] = None  # [x0, y0, x1, y1] pixels, x1/y1 exclusive
    bounds: Optional[tuple[Annotated[Vec3, Quantity("length", n=3)], Annotated[Vec3, Quantity("length", n=3)]]] = None

    @model_validator(mode="before")
    @classmethod
    def _radius_with_unit(cls, data):
        """``radius: 0.3 m`` or ``0.5 deg`` -> metres or radians (`radius_unit`); a number stays pixels."""
        if isinstance(data, dict) and isinstance(data.get("radius"), str):
            text = data["radius"]
            for kind, unit in (("length", "m"), ("angle", "rad")):
                try:
                    value = parse_quantity(text, kind)
                except UserError:
                    continue
                if any(ch.isalpha() for ch in text):
                    return {**data, "radius": value, "radius_unit": unit}
            try:
                float(text)
            except ValueError:
                raise ConfigValueError(
                    f"radius is pixels (a number), a length ('0.3 m') or an angle ('0.5 deg'); got {text!r}"
                ) from None
        return data

    @model_validator(mode="after")
    def _one(self):
        if sum(x is not None for x in (self.center, self.box, self.bounds)) != 1:
            raise ConfigValueError(
                "give exactly one of 'center' (world point [m]) with a radius, 'bounds' (world "
                "box [[x0, y0, z0], [x1, y1, z1]] [m]) or 'box' ([x0, y0, x1, y1] pixels)"
            )
        if self.box is not None and not (self.box[0] < self.box[2] and self.box[1] < self.box[3]):
            raise ConfigValueError(f"box must be [x0, y0, x1, y1] with x0 < x1 and y0 < y1, got {list(self.box)}")
        if self.bounds is not None and not all(a <= b for a, b in zip(*self.bounds)):
            raise ConfigValueError(
                "bounds must be [[x0, y0, z0], [x1, y1, z1]] with each lower corner coordinate at most the upper one"
            )
        return self

    def scaled(self, sx: float, sy: float) -> "Region":
        """This region on an image ``sx`` x ``sy`` times the size its pixels were given for: a
        pixel box grows outward to whole pixels, a pixel radius by the mean scale; regions in
        scene units are unchanged."""
        if self.box is not None:
            x0, y0, x1, y1 = self.box
            box = (
                math.floor(x0 * sx),
                math.floor(y0 * sy),
                max(math.ceil(x1 * sx), math.floor(x0 * sx) + 1),
                max(math.ceil(y1 * sy), math.floor(y0 * sy) + 1),
            )
            return self.model_copy(update={"box": box})
        if self.center is not None and self.radius_unit == "px":
            return self.model_copy(update={"radius": self.radius * math.sqrt(sx * sy)})
        return self


class OutputConfig(_Model):
    dir: Optional[Path] = None
    regions: dict[str, Region] = {}
    # the image size [width, height] the regions' pixel values are given for (default: the scenario
    # file's imager.resolution, before --set): on another resolution they scale with the image
    regions_resolution: Optional[tuple[int, int]] = None
    channels: tuple[str, ...] = CHANNELS
    # True (or "all"): every channel's plain preview and the regions'; "quick": only the previews a
    # render is read by, I and the regions; "figures": those of True and the annotated matplotlib
    # figures (colour bars, the ideal image beside the sensor's, the regions named, depth, material:
    # `pipeline.output_names`); False: none
    previews: Union[Literal["all", "quick", "figures"], bool] = True
    aux: tuple[str, ...] = ()
    # the EXR's compression: none (the default: written in a tenth of zip's time, the landing's
    # 12.0 MB in 0.06 s against 9.5 MB in 0.5 s on 2 cores; Monte Carlo noise leaves deflate little)
    # or zip (OpenEXR's ZIP, 16 scanlines a block)
    compression: Literal["none", "zip"] = "none"
    false_alarm: float = Field(1e-3, gt=0.0, lt=0.5)  # per target-sized test: the regions' probability of detection

    @field_validator("false_alarm", mode="before")
    @classmethod
    def _pfa(cls, v):
        return _finite_number(v, "probability")

    @field_validator("dir", mode="before")
    @classmethod
    def _dir(cls, v):
        if v is None:
            return None
        if not isinstance(v, (str, Path)) or not str(v).strip():
            raise ConfigValueError(f"expected a folder path, got {v!r}")
        return Path(v).expanduser().resolve()

    @field_validator("channels", mode="before")
    @classmethod
    def _channels(cls, v):
        return _subset(v, CHANNELS, "channel")

    @field_validator("previews", mode="before")
    @classmethod
    def _previews(cls, v):
        if isinstance(v, bool) or v in ("all", "quick", "figures"):
            return v
        raise ConfigValueError(
            f"expected true or all (every channel's plain preview and the regions'), quick (the image of I "
            f"and the regions), figures (those of true and the annotated figures) or false, got {v!r}"
        )

    @field_validator("aux", mode="before")
    @classmethod
    def _aux(cls, v):
        return _subset(v, AUX, "auxiliary channel")


def _subset(v, allowed, what):
    if isinstance(v, str):
        v = [v]
    if not isinstance(v, (list, tuple)):
        raise ConfigValueError(f"expected a list of {what}s")
    bad = [c for c in v if c not in allowed]
    if bad:
        raise ConfigValueError(f"unknown {what} {bad[0]!r}; known: {', '.join(allowed)}")
    if len(set(v)) != len(v):
        raise ConfigValueError(f"a {what} is listed twice")
    return tuple(v)


class ScenarioConfig(_Model):
    name: str
    source_file: Path
    frequencies: Annotated[tuple[float, ...], Quantity("frequency", many=True)]
    imager: Imager
    scene: tuple[SceneEntry, ...]
    materials: dict[str, dict] = {}
    atmosphere: Optional[AtmosphereConfig] = AtmosphereConfig()
    sky: Sky = Sky()
    render: Render = Render()
    output: OutputConfig = OutputConfig()

    @field_validator("name")
    @classmethod
    def _name(cls, v):
        # the name becomes output file names: keep it one plain path component
        if not v.strip() or v.strip() in (".", "..") or _NAME_FORBIDDEN & set(v) or not v.isprintable():
            raise ConfigValueError(f"name {v!r} must be a plain file name: not empty, no / or \\")
        if set(_NAME_MARKS) & set(v) or _FREQUENCY_SUFFIX.search(v):
            raise ConfigValueError(
                f"name {v!r} may not hold '@' nor end like '_35GHz': pmmw adds those to the names "
                "of a multi-frequency scenario's files, which could then be another scenario's"
            )
        if len(v) > MAX_NAME or len(v.encode("utf-8")) > 2 * MAX_NAME:
            raise ConfigValueError(f"name is {len(v)} characters long; at most {MAX_NAME} (it names the output files)")
        return v

    @field_validator("scene")
    @classmethod
    def _scene(cls, v):
        # after item validation, so a bad entry is not also reported as an empty scene
        if not v:
            raise ConfigValueError("the scene needs at least one entry (- mesh: ..., material: ...)")
        return v

    @field_validator("frequencies")
    @classmethod
    def _freqs(cls, out):
        if not out:
            raise ConfigValueError("give at least one frequency")
        why = next(filter(None, map(frequency_problem, out)), None)
        if why:
            raise ConfigValueError(why)
        if len(set(out)) != len(out):
            raise ConfigValueError("a frequency is listed twice")
        labels = [f"{f / 1e9:g}" for f in out]
        if len(out) > 1 and len(set(labels)) != len(labels):
            raise ConfigValueError(
                "two frequencies agree to 6 digits and would write the same files "
                f"(_{labels[0]}GHz ...): give frequencies that differ within 6 digits"
            )
        return out

    @field_validator("materials", mode="before")
    @classmethod
    def _materials(cls, v):
        if v is None:
            return {}
        if not isinstance(v, dict) or not all(isinstance(k, str) and isinstance(e, dict) for k, e in v.items()):
            raise ConfigValueError("expected a mapping of material id -> material entry")
        return v

    @field_validator("atmosphere", mode="before")
    @classmethod
    def _atm(cls, v):
        if v is None or (isinstance(v, str) and v.strip().lower() == "none"):
            return None
        return v

    @model_validator(mode="after")
    def _sky_model(self):
        """Default sky: the layered atmosphere's own sky when there is one, else the slab."""
        layered = self.atmosphere is not None and self.atmosphere.model == "layered"
        if self.sky.model is None:
            object.__setattr__(self, "sky", self.sky.model_copy(update={"model": "atmosphere" if layered else "slab"}))
        elif self.sky.model == "atmosphere" and not layered:
            raise ConfigValueError(
                "sky model 'atmosphere' needs a layered atmosphere (atmosphere: {profile: ...}), "
                "not 'none' or model: uniform"
            )
        return self

    @model_validator(mode="after")
    def _regions_scale(self):
        """Pixel regions given for another image size scale with the image (`Region.scaled`)."""
        ref = self.output.regions_resolution
        res = tuple(self.imager.resolution)
        if ref is not None and self.output.regions and tuple(ref) != res:
            if min(ref) < 1:
                raise ConfigValueError(f"output.regions_resolution must be positive, got {list(ref)}")
            sx, sy = res[0] / ref[0], res[1] / ref[1]
            regions = {n: r.scaled(sx, sy) for n, r in self.output.regions.items()}
            object.__setattr__(self.output, "regions", regions)
        return self

    @model_validator(mode="after")
    def _rain_coefficients(self):
        """A rain power law covers every frequency of the scenario (no silent fallback to P.838)."""
        if self.atmosphere is not None and self.atmosphere.model == "layered":
            for f in self.frequencies:
                self.atmosphere.weather_at(f)
        return self

    @model_validator(mode="after")
    def _band(self):
        lo, hi = FREQUENCY_RANGE
        half = self.imager.bandwidth / 2.0
        if half > 0 and any(not (lo <= f - half and f + half <= hi) for f in self.frequencies):
            raise ConfigValueError(
                f"imager.bandwidth {2 * half / 1e9:g} GHz reaches outside {lo / 1e9:g}-"
                f"{hi / 1e9:g} GHz around a frequency"
            )
        return self
