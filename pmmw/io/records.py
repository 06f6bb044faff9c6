"""YAML mappings -> typed records: the one path from what a user wrote to a validated pydantic
model, for every file kind pmmw reads (scenarios, material databases, physical-optics jobs,
atmosphere files).

`pmmw.io.yamlio.read_yaml` reads the file (duplicate keys and alias bombs refused); `validate`
turns the mapping into the file kind's model, and every problem pydantic finds into a
`UserError` naming the file and the key path as the user wrote it (``imager.pixels[1]``), with one
wording for every file kind:

* an unknown key: ``unknown key 'nosie' (did you mean 'noise'?); allowed: ...``, the allowed keys
  read from the model at that place;
* a missing key: ``required key missing``;
* a value a validator refused: the validator's own message;
* anything else: pydantic's message and the value given.

A file kind whose values are parsed by hand (sweep files, reflectance stacks) checks its keys with
`check_keys`, in the same wording.

A file kind adapts `validate` through three hooks: ``relocate`` (the key the user wrote where the model
stores it under another name), ``allowed`` (the key names to offer where the model's field
names differ from them) and ``wording`` (a message of its own for some problems).
"""

from __future__ import annotations

import difflib
import json
import re
import typing
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

from pydantic import BaseModel, ValidationError

from pmmw.errors import UserError, UserErrors

__all__ = ["allowed_keys", "check_keys", "key_path", "problem", "raise_all", "validate"]

#: Fields the loaders fill in themselves: never offered as keys a user may write.
HIDDEN_FIELDS = frozenset({"source_file", "key"})

Location = list[Any]
Relocate = Callable[[Location], Location]
Allowed = Callable[[Location, list[str]], list[str]]
Wording = Callable[[Mapping[str, Any], Location], "str | None"]


_PLAIN_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def key_path(loc: Iterable[Any], base: str | None = None) -> str:
    """A location as the key path a user reads: ``("imager", "pixels", 1)`` -> ``imager.pixels[1]``;
    a key that is not a plain name is quoted (``materials.runway.eps."95 GHz"``); ``base`` is a key
    path already written out, taken as is; empty parts are skipped."""
    out = base or ""
    for part in loc:
        if part is None or part == "":
            continue
        if isinstance(part, int) and not isinstance(part, bool):
            out += f"[{part}]"
            continue
        seg = str(part)
        seg = seg if _PLAIN_KEY.match(seg) else json.dumps(seg, ensure_ascii=False)
        out = f"{out}.{seg}" if out else seg
    return out


def _is_tag(part: Any) -> bool:
    """pydantic's union member and validator wrapper tags inside a location (not user keys)."""
    return isinstance(part, str) and ("[" in part or part.startswith("function-"))


def _unwrap(tp: Any) -> Any:
    origin = typing.get_origin(tp)
    if origin is typing.Union or (origin is not None and str(origin) == "types.UnionType"):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return _unwrap(args[0]) if len(args) == 1 else tp
    return tp


def _item_type(tp: Any, part: Any) -> Any:
    tp = _unwrap(tp)
    if isinstance(part, int):
        args = typing.get_args(tp)
        return _unwrap(args[0]) if args else None
    if isinstance(tp, type) and issubclass(tp, BaseModel) and part in tp.model_fields:
        return _unwrap(tp.model_fields[part].annotation)
    return None


def allowed_keys(model: type[BaseModel], loc: Sequence[Any], hidden: Iterable[str] = HIDDEN_FIELDS) -> list[str]:
    """The field names of the model found at ``loc`` inside ``model`` (none where ``loc`` does
    not lead to a model), less the ``hidden`` ones."""
    tp: Any = model
    for part in loc:
        tp = _item_type(tp, part)
        if tp is None:
            return []
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        hide = set(hidden)
        return [n for n in tp.model_fields if n not in hide]
    return []


def unknown_key(key: Any, allowed: Sequence[str], what: str | None = None) -> str:
    """The message for an unknown key (of a ``what``, e.g. "coating layer"): the nearest allowed
    key, then all of them."""
    close = difflib.get_close_matches(str(key), list(allowed), n=1, cutoff=0.6)
    return (
        f"unknown key {key!r}"
        + (f" for a {what}" if what else "")
        + (f" (did you mean {close[0]!r}?)" if close else "")
        + (f"; allowed: {', '.join(allowed)}" if allowed else "")
    )


def check_keys(
    mapping: dict, allowed: Sequence[str], file: Any, prefix: Sequence[Any] = (), required: Sequence[str] = ()
) -> list[UserError]:
    """The problems with a mapping's keys, in `validate`'s wording: each key not in ``allowed``
    and each ``required`` key missing, named by ``file`` and key path (under ``prefix``)."""
    out = [UserError(unknown_key(k, allowed), file, key_path([*prefix, k])) for k in mapping if k not in allowed]
    out += [UserError("required key missing", file, key_path([*prefix, k])) for k in required if k not in mapping]
    return out


def problem(
    err: Mapping[str, Any],
    file: Any,
    model: type[BaseModel],
    *,
    prefix: Sequence[Any] | str = (),
    relocate: Relocate | None = None,
    allowed: Allowed | None = None,
    wording: Wording | None = None,
) -> UserError:
    """One entry of a `pydantic.ValidationError` as a `UserError` naming ``file`` and the key.

    Parameters
    ----------
    err : dict
        An entry of ``ValidationError.errors()``.
    file : path or str
        The file the mapping came from.
    model : pydantic model class
        The model validated, to list the keys allowed where an unknown key was found.
    prefix : sequence or str
        Where the validated mapping sits in the file: parts (``("atmosphere",)``) or a key path
        already written out (``"materials.runway"``).
    relocate, allowed, wording : callables, optional
        The file kind's hooks (module docstring).
    """
    loc = list(err["loc"])
    if relocate is not None:
        loc = relocate(loc)
    typ = err["type"]
    msg = wording(err, loc) if wording is not None else None
    if msg is None:
        if typ == "extra_forbidden":
            names = allowed_keys(model, [p for p in loc[:-1] if not _is_tag(p)])
            if allowed is not None:
                names = allowed(loc[:-1], names)
            msg = unknown_key(loc[-1], names)
        elif typ == "missing":
            msg = "required key missing"
        elif typ in ("value_error", "assertion_error"):
            msg = str(err.get("ctx", {}).get("error", err["msg"]))
        else:
            msg = err["msg"]
            if "input" in err and not isinstance(err["input"], (dict, list)):
                msg += f", got {err['input']!r}"
    parts = [p for p in loc if not _is_tag(p)]
    key = key_path(parts, prefix) if isinstance(prefix, str) else key_path([*prefix, *parts])
    return UserError(msg, file=file, key=key or None)


def raise_all(errors: Sequence[UserError]) -> typing.NoReturn:
    """Raise every distinct problem: one `UserError`, or `UserErrors` for several."""
    unique: list[UserError] = []
    seen: set[str] = set()
    for e in errors:
        if str(e) not in seen:
            seen.add(str(e))
            unique.append(e)
    raise UserErrors(unique) if len(unique) > 1 else unique[0]


M = typing.TypeVar("M", bound=BaseModel)


def validate(
    model: type[M],
    data: Any,
    file: Any,
    *,
    context: dict | None = None,
    prefix: Sequence[Any] | str = (),
    relocate: Relocate | None = None,
    allowed: Allowed | None = None,
    wording: Wording | None = None,
    errors: Sequence[UserError] = (),
) -> M:
    """``data`` (a mapping read from ``file``) as a ``model`` record.

    Parameters
    ----------
    model : pydantic model class
    data : mapping
    file : path or str
        Named in every error.
    context : dict, optional
        pydantic's validation context (e.g. ``base_dir`` to resolve relative paths).
    prefix, relocate, allowed, wording
        As `problem`.
    errors : sequence of UserError
        Problems the caller found before validating, raised together with pydantic's.

    Raises
    ------
    UserError or UserErrors
        Every problem, each naming ``file`` and its key; a validator's own `UserError` gets the
        file named if it did not name one.
    """
    found = list(errors)
    record = None
    try:
        record = model.model_validate(data, context=context)
    except ValidationError as exc:
        found += [
            problem(e, file, model, prefix=prefix, relocate=relocate, allowed=allowed, wording=wording)
            for e in exc.errors()
        ]
    except UserError as e:  # raised unwrapped by a validator: still name the file
        e.file = e.file or str(file)
        found.append(e)
    if found:
        raise_all(found)
    assert record is not None
    return record
