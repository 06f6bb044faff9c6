"""The import graph of `pmmw` (the library) and `pmmw_cli` (the command line on top of it;
docs/ARCHITECTURE.md, "Layers"): no circle, no import up a layer beyond the ones listed here to be
removed (none now), and nothing in the library importing the command line.

Every import counts, at module level or inside a function (a lazy import is still a dependency),
except those under ``if TYPE_CHECKING:``; ``from package import module`` is an edge to the module.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("pmmw", "pmmw_cli")

# Lowest first: a module may import its own layer and the ones below (docs/ARCHITECTURE.md). A
# module's layer is that of its package's first-level name (``pmmw.trace.pool`` -> ``trace``);
# the command line's modules are named with their package (``pmmw_cli.cli``).
LAYERS = (
    {"__init__", "arrays", "constants", "errors", "units", "jit", "rng", "memory", "interrupt", "timings", "procfs"},
    {"io", "distributed", "blender"},
    {"physics", "atmosphere", "config", "sweeps.spec"},
    {"scene", "surface", "imaging"},
    {"trace"},
    {"pipeline"},
    {"reflectance", "physical_optics", "sweeps", "sky_table", "filekinds"},
    {"api"},
    {
        "pmmw_cli",
        "pmmw_cli.validation",
        "pmmw_cli.bench",
        "pmmw_cli.bench_anchor",
        "pmmw_cli.bench_po",
        "pmmw_cli.progress",
    },
    {"pmmw_cli.cli"},
    {"pmmw_cli.__main__"},
)

# Imports up a layer still to be removed: none (the media records and the surfaces' kernels live in
# the surface layer, below the tracer that uses them).
KNOWN_UPWARD: set = set()


def _modules() -> dict[str, Path]:
    out = {}
    for package in PACKAGES:
        for p in (ROOT / package).rglob("*.py"):
            name = ".".join((package, *p.relative_to(ROOT / package).with_suffix("").parts))
            out[name.removesuffix(".__init__")] = p
    return out


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST) -> list:
    found = []

    def visit(node):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                continue
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                found.append(child)
            visit(child)

    visit(tree)
    return found


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    edges = {}
    for name, path in mods.items():
        targets = set()
        for node in _imports(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                base = node.module or ""
                if node.level:
                    parts = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
                    parts = parts[: len(parts) - (node.level - 1)]
                    base = ".".join(parts + ([node.module] if node.module else []))
                names = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
            for t in names:
                while t and t not in mods:
                    t = t.rpartition(".")[0]
                if t.split(".")[0] in PACKAGES and t != name:
                    targets.add(t)
        edges[name] = targets
    return edges


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(edges[w]))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return out


def _top(module: str) -> str:
    """The name `LAYERS` places a module by."""
    parts = module.split(".")
    if parts[0] == "pmmw_cli":
        return ".".join(parts[:2])
    if parts[1:3] == ["sweeps", "spec"]:
        return "sweeps.spec"
    return parts[1] if len(parts) > 1 else "__init__"


def _layer(module: str) -> int:
    return next(i for i, layer in enumerate(LAYERS) if _top(module) in layer)


def test_every_module_has_a_layer():
    tops = {_top(m) for m in _modules()}
    assert tops - set().union(*LAYERS) == set()


def test_the_library_never_imports_the_command_line():
    """`pmmw` is usable without `pmmw_cli`: no module of the library imports it (at any depth,
    lazily or not); the control: the command line does import the library."""
    edges = _graph()
    assert {
        (m, t)
        for m, ts in edges.items()
        if m.startswith("pmmw.") or m == "pmmw"
        for t in ts
        if t.startswith("pmmw_cli")
    } == set()
    assert any(t.startswith("pmmw.") for t in edges["pmmw_cli.cli"])


def test_no_import_circle():
    assert _cycles(_graph()) == []


def test_no_import_up_a_layer_but_the_known_ones():
    up = {(m, t) for m, ts in _graph().items() for t in ts if _layer(t) > _layer(m)}
    assert up == KNOWN_UPWARD


def test_the_analysis_finds_a_circle_and_an_upward_import():
    """Controls: a circle and an upward edge put into a copy of the graph are found."""
    edges = _graph()
    edges["pmmw.errors"] = edges["pmmw.errors"] | {"pmmw_cli.cli"}
    assert any("pmmw.errors" in c and "pmmw_cli.cli" in c for c in _cycles(edges))
    assert _layer("pmmw_cli.cli") > _layer("pmmw.errors")


def test_the_library_draws_without_pyplot(tmp_path):
    """Previews and plots come from figures pyplot does not know: drawing them neither imports
    pyplot nor chooses a backend, so a notebook's backend stays as it was (in a fresh process; the
    control: importing pyplot there does load it)."""
    import subprocess
    import sys

    code = f"""
import sys
import numpy as np
import matplotlib
from pmmw.io.preview import write_figure
from pmmw.scene.materials import MaterialDB, plot_materials
before = matplotlib.rcParams._get_backend_or_none()
write_figure({str(tmp_path / "a.png")!r}, [('I', np.random.default_rng(1).random((20, 30)) * 300)], title='t')
plot_materials(MaterialDB.load(), ['water', 'murakowski2014.water'], {str(tmp_path / "b.png")!r})
assert 'matplotlib.pyplot' not in sys.modules, 'pyplot imported'
assert matplotlib.rcParams._get_backend_or_none() == before, 'backend changed'
import matplotlib.pyplot
assert 'matplotlib.pyplot' in sys.modules
"""
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr[-2000:]
    assert (tmp_path / "a.png").stat().st_size > 1000 and (tmp_path / "b.png").stat().st_size > 10_000


# Where the library may still write to a terminal: the signal line of the entry point's runtime,
# the warning lines the command line installs, the add-on's zip builder run as a script, and the
# Blender add-on (it runs inside Blender, whose console is its log).
PRINTS_ALLOWED = {"pmmw/interrupt.py", "pmmw/errors.py", "pmmw/blender/__main__.py"}


def _writes(path: Path) -> list[int]:
    """Lines of ``print(...)`` calls and ``sys.stdout/stderr.write`` in a file."""
    lines = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Call):
            f = node.func
            if isinstance(f, ast.Name) and f.id == "print":
                lines.append(node.lineno)
            elif (
                isinstance(f, ast.Attribute)
                and f.attr == "write"
                and isinstance(f.value, ast.Attribute)
                and f.value.attr in ("stdout", "stderr")
            ):
                lines.append(node.lineno)
    return lines


def test_the_library_never_prints():
    """The library speaks through return values, exceptions, `warnings` and the ``pmmw`` logger
    (`pmmw.io.progress`); only the command line prints. The control: the scan finds the command
    line's own status line writing."""
    found = {}
    for p in sorted((ROOT / "pmmw").rglob("*.py")):
        rel = p.relative_to(ROOT).as_posix()
        if rel in PRINTS_ALLOWED or rel.startswith("pmmw/blender/pmmw_blender/"):
            continue
        if _writes(p):
            found[rel] = _writes(p)
    assert found == {}
    assert _writes(ROOT / "pmmw_cli" / "progress.py")


def test_progress_reaches_the_command_line_not_a_notebook(tmp_path):
    """A render's summary line is a `logging` record: the command shows it on standard error; the
    API (no handler configured) shows nothing on either stream."""
    import subprocess
    import sys

    code = """
import pmmw
scn = pmmw.Scenario.load("configs/landing_95ghz.yaml").set({"imager.resolution": [8, 8], "render.target_error": None})
pmmw.render(scn, spp=1, workers=1, out=%r)
""" % str(tmp_path / "api")
    api = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert api.returncode == 0, api.stderr[-2000:]
    assert "M rays" not in api.stdout + api.stderr
    cli = subprocess.run(
        [
            sys.executable,
            "-m",
            "pmmw_cli",
            "render",
            "configs/landing_95ghz.yaml",
            "--set",
            "imager.resolution=[8, 8]",
            "--set",
            "render.target_error=null",
            "--spp",
            "1",
            "--out",
            str(tmp_path / "cli"),
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=600,
    )
    assert cli.returncode == 0, cli.stderr[-2000:]
    assert "M rays" in cli.stdout  # the command's result on standard output, its notes on standard error
