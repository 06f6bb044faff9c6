"""What a sweep renders: `SweepSpec` (the scenario, the grid, zip, executor, output folder), read
from a sweep file or the command line (``--grid KEY=LIST``, ``linspace(START, STOP, N)``), and its
variants (every combination, or the lists side by side) as scenario overrides. `pmmw.sweeps.run`
renders them; `pmmw.sweeps.report` writes their report.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import yaml

from pmmw.config.load import _split_key
from pmmw.errors import UserError, UserErrors
from pmmw.io.records import check_keys, raise_all
from pmmw.io.yamlio import load_yaml, read_yaml

if TYPE_CHECKING:
    from pmmw.config.schema import ScenarioConfig

MAX_VARIANTS = 10_000
_LINSPACE = re.compile(r"^\s*linspace\(\s*([^,]+?)\s*,\s*([^,]+?)\s*,\s*(\d+)\s*\)\s*$")
_NUMBER_UNIT = re.compile(r"^([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*)$")


@dataclass
class SweepSpec:
    scenario: Path
    grid: list[tuple[str, list]]  # (key, values) in order
    zip: bool | list = False  # True: every list side by side; a list of keys: those side by side
    executor: str = "local"
    scheduler: str | None = None
    cluster: Path | None = None
    out: Path | None = None
    source: str = "--grid"  # where the grid came from, for messages
    workers: int | None = None
    names: dict = field(default_factory=dict)  # key -> display label of each value (table, plots)
    axis: dict = field(default_factory=dict)  # the plots' x axis: key, label, values (numbers per value)


def linspace(text: str, where: str) -> list | None:
    """``linspace(2000 m, 200 m, 10)`` -> ['2000 m', '1800 m', ...] (None if not a linspace)."""
    m = _LINSPACE.match(text)
    if not m:
        return None
    ends = []
    for part in (m.group(1), m.group(2)):
        nm = _NUMBER_UNIT.match(part)
        if not nm:
            raise UserError(f"linspace ends must be numbers with an optional unit, got {part!r}", where)
        ends.append((float(nm.group(1)), nm.group(2).strip()))
    count = m.group(3).lstrip("0") or "0"
    if len(count) > len(str(MAX_VARIANTS)) or int(count) > MAX_VARIANTS:  # sized before a value is made
        shown = count if len(count) <= 20 else f"a {len(count)}-digit number of"
        raise UserError(f"linspace of {shown} points: a sweep has at most {MAX_VARIANTS:,} variants", where)
    (a, ua), (b, ub), n = ends[0], ends[1], int(count)
    if ua != ub:
        raise UserError(f"linspace ends must share a unit, got {ua!r} and {ub!r}", where)
    if n < 1:
        raise UserError("linspace needs at least 1 point", where)
    values = [a + (b - a) * k / (n - 1) if n > 1 else a for k in range(n)]
    return [f"{v:.10g} {ua}" if ua else float(f"{v:.12g}") for v in values]


def grid_values(value: object, where: str) -> list:
    """A grid entry's values: a YAML list, a linspace string, or one value."""
    if isinstance(value, str):
        lin = linspace(value, where)
        if lin is not None:
            return lin
    if isinstance(value, list):
        if not value:
            raise UserError("an empty list: give at least one value", where)
        return value
    return [value]


def parse_grid_options(items: list[str]) -> list[tuple[str, list]]:
    """``KEY=YAML_LIST`` items (``--grid``) -> [(key, values)]."""
    out = []
    for item in items:
        if "=" not in item:
            raise UserError(f"expected KEY=LIST, e.g. 'frequency=[35 GHz, 95 GHz]', got {item!r}", "--grid")
        key, text = (s.strip() for s in item.split("=", 1))
        lin = linspace(text, f"--grid {key}")
        out.append((key, lin if lin is not None else grid_values(load_yaml(text, "--grid", key), f"--grid {key}")))
    keys = [k for k, _ in out]
    if len(set(keys)) != len(keys):
        raise UserError("a key is swept twice", "--grid")
    return out


def load_sweep_file(path: Path) -> SweepSpec:
    """A sweep file: ``scenario``, ``grid`` (key -> list or linspace), ``zip``, ``executor``,
    ``scheduler``, ``cluster``, ``out``; relative paths against the file's folder (``out``
    against the current folder, as a scenario's output folder)."""
    raw = read_yaml(path, "sweep file")
    if not isinstance(raw, dict):
        raise UserError("a sweep file is a mapping with scenario and grid", path)
    allowed = ("scenario", "grid", "zip", "names", "axis", "executor", "scheduler", "cluster", "workers", "out")
    errors = check_keys(raw, allowed, path, required=("scenario", "grid"))
    if errors:
        raise_all(errors)
    if not isinstance(raw["grid"], dict) or not raw["grid"]:
        raise UserError("expected a mapping of scenario key -> list of values", path, "grid")
    base = path.resolve().parent
    grid = [(str(k), grid_values(v, f"{path}: grid.{k}")) for k, v in raw["grid"].items()]
    scn = Path(str(raw["scenario"]))
    cluster = raw.get("cluster")
    zipped = raw.get("zip", False)
    if not isinstance(zipped, (bool, list)):
        raise UserError("expected true, false or a list of grid keys", path, "zip")
    lengths = dict((k, len(v)) for k, v in grid)
    names = raw.get("names") or {}
    if not isinstance(names, dict):
        raise UserError("expected a mapping of grid key -> list of labels", path, "names")
    for k, labels in names.items():
        if k not in lengths or not isinstance(labels, list) or len(labels) != lengths[k]:
            raise UserError(
                f"names.{k} must label each of the grid's {lengths.get(k, 0)} values of {k!r}", path, f"names.{k}"
            )
    axis = raw.get("axis") or {}
    if axis and (
        not isinstance(axis, dict)
        or axis.get("key") not in lengths
        or not isinstance(axis.get("values", []), list)
        or ("values" in axis and len(axis["values"]) != lengths[axis["key"]])
    ):
        raise UserError("expected {key: a grid key, label: text, values: one number per value}", path, "axis")
    return SweepSpec(
        scenario=scn if scn.is_absolute() else base / scn,
        grid=grid,
        zip=zipped,
        executor=str(raw.get("executor", "local")),
        scheduler=raw.get("scheduler"),
        cluster=None if cluster is None else (Path(cluster) if Path(cluster).is_absolute() else base / cluster),
        out=None if raw.get("out") is None else Path(str(raw["out"])),
        source=str(path),
        workers=raw.get("workers"),
        names={k: [str(x) for x in v] for k, v in names.items()},
        axis=dict(axis),
    )


def zipped_keys(spec: SweepSpec) -> list[str]:
    """The keys whose lists go side by side: all with ``zip: true``, the listed ones with a list."""
    keys = [k for k, _ in spec.grid]
    if spec.zip is True:
        return keys
    if not spec.zip:
        return []
    unknown = [k for k in spec.zip if k not in keys]
    if unknown:
        raise UserError(f"zip names {unknown[0]!r}, which is not in the grid", spec.source, "zip")
    return list(spec.zip)


def variant_steps(spec: SweepSpec) -> list[dict]:
    """Every combination of the grid, as each key's position in its list: zipped keys go side by
    side as one axis (a flight path of poses), in product with the others. Positions, not values,
    so that a value written twice in a list (a zipped list's control) keeps its own label."""
    zipped = zipped_keys(spec)
    axes = []  # each axis: a list of {key: position} steps
    if zipped:
        lists = [dict(spec.grid)[k] for k in zipped]
        if len({len(v) for v in lists}) != 1:
            raise UserError(
                f"zipped lists must have one length, got {[len(v) for v in lists]} for {zipped}", spec.source, "zip"
            )
    # the grid's size from its axes' lengths, before a combination is made
    lengths = ([len(lists[0])] if zipped else []) + [len(values) for k, values in spec.grid if k not in zipped]
    count = math.prod(lengths)
    if count > MAX_VARIANTS:
        raise UserError(
            f"{count:,} variants ({' x '.join(map(str, lengths))}); a sweep has at most "
            f"{MAX_VARIANTS:,}: sweep fewer values or zip keys side by side",
            spec.source,
        )
    if zipped:
        axes.append([dict.fromkeys(zipped, i) for i in range(lengths[0])])
    axes += [[{k: i} for i in range(len(values))] for k, values in spec.grid if k not in zipped]
    combos = [dict(kv for step in c for kv in step.items()) for c in itertools.product(*axes)]
    order = [k for k, _ in spec.grid]
    return [{k: c[k] for k in order} for c in combos]


def variants(spec: SweepSpec, steps: list[dict] | None = None) -> list[dict]:
    """Every combination of the grid's values, as {key: value}: ``steps`` (`variant_steps`, made
    here when not given) with each position replaced by its value."""
    grid = dict(spec.grid)
    return [{k: grid[k][i] for k, i in step.items()} for step in (variant_steps(spec) if steps is None else steps)]


def _yaml_value(v: object) -> str:
    # mappings in their written order: output.regions' order names each pair "a - b" (a the target)
    return yaml.safe_dump(v, default_flow_style=True, width=10_000, sort_keys=False).strip().removesuffix("...").strip()


def overrides_of(params: dict) -> list[str]:
    return [f"{k}={_yaml_value(v)}" for k, v in params.items()]


def _label(spec: SweepSpec, key: str, i: int) -> object:
    """The ``i``-th value of ``key``'s list as the table shows it: its name from ``names``, or
    itself (YAML for lists)."""
    if key in spec.names:
        return spec.names[key][i]
    value = dict(spec.grid)[key][i]
    return value if isinstance(value, (int, float, str)) else _yaml_value(value)


def _key_path(key: str) -> list:
    """A key as its path of segments, so that ``scene.1.material`` and ``scene[1].material`` are one key."""
    try:
        return _split_key(key)
    except ValueError:
        return [key]


def _grid_key_of(key: str | None, grid_keys: list[str]) -> str | None:
    """The grid key an error's scenario key path belongs to: the same key, one inside it
    (``imager`` swept whole, ``imager.noise`` wrong) or one it is inside."""
    if not key:
        return None
    path = _key_path(key)
    for gk in grid_keys:
        g = _key_path(gk)
        n = min(len(g), len(path))
        if path[:n] == g[:n]:
            return gk
    return None


def check_variants(spec: SweepSpec, check: Callable[[ScenarioConfig], object] | None = None) -> int:
    """Check every variant's scenario (the scenario file with the variant's values) against the
    scenario schema, before anything is rendered; returns the number of variants.

    A problem with a swept key or value is named in the sweep's own terms, once per key and
    message: ``FILE: grid.imager.nosie: unknown key 'nosie' (did you mean 'noise'?)``, with the
    value when only some values are wrong. A problem of the scenario file itself is named there.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    check : callable, optional
        ``check(scenario)``, run on each variant's loaded scenario and raising `UserError` or
        `UserErrors` (the jobs pass `pipeline.variant_check`: the material ids, which this layer
        cannot resolve); its errors are named as the schema's are.

    Raises
    ------
    UserError or UserErrors
        Every problem found, by file and key.
    """
    from pmmw.config import load_scenario

    combos = variants(spec)
    grid_keys = [k for k, _ in spec.grid]
    per_key_values = {k: len(v) for k, v in spec.grid}
    found: dict[tuple, list] = {}  # (grid key or None, file, key, message) -> the values it was seen with
    for params in combos:
        try:
            scn = load_scenario(spec.scenario, overrides_of(params))
            if check is not None:
                check(scn)
        except UserError as exc:
            for e in getattr(exc, "errors", [exc]):
                gk = _grid_key_of(e.key, grid_keys)
                where = (gk, None, None) if gk is not None else (None, e.file, e.key)
                seen = found.setdefault((*where, e.message), [])
                if gk is not None and _yaml_value(params[gk]) not in seen:
                    seen.append(_yaml_value(params[gk]))
    errors = []
    for (gk, file, key, message), values in found.items():
        if gk is None:
            errors.append(UserError(message, file, key))
            continue
        every = len(values) == per_key_values[gk]
        shown = "" if every else f"value{'s' if len(values) > 1 else ''} {', '.join(values)}: "
        file = spec.source if spec.source != "--grid" else "--grid"
        errors.append(UserError(f"{shown}{message}", file, f"grid.{gk}" if file != "--grid" else gk))
    if errors:
        raise UserErrors(errors) if len(errors) > 1 else errors[0]
    return len(combos)
