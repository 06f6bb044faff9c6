"""The typed scenario: pydantic v2 models with every quantity in SI and every input path resolved.

Unit strings are parsed here, at the edge (`pmmw_cli.units.parse_quantity`); the rest of pmmw
only sees floats in [Hz], [m], [rad], [K], [Np/m]. Unknown keys are errors (``extra="forbid"``).
Relative input paths resolve against the scenario file's folder, which the loader passes in the
validation context as ``base_dir``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from pmmw_cli.errors import UserError
from pmmw_cli.units import parse_quantity

MESH_SUFFIXES = (".glb", ".gltf", ".obj", ".ply", ".stl", ".off")
CHANNELS = ("I", "Q", "U", "V", "Ex2", "Ey2")
AUX = ("depth", "material", "stderr", "samples")


class ConfigValueError(ValueError):
    """A validation failure whose message is already user-facing."""


def _q(value, kind):
    try:
        return parse_quantity(value, kind)
    except UserError as e:
        raise ConfigValueError(e.message) from None


def _vec3(value, kind="length"):
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ConfigValueError(f"expected a list of 3 numbers, got {value!r}")
    return tuple(_q(v, kind) for v in value)


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


def _input_path(value, info: ValidationInfo) -> Path:
    if not isinstance(value, (str, Path)):
        raise ConfigValueError(f"expected a file path, got {value!r}")
    p = Path(value).expanduser()
    base = (info.context or {}).get("base_dir")
    if not p.is_absolute() and base is not None:
        p = Path(base) / p
    p = p.resolve()
    if not p.is_file():
        raise ConfigValueError(f"file not found: {p}")
    return p


_NAME_FORBIDDEN = set("/\\\0")


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, arbitrary_types_allowed=True)


class Imager(_Model):
    position: tuple[float, float, float]
    look_at: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    fov: float
    resolution: tuple[int, int]
    aperture_diameter: float = 0.0
    noise: float = 0.0
    focus_distance: Optional[float] = None
    bandwidth: float = 0.0
    band_samples: int = Field(5, ge=1, le=64)
    frequency: Optional[Any] = Field(default=None, exclude=True)  # alias of the top-level key

    @field_validator("band_samples", mode="before")
    @classmethod
    def _ints(cls, v):
        return _integer(v)

    @field_validator("focus_distance", mode="before")
    @classmethod
    def _focus(cls, v):
        if v is None:
            return None
        d = _q(v, "length")
        if d <= 0:
            raise ConfigValueError(f"focus distance must be > 0, got {v!r}")
        return d

    @field_validator("bandwidth", mode="before")
    @classmethod
    def _bw(cls, v):
        b = _q(v, "frequency")
        if b < 0:
            raise ConfigValueError(f"bandwidth must be >= 0, got {v!r}")
        return b

    @field_validator("position", "look_at", "up", mode="before")
    @classmethod
    def _vec(cls, v):
        return _vec3(v)

    @field_validator("fov", mode="before")
    @classmethod
    def _fov(cls, v):
        fov = _q(v, "angle")
        if not 0.0 < fov < math.pi:
            raise ConfigValueError(f"field of view must be between 0 and 180 deg, got {v!r}")
        return fov

    @field_validator("resolution", mode="before")
    @classmethod
    def _res(cls, v):
        if (not isinstance(v, (list, tuple)) or len(v) != 2
                or not all(isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in v)):
            raise ConfigValueError(f"expected [width, height], two integers >= 1, got {v!r}")
        return tuple(v)

    @field_validator("aperture_diameter", mode="before")
    @classmethod
    def _aperture(cls, v):
        d = _q(v, "length")
        if d < 0:
            raise ConfigValueError(f"must be >= 0, got {v!r}")
        return d

    @field_validator("noise", mode="before")
    @classmethod
    def _noise(cls, v):
        t = _q(v, "temperature")
        if t < 0:
            raise ConfigValueError(f"noise must be >= 0 K, got {v!r}")
        return t

    @model_validator(mode="after")
    def _pose(self):
        if self.focus_distance is not None and self.aperture_diameter <= 0:
            raise ConfigValueError("focus_distance needs an aperture_diameter > 0 (depth of field comes from the aperture)")
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
    translate: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotate_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: Union[float, tuple[float, float, float]] = 1.0

    @field_validator("translate", mode="before")
    @classmethod
    def _t(cls, v):
        return _vec3(v)

    @field_validator("rotate_deg", mode="before")
    @classmethod
    def _r(cls, v):
        if not isinstance(v, (list, tuple)) or len(v) != 3:
            raise ConfigValueError(f"expected 3 angles in degrees, got {v!r}")
        # bare numbers are degrees as they stand (no round trip through radians)
        return tuple(math.degrees(_q(a, "angle")) if isinstance(a, str) else _finite_number(a, "angle in degrees")
                     for a in v)

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
    def _mesh(cls, v, info: ValidationInfo):
        p = _input_path(v, info)
        if p.suffix.lower() not in MESH_SUFFIXES:
            raise ConfigValueError(f"unsupported mesh format {p.suffix!r}; use one of {', '.join(MESH_SUFFIXES)}")
        return p

    @model_validator(mode="after")
    def _one_material(self):
        if (self.material is None) == (self.materials is None):
            raise ConfigValueError("give exactly one of 'material' (one id) or 'materials' (mesh name -> id)")
        return self


PROFILES = ("standard", "low_latitude", "mid_latitude_summer", "mid_latitude_winter",
            "high_latitude_summer", "high_latitude_winter")
MM_PER_H = 1e3 * 3600.0  # [mm/h] per [m/s]


class WeatherLayer(_Model):
    """A fog, cloud or rain slab between two heights above the ground."""

    kind: Literal["fog", "cloud", "rain"]
    base: float
    top: float
    liquid_water: float = 0.0  # [kg/m^3]
    rain_rate: float = 0.0  # [mm/h]

    @field_validator("base", "top", mode="before")
    @classmethod
    def _h(cls, v):
        z = _q(v, "length")
        if z < 0:
            raise ConfigValueError(f"heights are above the ground: must be >= 0, got {v!r}")
        return z

    @field_validator("liquid_water", mode="before")
    @classmethod
    def _lw(cls, v):
        w = _q(v, "density")
        if w < 0:
            raise ConfigValueError(f"liquid water content must be >= 0, got {v!r}")
        return w

    @field_validator("rain_rate", mode="before")
    @classmethod
    def _rr(cls, v):
        r = _q(v, "rate") * MM_PER_H
        if r < 0:
            raise ConfigValueError(f"rain rate must be >= 0, got {v!r}")
        return r

    @model_validator(mode="after")
    def _consistent(self):
        if self.top <= self.base:
            raise ConfigValueError("top must be above base")
        if self.kind == "rain" and self.liquid_water:
            raise ConfigValueError("a rain layer takes rain_rate (e.g. '10 mm/h'), not liquid_water")
        if self.kind != "rain" and self.rain_rate:
            raise ConfigValueError(f"a {self.kind} layer takes liquid_water (e.g. '0.3 g/m3'), not rain_rate")
        return self


class Atmosphere(_Model):
    """``model: layered`` (default): an ITU-R P.835 profile with gases (P.676), weather layers of
    fog/cloud (P.840) and rain (P.838); ``model: uniform``: one absorbing medium of ``loss`` at
    ``temperature`` along every path (the seed's Blender setting, sec. 2.2.9)."""

    model: Literal["layered", "uniform"] = "layered"
    profile: Literal[PROFILES] = "standard"
    ground_temperature: Optional[float] = None
    humidity: Optional[float] = None  # water-vapour density at the ground [kg/m^3]
    ground_altitude: float = 0.0
    layers: tuple[WeatherLayer, ...] = ()
    loss: Optional[float] = None  # uniform: [Np/m] of power
    temperature: Optional[float] = None  # uniform: [K]

    @model_validator(mode="before")
    @classmethod
    def _infer_model(cls, data):
        if isinstance(data, dict) and "model" not in data and ("loss" in data or "temperature" in data):
            data = dict(data, model="uniform")
        return data

    @field_validator("loss", mode="before")
    @classmethod
    def _loss(cls, v):
        return None if v is None else _q(v, "attenuation")

    @field_validator("temperature", "ground_temperature", mode="before")
    @classmethod
    def _t(cls, v):
        return None if v is None else _positive_temperature(v)

    @field_validator("humidity", mode="before")
    @classmethod
    def _hum(cls, v):
        if v is None:
            return None
        h = _q(v, "density")
        if h < 0:
            raise ConfigValueError(f"humidity (water-vapour density) must be >= 0, got {v!r}")
        return h

    @field_validator("ground_altitude", mode="before")
    @classmethod
    def _alt(cls, v):
        return _q(v, "length")

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
            raise ConfigValueError("loss/temperature set a uniform atmosphere (model: uniform); the layered "
                                   "model takes profile, ground_temperature, humidity and layers")
        return self


def _positive_temperature(v):
    t = _q(v, "temperature")
    if t <= 0:
        raise ConfigValueError(f"temperature must be > 0 K, got {v!r}")
    return t


class Sky(_Model):
    model: Optional[Literal["atmosphere", "slab", "uniform", "texture"]] = None  # None: see Scenario
    temperature: Optional[float] = None
    file: Optional[Path] = None
    zenith_opacity: Optional[float] = None
    ground_temperature: float = 290.0

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

    @field_validator("temperature", "ground_temperature", mode="before")
    @classmethod
    def _t(cls, v):
        return None if v is None else _q(v, "temperature")

    @field_validator("file", mode="before")
    @classmethod
    def _file(cls, v, info: ValidationInfo):
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
        if self.temperature is not None and self.temperature < 0:
            raise ConfigValueError("sky temperature must be >= 0 K")
        return self


class Render(_Model):
    spp: int = Field(16, ge=1)
    max_depth: int = Field(6, ge=1, le=64)
    threshold: float = 1e-3
    seed: int = Field(1, ge=0)
    workers: Optional[int] = Field(None, ge=1)
    tile: int = Field(32, ge=8, le=512)
    termination: Literal["roulette", "temperature"] = "roulette"
    strategy: Literal["split", "stochastic", "hybrid"] = "split"
    split_depth: int = Field(2, ge=0)
    target_error: Optional[float] = None
    min_spp: int = Field(4, ge=2)
    default_temperature: float = 290.0
    atmosphere_tolerance: float = 0.01  # [K] error allowed from skipping the atmosphere on short paths

    @field_validator("spp", "max_depth", "seed", "tile", "split_depth", "min_spp", mode="before")
    @classmethod
    def _ints(cls, v):
        return _integer(v)

    @field_validator("target_error", mode="before")
    @classmethod
    def _target(cls, v):
        if v is None:
            return None
        t = _q(v, "temperature")
        if t <= 0:
            raise ConfigValueError(f"target_error must be > 0 K, got {v!r}")
        return t

    @field_validator("atmosphere_tolerance", mode="before")
    @classmethod
    def _atm_tol(cls, v):
        t = _q(v, "temperature")
        if t < 0:
            raise ConfigValueError(f"atmosphere_tolerance must be >= 0 K (0: never skip), got {v!r}")
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

    @field_validator("default_temperature", mode="before")
    @classmethod
    def _t(cls, v):
        return _positive_temperature(v)


class Region(_Model):
    """A named region of interest: a world point with a radius in pixels, or a pixel box."""

    center: Optional[tuple[float, float, float]] = None
    radius: float = Field(2.0, gt=0)  # [pixels] around the projected center
    box: Optional[tuple[int, int, int, int]] = None  # [x0, y0, x1, y1] pixels, x1/y1 exclusive

    @field_validator("center", mode="before")
    @classmethod
    def _c(cls, v):
        return None if v is None else _vec3(v)

    @model_validator(mode="after")
    def _one(self):
        if (self.center is None) == (self.box is None):
            raise ConfigValueError("give exactly one of 'center' (world point [m]) or 'box' ([x0, y0, x1, y1] pixels)")
        if self.box is not None and not (self.box[0] < self.box[2] and self.box[1] < self.box[3]):
            raise ConfigValueError(f"box must be [x0, y0, x1, y1] with x0 < x1 and y0 < y1, got {list(self.box)}")
        return self


class Output(_Model):
    dir: Optional[Path] = None
    regions: dict[str, Region] = {}
    channels: tuple[str, ...] = CHANNELS
    previews: bool = True
    aux: tuple[str, ...] = ()

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


class Scenario(_Model):
    name: str
    source_file: Path
    frequencies: tuple[float, ...]
    imager: Imager
    scene: tuple[SceneEntry, ...]
    materials: dict[str, dict] = {}
    atmosphere: Optional[Atmosphere] = Atmosphere()
    sky: Sky = Sky()
    render: Render = Render()
    output: Output = Output()

    @field_validator("name")
    @classmethod
    def _name(cls, v):
        # the name becomes output file names: keep it one plain path component
        if not v.strip() or v.strip() in (".", "..") or _NAME_FORBIDDEN & set(v) or not v.isprintable():
            raise ConfigValueError(f"name {v!r} must be a plain file name: not empty, no / or \\")
        return v

    @field_validator("scene")
    @classmethod
    def _scene(cls, v):
        # after item validation, so a bad entry is not also reported as an empty scene
        if not v:
            raise ConfigValueError("the scene needs at least one entry (- mesh: ..., material: ...)")
        return v

    @field_validator("frequencies", mode="before")
    @classmethod
    def _freqs(cls, v):
        vals = v if isinstance(v, (list, tuple)) else [v]
        if not vals:
            raise ConfigValueError("give at least one frequency")
        out = tuple(_q(f, "frequency") for f in vals)
        if any(f <= 0 for f in out):
            raise ConfigValueError("frequencies must be > 0")
        if len(set(out)) != len(out):
            raise ConfigValueError("a frequency is listed twice")
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
            raise ConfigValueError("sky model 'atmosphere' needs a layered atmosphere (atmosphere: {profile: ...}), "
                                   "not 'none' or model: uniform")
        return self
