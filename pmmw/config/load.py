"""YAML file + ``--set`` overrides -> validated `ScenarioConfig`, with every error named by file and key."""

from __future__ import annotations

import copy
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import overload

import numpy as np

from pmmw.config.schema import (
    _FREQUENCY_SUFFIX,
    _NAME_MARKS,
    Antenna,
    AtmosphereConfig,
    Receiver,
    Region,
    ScenarioConfig,
)
from pmmw.errors import UserError, UserErrors
from pmmw.io.inputs import check_input_path
from pmmw.io.records import key_path, problem, validate
from pmmw.io.yamlio import MalformedYAML, load_yaml, read_yaml

_INDEX = re.compile(r"^(.*?)\[(\d+)\]$")


def default_name(path: Path) -> str:
    """The name of a scenario that gives none: its file's stem, with what pmmw itself adds to output
    names (``@``, a final ``_35GHz``) turned into ``-`` (``radar_35GHz.yaml`` -> ``radar-35GHz``)."""
    stem = path.stem
    for mark in _NAME_MARKS:
        stem = stem.replace(mark, "-")
    m = _FREQUENCY_SUFFIX.search(stem)
    return stem if m is None else f"{stem[: m.start()]}-{stem[m.start() + 1 :]}"


def load_scenario(
    path: str | Path,
    overrides: Sequence[str] = (),
    *,
    cli: dict | None = None,
    data: dict | None = None,
    values: dict | None = None,
) -> ScenarioConfig:
    """Read, override, validate and resolve a scenario file.

    Parameters
    ----------
    path : str or Path
        The scenario YAML; with ``data``, where that mapping stands (relative paths resolve
        against its folder, errors name it), whether or not the file exists.
    data : dict, optional
        The scenario's mapping, instead of the file's (the Python API, `pmmw.api`).
    values : dict, optional
        ``{key.path: value}`` overrides with Python values, applied after ``overrides``.
    overrides : list of str
        ``key.path=value`` items (``--set``), applied in order; values are YAML.
    cli : dict, optional
        Typed values of command-line flags: ``spp``, ``workers``, ``seed``, ``out`` (a Path
        relative to the current directory). Applied after ``overrides``.

    Raises
    ------
    UserError or UserErrors
        Every problem, named by file and dotted key path.
    """
    path = Path(path)
    blend = None
    if data is not None:
        raw = plain(data)
    else:
        check_input_path(path)
        if not path.exists():
            raise UserError("scenario file not found", file=path)
        if not path.is_file():
            raise UserError("is not a file (expected a scenario YAML)", file=path)
        if path.suffix.lower() == ".blend":  # Blender's scene, exported by the pmmw add-on's exporter
            from pmmw.blender import scenario_of_blend

            blend, path = path, scenario_of_blend(path)
        raw = read_yaml(path, "scenario")
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise UserError(
            f"the top level must be a mapping of keys (name, frequency, imager, scene, ...), got a {type(raw).__name__}",
            file=path,
        )
    keys = [str(o).split("=", 1)[0].strip() for o in overrides] + [str(k) for k in (values or {})]
    # pixel regions set alongside the overrides are the rendered image's pixels, not the file's
    file_resolution = (
        None if any(k == "output" or k.startswith("output.regions") for k in keys) else _file_resolution(raw)
    )
    raw = apply_overrides(raw, list(overrides))
    if (
        file_resolution is not None
        and isinstance(raw.get("output"), dict)
        and raw["output"].get("regions")
        and "regions_resolution" not in raw["output"]
    ):
        # pixel regions are the file's pixels: on a resolution set from outside they scale with the image
        raw["output"] = {**raw["output"], "regions_resolution": file_resolution}
    if values:
        raw = apply_overrides(raw, [], values=plain(dict(values)))
    for key, dotted in (("spp", "render.spp"), ("workers", "render.workers"), ("seed", "render.seed")):
        if cli and cli.get(key) is not None:
            raw = apply_overrides(raw, [], values={dotted: plain(cli[key])})
    if cli and cli.get("out") is not None:
        raw = apply_overrides(raw, [], values={"output.dir": str(Path(cli["out"]).expanduser().resolve())})
    if blend is None:
        return _validate(raw, path.resolve())
    try:
        return _validate(raw, path.resolve())
    except UserError as e:  # name the .blend, not the scenario exported from it into a temporary folder
        for err in getattr(e, "errors", [e]):
            if err.file == str(path.resolve()):
                err.file = f"{blend} (as exported)"
        raise UserErrors(list(getattr(e, "errors", [e]))) from None


@overload
def plain(value: dict) -> dict: ...
@overload
def plain(value: object) -> object: ...
def plain(value: object) -> object:
    """A copy of ``value`` with numpy scalars and arrays as the Python numbers, booleans and
    lists they hold (in mappings, lists and tuples too): a value from numpy stands wherever its
    Python type does (``np.int64(8)`` for ``8``, ``np.bool_(True)`` for ``True``)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, dict):
        return {plain(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        items = [plain(v) for v in value]
        return tuple(items) if type(value) is tuple else items
    return copy.deepcopy(value)


def _split_key(key: str) -> list[str | int]:
    """``scene[0].material`` or ``scene.0.material`` -> ['scene', 0, 'material']; a segment in double
    quotes is one key, dots included, as pmmw's messages print it: ``materials."murakowski2014.water".
    temperature`` -> ['materials', 'murakowski2014.water', 'temperature']."""
    parts: list[str | int] = []
    for quoted, part in _segments(key):
        if quoted:
            parts.append(part)
            continue
        if not part:
            raise ValueError("empty key segment")
        idx: list[int] = []
        m = _INDEX.match(part)
        while m:
            idx.insert(0, int(m.group(2)))
            part = m.group(1)
            m = _INDEX.match(part)
        if part:
            parts.append(int(part) if part.isdigit() else part)
        parts.extend(idx)
    return parts


def _segments(key: str) -> list[tuple[bool, str]]:
    """A key path's dot-separated segments as (quoted, text); ValueError on unbalanced quotes."""
    out, i = [], 0
    while True:
        if key.startswith('"', i):
            end = key.find('"', i + 1)
            if end < 0 or key[end + 1 : end + 2] not in ("", "."):
                raise ValueError("malformed quoting")
            out.append((True, key[i + 1 : end]))
            i = end + 1
        else:
            end = key.find(".", i)
            end = len(key) if end < 0 else end
            if '"' in key[i:end]:
                raise ValueError("malformed quoting")
            out.append((False, key[i:end]))
            i = end
        if i >= len(key):
            return out
        i += 1  # the dot
        if i == len(key):
            out.append((False, ""))
            return out


def _file_resolution(raw: dict) -> list[int] | None:
    """The scenario file's own ``imager.resolution`` (before overrides), when it is two whole numbers."""
    res = raw.get("imager", {}).get("resolution") if isinstance(raw.get("imager"), dict) else None
    if (
        isinstance(res, (list, tuple))
        and len(res) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) for v in res)
    ):
        return list(res)
    return None


def apply_overrides(raw: dict, overrides: list[str], *, values: dict | None = None) -> dict:
    """Apply ``key.path=value`` items (values parsed as YAML) to a copy of the raw scenario."""
    out = copy.deepcopy(raw)
    items = []
    for item in overrides:
        if "=" not in item:
            raise UserError(f"expected KEY.PATH=VALUE, got {item!r}", file="--set", key=item.strip() or None)
        key, text = item.split("=", 1)
        key = key.strip()
        try:
            value = load_yaml(text, "--set", key.strip()) if text.strip() else ""
        except MalformedYAML:
            value = text  # not YAML: taken as the string typed
        items.append((key, value))
    items.extend((values or {}).items())
    for key, value in items:
        try:
            parts = _split_key(key)
        except ValueError:
            raise UserError(f"malformed key path {key!r}", file="--set", key=key) from None
        node = out
        for i, part in enumerate(parts):
            last = i == len(parts) - 1
            if isinstance(part, int) and isinstance(node, dict):
                part = part if part in node else str(part)  # a mapping key that happens to be digits
            if isinstance(part, int):
                if not isinstance(node, list):
                    raise UserError(f"{key_path(parts[:i]) or 'the top level'} is not a list", file="--set", key=key)
                if part >= len(node):
                    raise UserError(f"index {part} is past the end of a list of {len(node)}", file="--set", key=key)
            elif not isinstance(node, dict):
                raise UserError(f"{key_path(parts[:i])} is not a mapping", file="--set", key=key)
            if last:
                node[part] = value
            else:
                nxt = node[part] if (isinstance(part, int) or part in node) else None
                if nxt is None:
                    if isinstance(part, int):
                        raise UserError(f"cannot set inside {key_path(parts[: i + 1])}", file="--set", key=key)
                    nxt = node[part] = {}
                node = nxt
    return out


def _validate(raw: dict, path: Path) -> ScenarioConfig:
    data = dict(raw)
    errors: list[UserError] = []
    # keys the loader sets itself are not user keys
    for internal in ("source_file", "frequencies"):
        if internal in data:
            data.pop(internal)
            hint = "did you mean 'frequency'?" if internal == "frequencies" else "it is set by pmmw"
            errors.append(UserError(f"unknown key {internal!r}; {hint}", path, internal))
    imager = data.get("imager")
    freq_key = "frequency"
    if isinstance(imager, dict) and "frequency" in imager:
        imager = dict(imager)
        data["frequencies"] = imager.pop("frequency")
        data["imager"] = imager
        data.pop("frequency", None)
        freq_key = "imager.frequency"
    elif "frequency" in data:
        data["frequencies"] = data.pop("frequency")
    data.setdefault("name", default_name(path))
    data["source_file"] = str(path)
    if isinstance(data.get("scene"), list):
        entries = []
        for i, e in enumerate(data["scene"]):
            if isinstance(e, dict):
                if "key" in e:
                    extra = {"type": "extra_forbidden", "loc": ("scene", i, "key")}
                    errors.append(
                        problem(
                            extra,
                            path,
                            ScenarioConfig,
                            relocate=lambda loc: _relocate(loc, freq_key, raw),
                            allowed=_allowed,
                        )
                    )
                e = dict(e, key=f"scene[{i}]")
            entries.append(e)
        data["scene"] = entries
    return validate(
        ScenarioConfig,
        data,
        path,
        context={"base_dir": path.parent},
        relocate=lambda loc: _relocate(loc, freq_key, raw),
        allowed=_allowed,
        errors=errors,
    )


def _relocate(loc: list, freq_key: str, raw: dict) -> list:
    """Where the loader moved a key, the key the user wrote: ``frequencies`` back to
    ``frequency`` (or ``imager.frequency``), ``sky.file`` back to ``sky.texture``."""
    if loc and loc[0] == "frequencies":
        loc = freq_key.split(".") + loc[1:]
    sky = raw.get("sky")
    if loc[:2] == ["sky", "file"] and isinstance(sky, dict) and "texture" in sky:
        loc[1] = "texture"
    return loc


def _allowed(loc: list, names: list[str]) -> list[str]:
    """The keys a user may write at ``loc``: the model's fields less the loader's own, with the
    spellings the loader accepts for them (``frequency``, ``sky.texture``)."""
    names = [n for n in names if n != "frequencies"]
    if not loc:
        names.insert(1, "frequency")
    elif loc == ["sky"]:
        names.insert(names.index("file"), "texture")
    return names


def _region_display(r: Region) -> dict:
    """A region as the resolved scenario shows it (its pixel values scaled to the image)."""
    if r.box is not None:
        return {"box": list(r.box)}
    if r.bounds is not None:
        return {"bounds": [[_qty(v, "m") for v in corner] for corner in r.bounds]}
    assert r.center is not None  # Region's validator: exactly one of center, box, bounds
    radius = {"px": round(r.radius, 4), "m": _qty(r.radius, "m"), "rad": _qty(math.degrees(r.radius), "deg")}
    return {"center": [_qty(v, "m") for v in r.center], "radius": radius[r.radius_unit]}


def _qty(value: float, unit: str, scale: float = 1.0) -> str:
    """An SI float as a unit string that `parse_quantity` reads back to (nearly) the same float."""
    return f"{value / scale:.12g} {unit}"


def _receiver_display(rx: Receiver) -> dict:
    """``imager.receiver`` with its units, only the keys given (the choices exclude each other)."""
    out = {
        "noise_temperature": None if rx.noise_temperature is None else _qty(rx.noise_temperature, "K"),
        "noise_figure": None if rx.noise_figure is None else f"{rx.noise_figure:.12g} dB",
        "bandwidth": None if rx.bandwidth is None else _qty(rx.bandwidth, "GHz", 1e9),
        "integration_time": None if rx.integration_time is None else _qty(rx.integration_time, "s"),
        "frame_rate": None if rx.frame_rate is None else _qty(rx.frame_rate, "Hz"),
        "receivers": rx.receivers if rx.frame_rate is not None else None,
        "pixels_per_receiver": rx.pixels_per_receiver,
        "mode": rx.mode,
        "gain_fluctuation": rx.gain_fluctuation,
        "reference_temperature": None if rx.reference_temperature is None else _qty(rx.reference_temperature, "K"),
    }
    return {k: v for k, v in out.items() if v is not None}


def _antenna_display(a: Antenna) -> dict:
    """``imager.antenna`` with its units."""
    return {
        "illumination": a.illumination,
        **({"edge_taper": f"{a.edge_taper:.12g} dB"} if a.edge_taper is not None else {}),
        "blockage": a.blockage,
        **({"spillover": a.spillover} if a.spillover is not None else {}),
        "spillover_temperature": _qty(a.spillover_temperature, "K"),
        **({"off_axis": a.off_axis} if a.off_axis != "fixed" else {}),
    }


def _uniform_display(atm: AtmosphereConfig) -> dict:
    """``atmosphere`` of ``model: uniform`` with its units."""
    assert atm.loss is not None and atm.temperature is not None  # AtmosphereConfig's validator sets both
    return {
        "model": "uniform",
        "loss": _qty(atm.loss * 1e3 * 10 / math.log(10), "dB/km"),  # [Np/m] of power -> dB/km
        "temperature": _qty(atm.temperature, "K"),
    }


def scenario_to_display(scn: ScenarioConfig) -> dict:
    """The resolved scenario as plain YAML-able data, with units re-attached as strings.

    Without ``source_file`` (set by the loader), the result is itself a valid scenario that
    loads back to the same values; `pipeline.scenario_hash` hashes it, so every field that
    changes the traced image must appear here.
    """
    im = scn.imager
    freqs = [_qty(f, "GHz", 1e9) for f in scn.frequencies]
    imager = {
        "position": [_qty(v, "m") for v in im.position],
        "look_at": [_qty(v, "m") for v in im.look_at],
        "up": list(im.up),
        "fov": _qty(math.degrees(im.fov), "deg"),
        "resolution": list(im.resolution),
        "aperture_diameter": _qty(im.aperture_diameter, "m"),
        "noise": _qty(im.noise, "K"),
        **({"focus_distance": _qty(im.focus_distance, "m")} if im.focus_distance is not None else {}),
        "bandwidth": _qty(im.bandwidth, "GHz", 1e9),
        "band_samples": im.band_samples,
        **({"receiver": _receiver_display(im.receiver)} if im.receiver is not None else {}),
        **({"antenna": _antenna_display(im.antenna)} if im.antenna is not None else {}),
    }
    scene = []
    for e in scn.scene:
        t = e.transform
        scene.append(
            {
                "mesh": str(e.mesh),
                # exactly one of the two is given (SceneEntry's validator)
                **({"material": e.material} if e.materials is None else {"materials": dict(e.materials)}),
                "transform": {
                    "translate": [_qty(v, "m") for v in t.translate],
                    "rotate_deg": list(t.rotate_deg),
                    "scale": t.scale if isinstance(t.scale, float) else list(t.scale),
                },
                **({"up_axis": e.up_axis} if e.up_axis else {}),
                **({"name": e.name} if e.name else {}),
            }
        )
    atm = scn.atmosphere
    sky = scn.sky
    render = scn.render.model_dump()
    render.update(
        workers=scn.render.workers or "auto",
        default_temperature=_qty(scn.render.default_temperature, "K"),
        target_error=None if scn.render.target_error is None else _qty(scn.render.target_error, "K"),
        atmosphere_tolerance=_qty(scn.render.atmosphere_tolerance, "K"),
    )
    return {
        "name": scn.name,
        "source_file": str(scn.source_file),
        "frequency": freqs[0] if len(freqs) == 1 else freqs,
        "imager": imager,
        "scene": scene,
        "materials": copy.deepcopy(scn.materials),
        "atmosphere": "none"
        if atm is None
        else (
            _uniform_display(atm)
            if atm.model == "uniform"
            else {
                "model": "layered",
                "profile": atm.profile,
                **(
                    {"ground_temperature": _qty(atm.ground_temperature, "K")}
                    if atm.ground_temperature is not None
                    else {}
                ),
                **({"humidity": _qty(atm.humidity * 1e3, "g/m3")} if atm.humidity is not None else {}),
                "ground_altitude": _qty(atm.ground_altitude, "m"),
                "layers": [
                    {
                        "kind": w.kind,
                        "base": _qty(w.base, "m"),
                        "top": _qty(w.top, "m"),
                        **(
                            {"liquid_water": _qty(w.liquid_water * 1e3, "g/m3")}
                            if w.kind != "rain"
                            else {"rain_rate": _qty(w.rain_rate, "mm/h")}
                        ),
                        # a power law only: P.838 (the default) keeps the display, and the hash, it had
                        **(
                            {
                                "attenuation": {
                                    "model": "power_law",
                                    "coefficients": {
                                        _qty(f, "GHz", 1e9): {"a": a, "b": b} for f, a, b in w.attenuation.table()
                                    },
                                }
                            }
                            if w.attenuation.model == "power_law"
                            else {}
                        ),
                        **({"scattering": False} if not w.scattering else {}),
                    }
                    for w in atm.layers
                ],
            }
        ),
        "sky": {
            "model": sky.model,
            **({"temperature": _qty(sky.temperature, "K")} if sky.temperature is not None else {}),
            **({"file": str(sky.file)} if sky.file is not None else {}),
            **({"zenith_opacity": sky.zenith_opacity} if sky.zenith_opacity is not None else {}),  # [Np]
            "ground_temperature": _qty(sky.ground_temperature, "K"),
        },
        "render": render,
        "output": {
            "dir": str(scn.output.dir) if scn.output.dir is not None else None,
            "channels": list(scn.output.channels),
            "previews": scn.output.previews,
            "aux": list(scn.output.aux),
            **({"compression": scn.output.compression} if scn.output.compression != "none" else {}),
            **({"false_alarm": scn.output.false_alarm} if scn.output.false_alarm != 1e-3 else {}),
            **(
                {"regions": {n: _region_display(r) for n, r in scn.output.regions.items()}}
                if scn.output.regions
                else {}
            ),
        },
    }
