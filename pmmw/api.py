"""The Python API: what the commands do, for notebooks and scripts (``import pmmw``).

A `Scenario` is a scenario mapping and the place it stands (relative paths resolve against that
folder, errors name it): from a YAML file (`Scenario.load`) or a dict (`Scenario.from_dict`),
with overrides by dotted key (`Scenario.set`, values as Python objects or strings with units).
`render` returns the image as an `xarray.Dataset` in kelvin (one variable per EXR channel, dims
``frequency``, ``y``, ``x``), writing the EXR, previews and report only when given ``out``; the
same seed gives the same numbers either way. `validate`, `sky`, `po` and `sweep` do what their
commands do and return data.

Errors
------
Every misuse raises `pmmw.UserError` (``pmmw.errors.UserError``), never a bare TypeError,
AttributeError or ValueError: an argument of the wrong type or kind, a value out of range, an
unknown, missing or repeated keyword argument, a scenario that is not a `Scenario`, dict or path,
a key of `Scenario.set` that is not a dotted key path, an empty path (``out=""``), a path too long
for the file system. Its text is one line, ``WHERE: KEY: message`` as the command prints it after
``error:``, and its attributes say where: ``file`` is the function (``pmmw.render``) and ``key``
the argument (``spp``) for a bad argument, or ``file`` the scenario (its YAML, or ``<scenario
dict>.yaml`` in ``base_dir`` for a mapping) and ``key`` the dotted key path (``imager.noise``)
for a bad scenario value. Several problems of one scenario come together as `pmmw.UserErrors`
(a `UserError`; ``.errors`` lists them). `pmmw.EnvironmentProblem` (also a `UserError`) is the
machine's refusal, not the input's: an output folder that cannot be written, a full disk, a
worker killed for memory. Ctrl-C raises KeyboardInterrupt between the steps of a computation
(within about a second in `po`).

numpy values stand wherever their Python type does (``np.int64(8)`` for ``8``, a
``np.float32`` for a float, ``np.bool_`` for a bool, arrays for lists), in arguments and in
scenario values.

The command line is a layer over the same functions (`pmmw.pipeline`, `pmmw.physical_optics`,
`pmmw.sweeps.run`): nothing here computes anything of its own.
"""

from __future__ import annotations

import copy
import difflib
import functools
import inspect
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, ParamSpec, TypeVar, overload

import numpy as np

from pmmw.errors import UserError, UserErrors
from pmmw.io.inputs import name_too_long, path_problem, shown

if TYPE_CHECKING:
    import pandas as pd
    import xarray as xr

    from pmmw.config.schema import ScenarioConfig
    from pmmw.pipeline import Resolved

__all__ = ["Scenario", "render", "validate", "sky", "brdf", "po", "sweep", "load", "regions"]


# -- arguments ----------------------------------------------------------------------------------


_P = ParamSpec("_P")
_R = TypeVar("_R")


def _api(name: str) -> Callable[[Callable[_P, _R]], Callable[_P, _R]]:
    """The checks every public function shares: its arguments bound to its signature (an unknown,
    missing, extra or repeated one is a `UserError` naming it), numpy values turned into Python
    ones, a name too long for the file system a `UserError` naming the file, and an error naming
    a command-line option (``--incidence``) reworded to name the argument."""
    where = f"pmmw.{name}"

    def wrap(fn: Callable[_P, _R]) -> Callable[_P, _R]:
        sig = inspect.signature(fn)

        @functools.wraps(fn)
        def call(*args: _P.args, **kwargs: _P.kwargs) -> _R:
            try:
                bound = sig.bind(*args, **kwargs)
            except TypeError:
                raise _binding_error(where, sig, args, kwargs) from None
            from pmmw.config.load import plain

            for k, v in bound.arguments.items():
                if isinstance(v, (np.generic, np.ndarray, dict, list, tuple)):
                    bound.arguments[k] = plain(v)
            try:
                return fn(*bound.args, **bound.kwargs)
            except UserError as e:
                raise _named(e, where) from None
            except OSError as e:
                problem = name_too_long(e)
                if problem is None:
                    raise
                raise problem from None

        return call

    return wrap


def _binding_error(where: str, sig: inspect.Signature, args: tuple, kwargs: dict[str, Any]) -> UserError:
    """What is wrong with calling ``where`` with these arguments, naming the argument."""
    params = {n: p for n, p in sig.parameters.items() if n not in ("cls", "self")}
    named = [n for n, p in params.items() if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    takes = f"{where} takes {', '.join(named)}"
    positional = [
        n
        for n in named
        if params[n].kind in (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    ]
    n_args = len(args) - (len(sig.parameters) > len(params))  # the bound cls or self
    if not any(p.kind is p.VAR_KEYWORD for p in params.values()):
        for k in kwargs:
            if k not in params:
                near = difflib.get_close_matches(k, named, 1)
                hint = f"; did you mean {near[0]!r}?" if near else ""
                return UserError(f"unknown argument{hint} ({takes})", where, k)
    if n_args > len(positional):
        rest = [n for n in named if n not in positional]
        return UserError(
            f"takes {len(positional)} positional argument(s) ({', '.join(positional)}); give "
            f"{', '.join(rest)} by keyword, e.g. {rest[0] if rest else 'name'}=...",
            where,
            rest[0] if rest else None,
        )
    for n in positional[:n_args]:
        if n in kwargs:
            return UserError("given twice, by position and by keyword", where, n)
    missing = [
        n
        for n in named
        if params[n].default is inspect.Parameter.empty
        and n not in kwargs
        and not (n in positional and positional.index(n) < n_args)
    ]
    return UserError(f"missing argument ({takes})", where, missing[0] if missing else None)


def _named(e: UserError, where: str) -> UserError:
    """``e``, naming the argument instead of a command's option (``--incidence`` -> ``incidence``)."""
    if isinstance(e, UserErrors):
        return UserErrors([_named(x, where) for x in e.errors])
    if e.file == "--set":  # an override of `Scenario.set`, named by its key
        return type(e)(e.message, "pmmw.Scenario.set", e.key)
    option = e.key if e.file == "command line" else e.file  # `pmmw brdf` names its options either way
    if isinstance(option, str) and option.startswith("--"):
        key = option[2:].replace("-", "_")
        return type(e)(e.message, where, key if e.key in (None, option) else f"{key}: {e.key}")
    return e


def _kind(v: object) -> str:
    return f"{type(v).__name__} {v!r}" if not isinstance(v, (str, Path)) else repr(v)


@overload
def _integer(where: str, name: str, v: object, lo: int, optional: Literal[False]) -> int: ...
@overload
def _integer(where: str, name: str, v: object, lo: int, optional: bool = True) -> int | None: ...
def _integer(where: str, name: str, v: object, lo: int, optional: bool = True) -> int | None:
    """A whole number >= lo (numpy integers were made Python ones), or None if ``optional``."""
    if v is None and optional:
        return None
    if isinstance(v, bool) or not isinstance(v, int) or v < lo:
        raise UserError(f"expected a whole number >= {lo}, got {_kind(v)}", where, name)
    return v


@overload
def _number(where: str, name: str, v: object, optional: Literal[False] = False) -> float: ...
@overload
def _number(where: str, name: str, v: object, optional: bool) -> float | None: ...
def _number(where: str, name: str, v: object, optional: bool = False) -> float | None:
    """A finite real number, or None if ``optional``."""
    if v is None and optional:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise UserError(f"expected a finite number, got {_kind(v)}", where, name)
    return v


def _flag(where: str, name: str, v: object) -> bool:
    if not isinstance(v, bool):
        raise UserError(f"expected True or False, got {_kind(v)}", where, name)
    return v


@overload
def _text(where: str, name: str, v: object, optional: Literal[False], choices: Sequence[str] | None = None) -> str: ...
@overload
def _text(
    where: str, name: str, v: object, optional: bool = True, choices: Sequence[str] | None = None
) -> str | None: ...
def _text(where: str, name: str, v: object, optional: bool = True, choices: Sequence[str] | None = None) -> str | None:
    """A str (one of ``choices`` when given), or None if ``optional``."""
    if v is None and optional:
        return None
    if choices is not None and (not isinstance(v, str) or v not in choices):
        raise UserError(f"expected one of {', '.join(map(repr, choices))}, got {_kind(v)}", where, name)
    if not isinstance(v, str):
        raise UserError(f"expected a str, got {_kind(v)}", where, name)
    return v


@overload
def _quantity(where: str, name: str, v: object, optional: Literal[False] = False) -> str | float: ...
@overload
def _quantity(where: str, name: str, v: object, optional: bool) -> str | float | None: ...
def _quantity(where: str, name: str, v: object, optional: bool = False) -> str | float | None:
    """A quantity as the command line takes it: a str with a unit ('95 GHz') or a number [SI]."""
    if v is None and optional:
        return None
    if isinstance(v, bool) or not isinstance(v, (str, int, float)):
        raise UserError(f"expected a str with a unit (e.g. '95 GHz') or a number, got {_kind(v)}", where, name)
    return v


@overload
def _path(where: str, name: str, v: object, optional: Literal[False] = False) -> Path: ...
@overload
def _path(where: str, name: str, v: object, optional: bool) -> Path | None: ...
def _path(where: str, name: str, v: object, optional: bool = False) -> Path | None:
    """A str or os.PathLike naming a file or folder (not empty, not too long), as a Path."""
    if v is None and optional:
        return None
    if not isinstance(v, (str, os.PathLike)) or isinstance(os.fspath(v), bytes):
        raise UserError(f"expected a path (str or pathlib.Path), got {_kind(v)}", where, name)
    if not os.fspath(v).strip():
        raise UserError(
            "an empty path names no file or folder (it would mean the current folder); give one, e.g. 'out/run' or '.'",
            where,
            name,
        )
    why = path_problem(v)
    if why:
        raise UserError(f"{why}: {shown(v)}", where, name)
    return Path(v).expanduser()


@dataclass(frozen=True)
class Scenario:
    """A scenario mapping, where it stands, and overrides (applied in order, after the mapping).

    data : dict or None
        The mapping (None: read ``path`` when used, so edits to the file are seen).
    path : Path
        The YAML file, or for a mapping the file it stands for (its folder resolves relative paths).
    values : dict
        ``{"imager.noise": "2 K", "render.spp": 8, ...}``: dotted keys as ``--set`` takes them.
    """

    data: dict | None
    path: Path
    values: dict = field(default_factory=dict)

    @classmethod
    @_api("Scenario.load")
    def load(cls, path: str | os.PathLike[str]) -> Scenario:
        """The scenario of a YAML file (read when rendered or validated)."""
        return cls(None, _path("pmmw.Scenario.load", "path", path).resolve())

    @classmethod
    @_api("Scenario.from_dict")
    def from_dict(cls, data: Mapping, base_dir: str | os.PathLike[str] = ".") -> Scenario:
        """A scenario from a mapping as the YAML would hold it; relative paths (meshes, sky
        texture) resolve against ``base_dir``."""
        where = "pmmw.Scenario.from_dict"
        if not isinstance(data, Mapping):
            raise UserError(
                f"a scenario is a dict of keys (name, frequency, imager, scene, ...), got {_kind(data)}", where, "data"
            )
        bad = [k for k in data if not isinstance(k, str)]
        if bad:
            raise UserError(
                f"the keys of a scenario are str (name, frequency, imager, ...), got {bad[0]!r}", where, "data"
            )
        return cls(copy.deepcopy(dict(data)), _path(where, "base_dir", base_dir).resolve() / "<scenario dict>.yaml")

    @_api("Scenario.set")
    def set(self, values: dict | None = None, **keys: object) -> Scenario:
        """A copy with more overrides: ``s.set({"imager.noise": "2 K"})`` or, for top-level keys,
        ``s.set(frequency="35 GHz")``."""
        from pmmw.config.load import _split_key

        where = "pmmw.Scenario.set"
        if values is not None and not isinstance(values, Mapping):
            raise UserError(
                f"expected a dict of dotted key paths and values, e.g. {{'imager.noise': '2 K'}}, got {_kind(values)}",
                where,
                "values",
            )
        for key in values or {}:
            if not isinstance(key, str):
                raise UserError(f"a key is a dotted key path (str) like 'imager.noise', got {key!r}", where, "values")
            try:
                _split_key(key)
            except ValueError:
                raise UserError(
                    f"malformed key path {key!r}; expected e.g. 'imager.noise' or 'scene[0].material'", where, "values"
                ) from None
        return replace(self, values={**self.values, **(values or {}), **keys})

    def resolved(self) -> ScenarioConfig:
        """The validated, typed scenario (`pmmw.config.schema.ScenarioConfig`): SI values, defaults
        filled in, paths absolute."""
        from pmmw.config import load_scenario

        return load_scenario(self.path, data=self.data, values=self.values)

    def _kw(self) -> dict:
        return {"data": self.data, "values": self.values}


# What the functions below take as a scenario: a `Scenario`, a mapping as the YAML holds it, or the
# path of a YAML file.
ScenarioLike = Scenario | Mapping | str | os.PathLike


def _scenario(s: object, where: str, name: str = "scenario") -> Scenario:
    """A `Scenario` of a Scenario, a mapping or a path (the argument ``name`` of ``where``)."""
    if isinstance(s, Scenario):
        return s
    if isinstance(s, Mapping):
        return Scenario.from_dict(s)
    if isinstance(s, (str, os.PathLike)):
        return Scenario(None, _path(where, name, s).resolve())
    raise UserError(f"expected a pmmw.Scenario, a dict or the path of a scenario YAML, got {_kind(s)}", where, name)


@_api("validate")
def validate(scenario: ScenarioLike) -> dict:
    """What ``pmmw validate`` prints: the resolved scenario, geometry, media per frequency, the
    slab sky's values, resources and warnings; for the path of another pmmw file (a sweep file,
    a physical-optics job, a brdf stack or a Dask cluster file) its check as that kind, ``kind``
    first (`pmmw.filekinds`)."""
    from pmmw.pipeline import validate as run

    if isinstance(scenario, (str, os.PathLike)) and Path(scenario).is_file():
        from pmmw.filekinds import SCENARIO, file_kind, validate_file
        from pmmw.io.yamlio import read_yaml

        if file_kind(read_yaml(Path(scenario), "pmmw file")) != SCENARIO:
            return validate_file(scenario)
    s = _scenario(scenario, "pmmw.validate")
    return run(s.path, **s._kw())


@_api("render")
def render(
    scenario: ScenarioLike,
    *,
    spp: int | None = None,
    workers: int | None = None,
    seed: int | None = None,
    out: str | os.PathLike[str] | None = None,
    quiet: bool = True,
) -> xr.Dataset:
    """Render a scenario; returns an `xarray.Dataset`.

    Parameters
    ----------
    scenario : Scenario, dict or path
    spp, workers, seed : optional
        As ``--spp``, ``--workers``, ``--seed``.
    out : path, optional
        Also write what ``pmmw render --out`` writes (EXR, previews, report) there.

    Returns
    -------
    xarray.Dataset
        Variables named as the EXR channels (``I``, ``Q``, ``U``, ``V``, ``Ex2``, ``Ey2`` after the
        imager, ``ideal.I`` ... before it, ``aux.*``), float32 [K] with dims (frequency, y, x);
        coordinates ``frequency`` [Hz] and pixel indices ``y`` (row 0 at the top) and ``x``;
        attributes: the EXR header without its ``pmmw:`` prefix, ``regions`` (the report's
        region means, contrasts with their SNR and ``detectable`` by the detection criterion, and
        verdicts, per frequency, when the scenario names regions) and, rendered
        in memory, ``warnings`` (the report's; they are printed too).
    """
    from pmmw import pipeline

    where = "pmmw.render"
    s = _scenario(scenario, where)
    spp, workers, seed = (
        _integer(where, "spp", spp, 1),
        _integer(where, "workers", workers, 1),
        _integer(where, "seed", seed, 0),
    )
    out, quiet = _path(where, "out", out, optional=True), _flag(where, "quiet", quiet)
    cli: dict[str, Any] = {k: v for k, v in (("spp", spp), ("workers", workers), ("seed", seed)) if v is not None}
    if out is not None:
        import json

        from pmmw.io.exr import read_exr

        exrs = pipeline.render(s.path, (), out=out, quiet=quiet, **cli, **s._kw())
        per_f, regions = [], {}
        scn = s.resolved()
        for path, f in zip(exrs, scn.frequencies):
            chans, attrs = read_exr(path)
            per_f.append((f, chans, attrs))
            report = json.loads((Path(path).parent / pipeline.output_names(scn, f)["reports"][0]).read_text())
            if report.get("regions"):
                regions[f"{f / 1e9:g} GHz"] = report["regions"]
        return _dataset(per_f, regions)
    pipeline.clear_warnings()
    res = pipeline.resolve(s.path, (), cli={**cli}, **s._kw())
    return _render_resolved(res, quiet)


def _render_resolved(res: Resolved, quiet: bool, earlier_warnings: Iterable[str] = ()) -> xr.Dataset:
    """`render` in memory of a resolved scenario (`pipeline.Resolved`)."""
    from pmmw import pipeline

    scn = res.scenario
    n = scn.render.workers or pipeline.default_workers()
    # the memory check of `pmmw render` (no disk check: nothing is written)
    pipeline.check_memory(pipeline.estimate_resources(scn, int(res.geometry.faces.shape[0]), n), scn.source_file)
    shash = pipeline.scenario_hash(scn, res.db)
    per_f, regions = [], {}
    for f in scn.frequencies:
        job, img, _ = pipeline.trace_frequency(res, f, workers=n, quiet=quiet)
        assert job is not None and img is not None  # None only for a shard
        images = pipeline.frequency_images(scn, f, job, img, shash, res.kernels)
        per_f.append((f, images["channels"], images["attrs"]))
        if scn.output.regions:
            regions[f"{f / 1e9:g} GHz"] = pipeline.region_stats(
                scn,
                job.camera,
                images["sensor"],
                img,
                images["region_kernels"] or images["kernel"],
                noise_maps=images["noise_maps"],
            )
    ds = _dataset(per_f, regions)
    warnings = list(dict.fromkeys([*earlier_warnings, *pipeline.collected_warnings()]))
    ds.attrs["warnings"] = "\n".join(warnings)  # text: netCDF attributes hold no lists of text
    return ds


def _dataset(per_f: list[tuple[float, dict[str, np.ndarray], dict]], regions: dict) -> xr.Dataset:
    """An xarray.Dataset of [(frequency [Hz], channels {name: (H, W)}, EXR header)].

    The image coordinates are the pixel centres' angles from the viewing direction [deg]: ``x``
    to the right, increasing along a row, and ``y`` upward, decreasing down the rows, so that
    ``ds["I"].plot()`` draws row 0 at the top without ``yincrease=False`` (xarray puts larger
    ``y`` values higher). ``row`` and ``col`` give the pixel indices (row 0 at the top) along
    the same dimensions. ``regions`` is JSON text (`regions` reads it), so that the Dataset
    saves to netCDF and Zarr, whose attributes hold no mappings.
    """
    import json

    import xarray as xr

    per_f = sorted(per_f, key=lambda t: t[0])
    names = list(per_f[0][1])
    h, w = per_f[0][1][names[0]].shape
    from pmmw.pipeline import channel_quantity

    data = {
        c: (
            ("frequency", "y", "x"),
            np.stack([np.asarray(ch[c]) for _, ch, _ in per_f]),
            dict(zip(("units", "long_name"), channel_quantity(c))),
        )
        for c in names
    }
    attrs = {k.removeprefix("pmmw:"): v for k, v in per_f[0][2].items() if k != "pmmw:frequency_hz"}
    if regions:
        attrs["regions"] = json.dumps(regions)
    # the pinhole's image plane at unit distance: half its width is tan(fov / 2), square pixels
    # (`scene.camera.Camera.image_coordinates`)
    half = math.tan(math.radians(float(attrs.get("fov_deg", 0.0))) / 2.0) or 1.0 / w
    col, row = np.arange(w), np.arange(h)
    x_deg = np.degrees(np.arctan(((col + 0.5) / (w / 2.0) - 1.0) * half))
    y_deg = np.degrees(np.arctan((h / 2.0 - (row + 0.5)) / (w / 2.0) * half))
    coords = {
        "frequency": ("frequency", [f for f, _, _ in per_f], {"units": "Hz"}),
        "y": ("y", y_deg, {"units": "deg", "long_name": "angle above the viewing direction"}),
        "x": ("x", x_deg, {"units": "deg", "long_name": "angle right of the viewing direction"}),
        "row": ("y", row, {"long_name": "pixel row (0 at the top)"}),
        "col": ("x", col, {"long_name": "pixel column (0 at the left)"}),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def regions(ds: xr.Dataset) -> dict:
    """The region statistics of a rendered Dataset (``ds.attrs["regions"]``, JSON text so that
    the Dataset saves to netCDF and Zarr) as a mapping: frequency label (``"95 GHz"``) ->
    ``means``, ``contrasts``, ``verdicts``, ... as in ``report.json``; {} without regions."""
    import json

    text = getattr(ds, "attrs", {}).get("regions")
    if text is None:
        return {}
    return json.loads(text) if isinstance(text, str) else dict(text)


#: the imager keys a `LoadedScene.render` pose may set
POSE_KEYS = ("position", "look_at", "up", "fov", "resolution", "focus_distance")


@_api("load")
def load(scenario: ScenarioLike) -> LoadedScene:
    """Read a scenario and build its scene once, for many renders (`LoadedScene.render`).

    Parameters
    ----------
    scenario : Scenario, dict or path

    Returns
    -------
    LoadedScene
        Its meshes read, transformed and joined, its materials checked: each render with another
        pose, frequency or material override rebuilds only what that changes (the same image as
        `render` with the same override, bit for bit). Measured over 4 poses at 16 x 16 pixels,
        1 sample, 1 worker, on the shared 2-core development machine: the outdoor concealed-
        weapon scene (`configs/cwd_outdoor_95ghz.yaml`, a 1.8 MB GLB, 45 000 triangles)
        0.55-0.62 s per image by `render`, 0.21-0.26 s by `LoadedScene.render` (2.1-3.0 times
        as fast); the cinderblocks scene (512 triangles) 0.45-0.79 s against 0.34-0.52 s
        (1.3-1.5 times). What is saved is the YAML, the material database and the meshes read
        each time; what is left is the trace and the imager model (the blur and the noise), which
        a large image makes dominant. The imager's PSF kernel is made once per frequency, pixel
        pitch and aperture and reused by the renders that share them.
    """
    return LoadedScene(_scenario(scenario, "pmmw.load"))


class LoadedScene:
    """A scenario resolved once (`load`): `render` many times with other poses, frequencies or
    materials. ``builds`` counts how often the geometry and the material database were built."""

    def __init__(self, scenario: Scenario) -> None:
        from pmmw import pipeline

        self.scenario = scenario
        pipeline.clear_warnings()
        self._res = pipeline.resolve(scenario.path, (), **scenario._kw())
        self._warnings = list(pipeline.collected_warnings())  # the scene's own (meshes, materials)
        self.builds = {"geometry": 1, "materials": 1}
        # the imager's PSF kernels (and field PSFs), shared by the renders (`pipeline.imager_kernel`):
        # one per distinct pixel pitch, frequency and aperture tried, kept while the scene is
        self._kernels: dict = {}

    def __repr__(self) -> str:
        return f"LoadedScene({self.scenario.path.name}: {self._res.geometry.faces.shape[0]} triangles)"

    def render(
        self,
        *,
        pose: dict | None = None,
        frequency: str | float | list | None = None,
        materials: dict | None = None,
        values: dict | None = None,
        spp: int | None = None,
        workers: int | None = None,
        seed: int | None = None,
        quiet: bool = True,
    ) -> xr.Dataset:
        """Render the loaded scene with overrides; returns an `xarray.Dataset` as `render` does.

        Parameters
        ----------
        pose : dict, optional
            Imager keys: ``position``, ``look_at``, ``up`` [m], ``fov``, ``resolution``,
            ``focus_distance`` (values as in a scenario, units accepted).
        frequency : str, float or list, optional
            ``"35 GHz"``, [Hz], or a list.
        materials : dict, optional
            ``{id: entry}``: material overrides as the scenario's ``materials:`` takes them
            (replacing the scenario's entry of that id).
        values : dict, optional
            Any other ``{dotted.key: value}`` overrides; one that changes ``scene`` rebuilds the
            geometry.
        spp, workers, seed, quiet
            As `render`.
        """
        return _loaded_render(self, pose, frequency, materials, values, spp, workers, seed, quiet)


def _loaded_render(
    loaded: LoadedScene,
    pose: dict | None,
    frequency: str | float | list | None,
    materials: dict | None,
    values: dict | None,
    spp: int | None,
    workers: int | None,
    seed: int | None,
    quiet: bool,
) -> xr.Dataset:
    from pmmw import pipeline
    from pmmw.config import load_scenario

    where = "pmmw.LoadedScene.render"
    s = loaded.scenario
    changes = {}
    for name, given in (("pose", pose), ("materials", materials), ("values", values)):
        if given is not None and not isinstance(given, Mapping):
            raise UserError(f"expected a dict, got {_kind(given)}", where, name)
    for k, v in (pose or {}).items():
        if k not in POSE_KEYS:
            raise UserError(f"unknown pose key {k!r}; known: {', '.join(POSE_KEYS)}", where, "pose")
        changes[f"imager.{k}"] = v
    if frequency is not None:
        changes["frequency"] = frequency
    changes.update({f"materials.{k}": v for k, v in (materials or {}).items()})
    changes.update(values or {})
    cli = {
        k: v
        for k, v in (
            ("spp", _integer(where, "spp", spp, 1)),
            ("workers", _integer(where, "workers", workers, 1)),
            ("seed", _integer(where, "seed", seed, 0)),
        )
        if v is not None
    }
    from pmmw.config.load import plain

    pipeline.clear_warnings()
    scn = load_scenario(s.path, data=s.data, values={**s.values, **plain(changes)}, cli=cli)
    old = loaded._res
    db, geom = old.db, old.geometry
    if scn.materials != old.scenario.materials:
        db = pipeline.material_database(scn)
        loaded.builds["materials"] += 1
    if repr(scn.scene) != repr(old.scenario.scene):
        pipeline.check_material_ids(scn.scene, db, scn.source_file)
        geom = pipeline.build_geometry(scn.scene, scenario_file=scn.source_file)
        loaded.builds["geometry"] += 1
    elif db is not old.db:
        pipeline.check_material_ids(scn.scene, db, scn.source_file)
    res = pipeline.Resolved(scn, db, geom, kernels=loaded._kernels)
    return _render_resolved(res, _flag(where, "quiet", quiet), loaded._warnings)


@_api("sky")
def sky(
    frequency: str | float,
    atmosphere: dict | None = None,
    elevations_deg: Sequence[float] = (5, 10, 15, 20, 30, 45, 60, 90),
) -> xr.Dataset:
    """Sky brightness of a layered atmosphere against elevation, as ``pmmw sky`` computes it.

    frequency : str or float ('95 GHz' or [Hz]); atmosphere : a scenario's ``atmosphere:`` mapping
    (default ``{profile: standard}``); elevations_deg : numbers within 0..90, as ``pmmw sky
    --elevations`` takes them. Returns an `xarray.Dataset` of ``Tv`` and ``Th`` [K] over
    ``elevation`` [deg].
    """
    import xarray as xr

    from pmmw import sky_table as skycmd
    from pmmw.config.schema import parse_frequency

    where = "pmmw.sky"
    f = parse_frequency(_quantity(where, "frequency", frequency), f"{where}: frequency")
    if atmosphere is not None and not isinstance(atmosphere, Mapping):
        raise UserError(
            f"expected a dict like a scenario's atmosphere: mapping, e.g. {{'profile': 'standard'}}, got "
            f"{_kind(atmosphere)}",
            where,
            "atmosphere",
        )
    elevations = skycmd.parse_elevations(elevations_deg, where, "elevations_deg")
    try:
        atm = skycmd.load_atmosphere(None, None, [], None, None, data=dict(atmosphere or {}))
    except UserError as e:
        raise UserError(e.message, where, e.key) if e.file == "command line" else e from None
    rows = skycmd.sky_table(atm, f, elevations)
    return xr.Dataset(
        {"Tv": ("elevation", rows[:, 1], {"units": "K"}), "Th": ("elevation", rows[:, 2], {"units": "K"})},
        coords={"elevation": ("elevation", rows[:, 0], {"units": "deg"})},
        attrs={"frequency_hz": f},
    )


#: `brdf`'s options by kind (the flags of ``pmmw brdf``; `pmmw.reflectance.run_brdf`)
_BRDF_NUMBERS = ("incidence", "azimuth", "threshold")
_BRDF_OPTIONAL_NUMBERS = ("ex", "ey", "m", "alpha", "alpha_y", "gloss", "orientation")
_BRDF_COUNTS = {"samples": 1, "seed": 0, "double_samples": 1}
_BRDF_FLAGS = ("double", "mueller", "plots")
_BRDF_TEXTS = ("material", "model", "shadowing")
_BRDF_QUANTITIES = ("frequency", "wavelength")
_BRDF_COMPLEX = ("n", "eps")


def _complex(where: str, name: str, v: object) -> str | float | list[float] | None:
    """A complex number as the command line takes it ('0.23+3.46j', a number, [re, im]); a Python
    complex as [re, im]."""
    if v is None or isinstance(v, str) or (isinstance(v, (int, float)) and not isinstance(v, bool)):
        return v
    if isinstance(v, complex):
        return [v.real, v.imag]
    if (
        isinstance(v, (list, tuple))
        and len(v) == 2
        and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
    ):
        return list(v)
    raise UserError(
        f"expected a complex number (0.23+3.46j, a str like '5.5+0.5j' or [re, im]), got {_kind(v)}", where, name
    )


@_api("brdf")
def brdf(*, method: str = "mc", out: str | os.PathLike[str] | None = None, **options: Any) -> dict[str, xr.Dataset]:
    """The polarized BRDF of a rough (layered) surface, as ``pmmw brdf`` computes it; keyword
    options as its flags (``n``, ``eps``, ``material``, ``stack``, ``frequency``, ``incidence``,
    ``azimuth``, ``model``, ``ex``, ``alpha``, ``samples``, ``seed``, ...; docs/brdf.md).

    Returns an `xarray.Dataset` per method in a dict ``{method: Dataset}``: ``mueller`` [1/sr]
    over (zenith, azimuth, row, col) in 1-degree cells and ``stokes`` over (component: I, Q, U,
    V; zenith; azimuth) [1/sr], with
    the method's summary (total reflectance, ...) as attributes; files only with ``out``.
    """
    import xarray as xr

    from pmmw.reflectance import grid_directions, run_brdf
    from pmmw.reflectance.command import METHODS
    from pmmw.reflectance.stack import Stack

    where = "pmmw.brdf"
    known = [n for n in inspect.signature(run_brdf).parameters if n not in ("method", "out")]
    for name in options:
        if name not in known:
            near = difflib.get_close_matches(name, known, 1)
            hint = f"; did you mean {near[0]!r}?" if near else ""
            raise UserError(f"unknown option{hint} ({where} takes method, out, {', '.join(known)})", where, name)
    _text(where, "method", method, optional=False, choices=METHODS)
    out = _path(where, "out", out, optional=True)
    for name, v in options.items():
        if name in _BRDF_NUMBERS:
            _number(where, name, v)
        elif name in _BRDF_OPTIONAL_NUMBERS:
            _number(where, name, v, optional=True)
        elif name in _BRDF_COUNTS:
            _integer(where, name, v, _BRDF_COUNTS[name], optional=False)
        elif name in _BRDF_FLAGS:
            _flag(where, name, v)
        elif name in _BRDF_TEXTS:
            _text(where, name, v)
        elif name in _BRDF_QUANTITIES:
            _quantity(where, name, v, optional=True)
        elif name in _BRDF_COMPLEX:
            options[name] = _complex(where, name, v)
        elif name == "stokes" and not (
            isinstance(v, (list, tuple))
            and len(v) == 4
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
        ):
            raise UserError(f"expected four numbers [I, Q, U, V], got {_kind(v)}", where, name)
        elif name == "stack" and v is not None and not isinstance(v, Stack):
            options[name] = _path(where, name, v)
    res = run_brdf(method=method, out=out, **options)
    theta, phi, _ = grid_directions()
    zen, az = np.degrees(theta[:, 0]), np.degrees(phi[0, :])
    out_ds = {}
    for name, m in res.methods.items():
        attrs = {k: v for k, v in m.summary.items() if isinstance(v, (int, float, str))}
        out_ds[name] = xr.Dataset(
            {
                "mueller": (("zenith", "azimuth", "row", "col"), m.mueller, {"units": "1/sr"}),
                "stokes": (("component", "zenith", "azimuth"), m.stokes, {"units": "1/sr"}),
            },
            coords={
                "zenith": ("zenith", zen, {"units": "deg"}),
                "azimuth": ("azimuth", az, {"units": "deg"}),
                "component": ["I", "Q", "U", "V"],
            },
            attrs=attrs,
        )
    return out_ds


def _angles(where: str, name: str, v: object, many: bool) -> str | None:
    """Angles [deg] as ``pmmw po`` takes them: a str ('0:180:1', '30,0'), a number or, where
    ``many``, a list of numbers."""
    if v is None or isinstance(v, str):
        return v
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return repr(float(v))
    if (
        many
        and isinstance(v, (list, tuple))
        and v
        and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
    ):
        return ",".join(repr(float(x)) for x in v)
    what = "a list of numbers" if many else "a str"
    raise UserError(
        f"expected angles in degrees: {what} like {'[30, 0]' if many else '0:180:1'} or one number, got {_kind(v)}",
        where,
        name,
    )


@_api("po")
def po(
    mesh: str | os.PathLike[str],
    *,
    frequency: str | float,
    material: str | None = None,
    eps: str | complex | Sequence[float] | None = None,
    incidence: str | Sequence[float] = "0,0",
    polarization: str = "theta",
    theta: str | float | None = None,
    phi: str | float | Sequence[float] | None = None,
    monostatic: bool = False,
    bounces: int = 1,
    method: str = "auto",
    force: bool = False,
) -> xr.Dataset:
    """Radar cross sections of a mesh by physical optics (``pmmw po``'s quick form); returns an
    `xarray.Dataset` with ``rcs_theta`` and ``rcs_phi`` [m^2] over (phi, theta) in degrees and
    the run's summary (backscatter, peak, lit facets) as attributes.

    ``incidence`` is '30,0' or ``[30, 0]`` [deg]; ``theta`` 'START:STOP:STEP' or one angle; ``phi``
    'P1,P2', 'START:STOP:STEP', one angle or a list [deg]. ``eps`` (instead of ``material``) is a
    relative permittivity: '5.5+0.5j', a number, a complex or ``[re, im]``. ``force`` solves past
    the memory check, as ``--force``.
    """
    import xarray as xr

    from pmmw.config.schema import parse_frequency
    from pmmw.physical_optics.command import MAX_BOUNCES, METHODS, run_po

    where = "pmmw.po"
    mesh = _path(where, "mesh", mesh)
    frequency = parse_frequency(_quantity(where, "frequency", frequency), f"{where}: frequency")
    material, eps = _text(where, "material", material), _complex(where, "eps", eps)
    angles = _angles(where, "incidence", incidence, many=True)
    if angles is None or len(angles.split(",")) != 2:
        raise UserError(
            f"expected two angles [theta, phi] in degrees, e.g. '30,0' or [30, 0], got {_kind(incidence)}",
            where,
            "incidence",
        )
    theta, phi = _angles(where, "theta", theta, many=False), _angles(where, "phi", phi, many=True)
    _text(where, "polarization", polarization, optional=False, choices=("theta", "phi"))
    _text(where, "method", method, optional=False, choices=METHODS)
    _flag(where, "monostatic", monostatic)
    _flag(where, "force", force)
    _integer(where, "bounces", bounces, 1, optional=False)
    if bounces > MAX_BOUNCES:
        raise UserError(f"expected 1 to {MAX_BOUNCES} bounces, got {bounces}", where, "bounces")
    res = run_po(
        mesh,
        material=material,
        eps=eps,
        frequency=frequency,
        incidence=angles,
        polarization=polarization,
        theta=theta,
        phi=phi,
        monostatic=monostatic,
        bounces=bounces,
        method=method,
        force=force,
    )
    assert res.axes is not None  # a quick run's grid
    thetas, phis = res.axes
    shape = (phis.size, thetas.size)
    summary = {k: v for k, v in res.summary.items() if not isinstance(v, dict)}
    summary.update({f"peak_{k}": v for k, v in res.summary["peak"].items()})
    summary = {k: (v if v is not None else float("nan")) for k, v in summary.items()}
    return xr.Dataset(
        {
            "rcs_theta": (("phi", "theta"), res.rcs_theta.reshape(shape), {"units": "m^2"}),
            "rcs_phi": (("phi", "theta"), res.rcs_phi.reshape(shape), {"units": "m^2"}),
        },
        coords={"theta": np.degrees(thetas), "phi": np.degrees(phis)},
        attrs=summary,
    )


@_api("sweep")
def sweep(
    scenario: ScenarioLike,
    grid: dict,
    *,
    out: str | os.PathLike[str],
    zip: bool | list = False,
    executor: str = "local",
    workers: int | None = None,
    resume: bool = False,
    quiet: bool = True,
) -> pd.DataFrame:
    """Render every variant of ``grid`` ({key: list of values}) as ``pmmw sweep`` does, into
    ``out``; returns the results table (``sweep.csv``) as a `pandas.DataFrame`."""
    import pandas as pd

    from pmmw.config.load import _split_key
    from pmmw.distributed import EXECUTORS
    from pmmw.sweeps.run import SweepSpec, run_sweep

    where = "pmmw.sweep"
    s = _scenario(scenario, where)
    if s.data is not None or s.values:
        raise UserError(
            "a sweep renders a scenario file: save the scenario as YAML (its variants are its grid), or "
            "give the overrides as grid keys with one value",
            where,
            "scenario",
        )
    example = "{'render.seed': [1, 2]}"
    if not isinstance(grid, Mapping) or not grid:
        raise UserError(
            f"expected a dict of dotted keys and lists of values, e.g. {example}, got {_kind(grid)}", where, "grid"
        )
    for k, v in grid.items():
        if not isinstance(k, str) or not k.strip():
            raise UserError(f"a key is a dotted key path (str) like 'render.seed', got {k!r}", where, "grid")
        try:
            _split_key(k)
        except ValueError:
            raise UserError(f"malformed key path {k!r}", where, "grid") from None
        if not isinstance(v, (list, tuple)) or not v:
            raise UserError(f"the values of {k!r} are a non-empty list, e.g. {example}, got {_kind(v)}", where, "grid")
    out = _path(where, "out", out)
    if not isinstance(zip, bool) and not (isinstance(zip, (list, tuple)) and all(isinstance(k, str) for k in zip)):
        raise UserError(f"expected True, False or a list of grid keys, got {_kind(zip)}", where, "zip")
    _text(where, "executor", executor, optional=False, choices=EXECUTORS)
    workers = _integer(where, "workers", workers, 1)
    _flag(where, "resume", resume)
    _flag(where, "quiet", quiet)
    spec = SweepSpec(
        scenario=s.path,
        grid=[(k, list(v)) for k, v in grid.items()],
        zip=zip,
        executor=executor,
        out=out,
        source="pmmw.sweep",
        workers=workers,
    )
    run_sweep(spec, resume=resume, quiet=quiet)
    return pd.read_csv(Path(out) / "sweep.csv")
