"""Reference pages generated from the code at build time (run by mkdocs-gen-files, `make docs`).

Each fact exists once, in the code, and the pages are written from it:

* ``reference/cli.md``: every command and option, from the typer app's click commands;
* ``reference/scenario.md``: every scenario key with its type, unit and default, from the pydantic
  schema (`pmmw.config.schema`), with the comment written beside the field in the source;
* ``reference/materials.md``: every material of the shipped database with its permittivity model
  or table, valid range and source (`pmmw.scene.materials.MaterialDB`);
* ``reference/models.md``: every model of each registry (roughness, sky, permittivity);
* ``reference/api.md``: the Python API and the main library modules, from their docstrings
  (mkdocstrings reads them without importing the modules).

Also ``changelog.md`` (the repository's CHANGELOG.md) and ``shipped-scenes.md`` (scenes/README.md).
Run it alone to check it: ``python docs/gen_ref.py`` prints the pages' sizes;
tests/cli/test_docs_reference.py checks what the pages hold.
"""

from __future__ import annotations

import inspect
import math
import re
import sys
import typing
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

try:
    import mkdocs_gen_files
except ImportError:  # run alone: print instead of writing into the site
    mkdocs_gen_files = None

GENERATED = "This page is generated from the code at each build (`docs/gen_ref.py`); edit the code, not the page.\n\n"


def _write(name: str, text: str) -> None:
    if mkdocs_gen_files is None:
        print(f"{name}: {len(text)} characters")
        return
    with mkdocs_gen_files.open(name, "w") as f:
        f.write(text)
    mkdocs_gen_files.set_edit_path(name, "gen_ref.py")


def _cell(text) -> str:
    """Text for one Markdown table cell."""
    return " ".join(str(text).split()).replace("|", "\\|")


# -- commands -------------------------------------------------------------------------------------
# typer's click objects (typer may carry its own copy of click: parameters are told apart by their
# ``param_type_name``, groups by their ``commands``)


def _command_section(cmd, path: list[str], level: int) -> list[str]:
    """One command's heading, help, usage and a table of its parameters as ``--help`` prints them."""
    name = " ".join(path)
    out = [f"{'#' * level} `{name}`", ""]
    helptext = inspect.cleandoc(cmd.help or "")
    if helptext:
        out += [helptext, ""]
    ctx = cmd.context_class(cmd, info_name=path[-1])
    usage = " ".join([name, *cmd.collect_usage_pieces(ctx)])
    out += ["```text", usage, "```", ""]
    records = [(p, p.get_help_record(ctx)) for p in cmd.params]
    records = [(p, r) for p, r in records if r is not None and "--help" not in r[0]]
    if records:
        out += ["| parameter | what |", "| --- | --- |"]
        for p, (names, what) in records:
            out.append(f"| `{_cell(names)}` | {_cell(what)} |")
        out.append("")
    if hasattr(cmd, "commands"):
        for sub_name, sub in sorted(cmd.commands.items()):
            out += _command_section(sub, [*path, sub_name], level + 1)
    return out


def cli_page() -> str:
    import typer.main

    from pmmw_cli.cli import app

    root = typer.main.get_command(app)
    lines = [
        "# Commands",
        "",
        GENERATED.strip(),
        "",
        f"{inspect.cleandoc(root.help or '')}",
        "",
        "Every command prints a user error as one line `error: FILE: KEY: message` and exits with "
        "status 2; a problem of the machine (disk full, a lock held) exits with 1; an interrupt with "
        "128 + the signal's number ([reliability](../guide/reliability.md)). `pmmw COMMAND --help` "
        "prints the same options as below.",
        "",
    ]
    for name, cmd in sorted(root.commands.items()):
        lines += _command_section(cmd, ["pmmw", name], 2)
    return "\n".join(lines) + "\n"


# -- scenario keys --------------------------------------------------------------------------------


def _field_comments(cls) -> dict[str, str]:
    """field name -> the comment beside (or the comment lines just above) its line in the source."""
    try:
        src = inspect.getsource(cls)
    except (OSError, TypeError):
        return {}
    out, above = {}, []
    for line in src.splitlines()[1:]:
        s = line.strip()
        if s.startswith("#"):
            above.append(s.lstrip("# "))
            continue
        m = re.match(r"([a-z_][a-z0-9_]*)\s*:\s*[^=]", s)
        if m and line.startswith("    ") and not line.startswith("     "):
            beside = s.split("  # ", 1)[1] if "  # " in s else ""
            out[m.group(1)] = " ".join([*above, beside]).strip()
        if s.startswith(("def ", "@")):
            break
        above = []
    return out


def _type_name(tp) -> str:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin is typing.Annotated:
        return _type_name(args[0])
    if origin is typing.Union:
        names = [_type_name(a) for a in args if a is not type(None)]
        return " or ".join(names)
    if origin is typing.Literal:
        return " or ".join(f"`{a}`" for a in args)
    if origin in (tuple,):
        if len(args) == 2 and args[1] is Ellipsis:
            return f"list of {_type_name(args[0])}"
        if args and all(a == args[0] for a in args):
            return f"list of {len(args)} {_type_name(args[0])}"
        return "list (" + ", ".join(_type_name(a) for a in args) + ")"
    if origin is dict:
        return f"mapping {_type_name(args[0])} → {_type_name(args[1])}"
    if isinstance(tp, type):
        return {
            "str": "text",
            "int": "integer",
            "float": "number",
            "bool": "boolean",
            "PosixPath": "path",
            "Path": "path",
            "Any": "any",
        }.get(tp.__name__, tp.__name__)
    return str(tp).replace("typing.", "")


def _unit(field) -> str:
    from pmmw.config.schema import Quantity
    from pmmw.units import _KINDS

    for m in field.metadata:
        if isinstance(m, Quantity):
            internal, bare, _, noun = _KINDS[m.kind]
            stored = m.unit or internal
            taken = f"; a bare number in {bare}" if bare else "; give the unit"
            return f"{noun} [{stored}]{taken}"
    return ""


def _default_text(field, unit: str) -> str:
    from pydantic_core import PydanticUndefined

    d = field.default
    if d is PydanticUndefined:
        return "required"
    if d is None:
        return ""
    from pydantic import BaseModel

    if isinstance(d, BaseModel):
        return "see below"
    if isinstance(d, float) and "[rad]" in unit:
        return f"`{math.degrees(d):g} deg`"
    if isinstance(d, tuple):
        return "`[" + ", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in d) + "]`" if d else "`[]`"
    return f"`{d}`"


def _model_of(tp):
    """The pydantic model a field's type holds (itself, a list of it, a mapping to it), or None."""
    from pydantic import BaseModel

    for t in [tp, *typing.get_args(tp)]:
        for u in [t, *typing.get_args(t)]:
            if isinstance(u, type) and issubclass(u, BaseModel):
                return u
    return None


def _keys(model, prefix: str, rows: list, seen: set) -> None:
    from pmmw.config.schema import ScenarioConfig

    comments = {}
    for cls in reversed(model.__mro__):
        if hasattr(cls, "model_fields"):
            comments.update(_field_comments(cls))
    for name, field in model.model_fields.items():
        if field.exclude or name in ("source_file", "key"):
            continue
        key = "frequency" if (model is ScenarioConfig and name == "frequencies") else name
        path = f"{prefix}{key}"
        unit = _unit(field)
        sub = _model_of(field.annotation)
        tname = _type_name(field.annotation)
        rows.append(
            f"| `{path}` | {_cell(tname)} | {_cell(unit)} | {_cell(_default_text(field, unit))} | "
            f"{_cell(comments.get(name, ''))} |"
        )
        if sub is not None and sub not in seen:
            seen.add(sub)
            origin = typing.get_origin(field.annotation)
            inner = typing.get_args(field.annotation)
            if origin is tuple or (origin is typing.Union and any(typing.get_origin(a) is tuple for a in inner)):
                _keys(sub, f"{path}[i].", rows, seen)
            elif origin is dict:
                _keys(sub, f"{path}.NAME.", rows, seen)
            else:
                _keys(sub, f"{path}.", rows, seen)


def scenario_page() -> str:
    from pmmw.config import schema

    rows = ["| key | type | unit | default | note |", "| --- | --- | --- | --- | --- |"]
    _keys(schema.ScenarioConfig, "", rows, {schema.ScenarioConfig})
    lo, hi = schema.FREQUENCY_RANGE
    return "\n".join(
        [
            "# Scenario keys",
            "",
            GENERATED.strip(),
            "",
            "Every key of a scenario file, from the schema that validates it (`pmmw.config.schema`). "
            "The [scenario guide](../guide/scenario.md) explains them with examples. A quantity is a "
            "number or a unit string (`'95 GHz'`, `'0.8 mm'`, `'10 deg'`, `'20 degC'`); *unit* gives the "
            "unit pmmw stores it in and the unit a bare number is taken in. `[i]` is an item of a list, "
            "`NAME` a key of your choosing. An unknown key is an error that names it.",
            "",
            f"Frequencies lie within {lo / 1e9:g}-{hi / 1e9:g} GHz (the atmosphere models' range); an image "
            f"side is at most {schema.MAX_SIDE} pixels and {schema.MAX_PIXELS // (1 << 20)} Mpx in all.",
            "",
            *rows,
            "",
            "Material entries under `materials:` (a scenario's own materials, or overrides of the database's) "
            "take the keys of a database entry: see [Materials](materials.md).",
            "",
        ]
    )


# -- materials ------------------------------------------------------------------------------------


def materials_page() -> str:
    from pmmw.scene.materials import MaterialDB

    db = MaterialDB.load()
    rows = [
        "| id | name | kind | permittivity | valid range | temperature | source |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for mid in db.ids():
        m = db.get(mid)
        if m.model is not None:
            spec = m.model.spec
            params = ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}" for k, v in m.model.params.items())
            eps = f"model `{spec.name}`" + (f" ({params})" if params else "")
            rng = spec.ranges(m.model.params)
            if spec.intervals is None:  # the parameters leave the range the model's own, temperature too
                rng += f", {spec.temperatures()}"
        elif m.freqs:
            eps = "table: " + "; ".join(f"{f / 1e9:g} GHz: {e.real:.4g}{e.imag:+.3g}j" for f, e in zip(m.freqs, m.eps))
            rng = (
                f"{min(m.freqs) / 1e9:g}-{max(m.freqs) / 1e9:g} GHz (tabulated)"
                if len(m.freqs) > 1
                else f"{m.freqs[0] / 1e9:g} GHz"
            )
        else:
            eps, rng = ("perfect conductor" if m.kind == "opaque" else "—"), "any"
        if m.coating:
            eps += "; coated: " + ", ".join(f"{c.material} {c.thickness * 1e3:g} mm" for c in m.coating)
        if m.roughness is not None:
            eps += "; rough"
        temp = f"{m.temperature:g} K" if m.temperature is not None else "scene"
        rows.append(
            f"| `{mid}` | {_cell(m.name)} | {m.kind} | {_cell(eps)} | {_cell(rng)} | {temp} | {_cell(m.source)} |"
        )
    return "\n".join(
        [
            "# Materials",
            "",
            GENERATED.strip(),
            "",
            f"The {len(db)} materials of the shipped database (`materials/*.yaml`), as `pmmw materials list` "
            "shows them; `pmmw materials show ID --plot eps.png` draws one against frequency. A scenario "
            "names them by id; [the materials guide](../guide/materials.md) tells how a mesh's material "
            "names map to ids and how to add your own; [Material data](../materials.md) discusses the "
            "sources. Outside a material's valid range its value is still computed, with a warning.",
            "",
            *rows,
            "",
        ]
    )


# -- registries -----------------------------------------------------------------------------------


def _first_paragraph(obj) -> str:
    doc = inspect.getdoc(obj) or ""
    return doc.split("\n\n")[0].replace("\n", " ")


def models_page() -> str:
    from pmmw.physics import roughness
    from pmmw.scene import dielectric, sky

    out = [
        "# Models",
        "",
        GENERATED.strip(),
        "",
        "The models each registry offers, by the name a scenario or material file gives.",
        "",
        "## Roughness models",
        "",
        "Chosen by `roughness: {model: NAME, ...}` in a material (or a `pmmw brdf` stack layer); see "
        "[rough surfaces](../guide/rough-surfaces.md) and [the BRDF notes](../brdf.md). Registry: "
        "`pmmw.physics.roughness.REGISTRY`.",
        "",
        "| model | parameters (range, default) | what |",
        "| --- | --- | --- |",
    ]
    for name, ctor in roughness.REGISTRY.items():
        params = []
        for p, (lo, incl, hi, default, what) in roughness.PARAMETERS.get(name, {}).items():
            bound = f"{'≥' if incl else '>'} {lo:g}" + (f", ≤ {hi:g}" if hi is not None else "")
            d = (
                "required"
                if default is roughness._REQUIRED
                else ("optional" if default is None else f"default {default:g}")
            )
            params.append(f"`{p}`: {what} ({bound}; {d})")
        cell = "<br>".join(_cell(p) for p in params)
        out.append(f"| `{name}` | {cell} | {_cell(_first_paragraph(ctor))} |")
    out += [
        "",
        "## Sky models",
        "",
        "Chosen by `sky: {model: NAME}`; see [atmosphere and sky](../guide/atmosphere.md). Registry: "
        "`pmmw.scene.sky.SKY_MODELS`.",
        "",
        "| model | what |",
        "| --- | --- |",
    ]
    classes = {
        "uniform": sky.UniformSky,
        "slab": sky.SlabSky,
        "atmosphere": sky.AtmosphereSky,
        "texture": sky.TextureSky,
    }
    for name in sky.SKY_MODELS:
        out.append(f"| `{name}` | {_cell(_first_paragraph(classes.get(name, sky.SKY_MODELS[name])))} |")
    out += [
        "",
        "## Permittivity models",
        "",
        "Chosen by `model: {name: NAME, ...}` in a material entry; see [the materials guide]"
        "(../guide/materials.md). Registry: `pmmw.scene.dielectric.MODELS`.",
        "",
        "| model | parameters | frequency range | temperature range | source |",
        "| --- | --- | --- | --- | --- |",
    ]
    for name, ms in dielectric.MODELS.items():
        params = ", ".join(
            [f"`{p}`" for p in ms.params] + [f"`{p}` (optional)" for p in ms.optional if p not in ms.params]
        )
        out.append(
            f"| `{name}` | {params or '—'} | {ms.f_range[0] / 1e9:g}-{ms.f_range[1] / 1e9:g} GHz | "
            f"{ms.t_range[0]:g}-{ms.t_range[1]:g} K | {_cell(ms.source)} |"
        )
    return "\n".join(out) + "\n"


# -- API ------------------------------------------------------------------------------------------

API_MODULES = [
    ("pmmw.api", "The Python API: `pmmw.Scenario`, `render`, `validate`, `sky`, `brdf`, `po`, `sweep`."),
    ("pmmw.errors", "Errors and warnings."),
    ("pmmw.units", "Unit strings."),
    ("pmmw.config.load", "Reading scenarios."),
    ("pmmw.scene.materials", "The material database."),
    ("pmmw.scene.dielectric", "Permittivity models."),
    ("pmmw.scene.sky", "Sky models."),
    ("pmmw.physics.fresnel", "Fresnel coefficients."),
    ("pmmw.physics.multilayer", "Layered media."),
    ("pmmw.physics.roughness", "Microfacet roughness models."),
    ("pmmw.atmosphere.model", "The layered atmosphere."),
    ("pmmw.atmosphere.itu", "ITU-R models."),
    ("pmmw.imaging.imager", "The imager: beam, band, noise."),
    ("pmmw.imaging.detection", "The detection criterion."),
]


def api_pages() -> list[tuple[str, str]]:
    index = [
        "# Python API",
        "",
        GENERATED.strip(),
        "",
        "From the docstrings (numpydoc), read without importing the modules. The "
        "[Python API guide](../../guide/python-api.md) shows the API at work.",
        "",
        "| module | |",
        "| --- | --- |",
    ]
    pages = []
    for mod, what in API_MODULES:
        index.append(f"| [`{mod}`]({mod}.md) | {what} |")
        pages.append((f"reference/api/{mod}.md", f"# `{mod}`\n\n::: {mod}\n"))
    return [("reference/api/index.md", "\n".join(index) + "\n"), *pages]


# -- changelog ------------------------------------------------------------------------------------


def changelog_page() -> str:
    text = (ROOT / "CHANGELOG.md").read_text()
    # links into docs/ as the repository writes them, made relative to the site's root
    return re.sub(r"\]\(docs/", "](", text)


def main() -> None:
    _write("reference/cli.md", cli_page())
    _write("reference/scenario.md", scenario_page())
    _write("reference/materials.md", materials_page())
    _write("reference/models.md", models_page())
    for name, text in api_pages():
        _write(name, text)
    _write("changelog.md", changelog_page())
    # the scene scripts' guide, where it is kept (beside the scripts; its links start there: docs/hooks.py)
    _write("shipped-scenes.md", (ROOT / "scenes" / "README.md").read_text())


# mkdocs-gen-files runs the script with runpy.run_path (run name "<run_path>"); a test imports it
if __name__ in ("__main__", "<run_path>"):
    main()
