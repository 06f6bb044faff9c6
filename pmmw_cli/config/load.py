"""YAML file + ``--set`` overrides -> validated `Scenario`, with every error named by file and key."""

from __future__ import annotations

import copy
import math
import re
import typing
from pathlib import Path

import yaml
from pydantic import BaseModel, ValidationError

from pmmw_cli.config.schema import Scenario
from pmmw_cli.errors import UserError, UserErrors

_INDEX = re.compile(r"^(.*?)\[(\d+)\]$")


def load_scenario(path, overrides=(), *, cli: dict | None = None) -> Scenario:
    """Read, override, validate and resolve a scenario file.

    Parameters
    ----------
    path : str or Path
        The scenario YAML.
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
    if not path.exists():
        raise UserError("scenario file not found", file=path)
    if not path.is_file():
        raise UserError("is not a file (expected a scenario YAML)", file=path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise UserError(f"cannot read: {e}", file=path) from None
    try:
        raw = yaml.safe_load(text)
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        raise UserError(f"malformed YAML: {where}{e.problem or e}", file=path) from None
    except yaml.YAMLError as e:
        raise UserError(f"malformed YAML: {e}", file=path) from None
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise UserError(f"the top level must be a mapping of keys (name, frequency, imager, scene, ...), got a {type(raw).__name__}", file=path)
    raw = apply_overrides(raw, list(overrides))
    for key, dotted in (("spp", "render.spp"), ("workers", "render.workers"), ("seed", "render.seed")):
        if cli and cli.get(key) is not None:
            raw = apply_overrides(raw, [], values={dotted: cli[key]})
    if cli and cli.get("out") is not None:
        raw = apply_overrides(raw, [], values={"output.dir": str(Path(cli["out"]).expanduser().resolve())})
    return _validate(raw, path.resolve())


def _split_key(key: str) -> list:
    """``scene[0].material`` or ``scene.0.material`` -> ['scene', 0, 'material']."""
    parts = []
    for part in key.split("."):
        if not part:
            raise ValueError("empty key segment")
        idx = []
        m = _INDEX.match(part)
        while m:
            idx.insert(0, int(m.group(2)))
            part = m.group(1)
            m = _INDEX.match(part)
        if part:
            parts.append(int(part) if part.isdigit() else part)
        parts.extend(idx)
    return parts


def apply_overrides(raw: dict, overrides: list[str], *, values: dict | None = None) -> dict:
    """Apply ``key.path=value`` items (values parsed as YAML) to a copy of the raw scenario."""
    out = copy.deepcopy(raw)
    items = []
    for item in overrides:
        if "=" not in item:
            raise UserError(f"expected KEY.PATH=VALUE, got {item!r}", file="--set")
        key, text = item.split("=", 1)
        key = key.strip()
        try:
            value = yaml.safe_load(text) if text.strip() else ""
        except yaml.YAMLError:
            value = text
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
            if isinstance(part, int):
                if not isinstance(node, list):
                    raise UserError(f"{_fmt(parts[:i]) or 'the top level'} is not a list", file="--set", key=key)
                if part >= len(node):
                    raise UserError(f"index {part} is past the end of a list of {len(node)}", file="--set", key=key)
            elif not isinstance(node, dict):
                raise UserError(f"{_fmt(parts[:i])} is not a mapping", file="--set", key=key)
            if last:
                node[part] = value
            else:
                nxt = node[part] if (isinstance(part, int) or part in node) else None
                if nxt is None:
                    if isinstance(part, int):
                        raise UserError(f"cannot set inside {_fmt(parts[:i + 1])}", file="--set", key=key)
                    nxt = node[part] = {}
                node = nxt
    return out


def _fmt(loc) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _validate(raw: dict, path: Path) -> Scenario:
    data = dict(raw)
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
    if "frequencies" in raw:  # the internal name is not a user key
        data.pop("frequencies", None)
        return _raise([UserError("unknown key 'frequencies'; did you mean 'frequency'?", path, "frequencies")])
    data.setdefault("name", path.stem)
    data["source_file"] = str(path)
    if isinstance(data.get("scene"), list):
        data["scene"] = [dict(e, key=f"scene[{i}]") if isinstance(e, dict) else e for i, e in enumerate(data["scene"])]
    try:
        return Scenario.model_validate(data, context={"base_dir": path.parent})
    except ValidationError as exc:
        errors = [_user_error(err, path, freq_key) for err in exc.errors()]
        return _raise(errors)


def _raise(errors):
    unique, seen = [], set()
    for e in errors:
        if str(e) not in seen:
            seen.add(str(e))
            unique.append(e)
    raise UserErrors(unique) if len(unique) > 1 else unique[0]


def _user_error(err: dict, path: Path, freq_key: str) -> UserError:
    loc = list(err["loc"])
    if loc and loc[0] == "frequencies":
        loc = freq_key.split(".") + loc[1:]
        loc = [p for p in loc if not isinstance(p, int)] if len(loc) > 1 else loc
    typ = err["type"]
    if typ == "extra_forbidden":
        allowed = _allowed_keys(loc[:-1])
        msg = f"unknown key {loc[-1]!r}" + (f"; allowed: {', '.join(allowed)}" if allowed else "")
    elif typ == "missing":
        msg = "required key missing"
    elif typ in ("value_error", "assertion_error"):
        msg = str(err.get("ctx", {}).get("error", err["msg"]))
    else:
        msg = err["msg"]
        if "input" in err and not isinstance(err["input"], (dict, list)):
            msg += f", got {err['input']!r}"
    # drop pydantic's union/function-wrapper tags from the location
    loc = [p for p in loc if not (isinstance(p, str) and ("[" in p or p.startswith("function-")))]
    return UserError(msg, file=path, key=_fmt(loc) or None)


def _allowed_keys(loc) -> list[str]:
    """The field names of the model at ``loc`` inside `Scenario`, for "unknown key" messages."""
    tp = Scenario
    for part in loc:
        tp = _item_type(tp, part)
        if tp is None:
            return []
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        hidden = {"source_file", "frequencies", "key"}
        names = [n for n in tp.model_fields if n not in hidden]
        if tp is Scenario:
            names.insert(1, "frequency")
        return names
    return []


def _item_type(tp, part):
    tp = _unwrap(tp)
    if isinstance(part, int):
        args = typing.get_args(tp)
        return _unwrap(args[0]) if args else None
    if isinstance(tp, type) and issubclass(tp, BaseModel) and part in tp.model_fields:
        return _unwrap(tp.model_fields[part].annotation)
    return None


def _unwrap(tp):
    origin = typing.get_origin(tp)
    if origin is typing.Union or (origin is not None and str(origin) == "types.UnionType"):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return _unwrap(args[0]) if len(args) == 1 else tp
    return tp


def _fmt_quantity(value: float, unit: str, scale: float = 1.0) -> str:
    return f"{value / scale:.6g} {unit}"


def scenario_to_display(scn: Scenario) -> dict:
    """The resolved scenario as plain YAML-able data, with units re-attached."""
    im = scn.imager
    freqs = [_fmt_quantity(f, "GHz", 1e9) for f in scn.frequencies]
    out = {
        "name": scn.name,
        "source_file": str(scn.source_file),
        "frequency": freqs[0] if len(freqs) == 1 else freqs,
        "imager": {
            "position_m": list(im.position), "look_at_m": list(im.look_at), "up": list(im.up),
            "fov": _fmt_quantity(math.degrees(im.fov), "deg"), "resolution": list(im.resolution),
            "aperture_diameter": _fmt_quantity(im.aperture_diameter, "m"), "noise": _fmt_quantity(im.noise, "K"),
        },
        "scene": [
            {
                "mesh": str(e.mesh),
                **({"material": e.material} if e.material is not None else {"materials": dict(e.materials)}),
                "transform": {"translate_m": list(e.transform.translate), "rotate_deg": list(e.transform.rotate_deg),
                              "scale": e.transform.scale if isinstance(e.transform.scale, float) else list(e.transform.scale)},
                **({"up_axis": e.up_axis} if e.up_axis else {}),
                **({"name": e.name} if e.name else {}),
            }
            for e in scn.scene
        ],
        "materials": copy.deepcopy(scn.materials),
        "atmosphere": "none" if scn.atmosphere is None else {
            "loss": _fmt_quantity(scn.atmosphere.loss * 1e3 * 10 / math.log(10), "dB/km"),
            "temperature": _fmt_quantity(scn.atmosphere.temperature, "K"),
        },
        "sky": {
            "model": scn.sky.model,
            **({"temperature": _fmt_quantity(scn.sky.temperature, "K")} if scn.sky.temperature is not None else {}),
            **({"file": str(scn.sky.file)} if scn.sky.file is not None else {}),
            **({"zenith_opacity_Np": scn.sky.zenith_opacity} if scn.sky.zenith_opacity is not None else {}),
            "ground_temperature": _fmt_quantity(scn.sky.ground_temperature, "K"),
        },
        "render": {
            **scn.render.model_dump(),
            "workers": scn.render.workers or "auto",
            "default_temperature": _fmt_quantity(scn.render.default_temperature, "K"),
        },
        "output": {
            "dir": str(scn.output.dir) if scn.output.dir is not None else None,
            "channels": list(scn.output.channels), "previews": scn.output.previews, "aux": list(scn.output.aux),
        },
    }
    return out
