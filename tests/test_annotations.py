"""Type hints on the public signatures (docs/ARCHITECTURE.md, "Conventions"): every public function and
method of the modules mypy checks (``[tool.mypy] files`` in pyproject.toml) and of `HINTED` has a
hint on each parameter and on its return, so that mypy checks their callers and their bodies.

Read from the source with Python's ast, not imported. Public: a module-level function or a method of
a module-level class whose name has no leading underscore, or a dunder such as ``__init__`` (methods
of a private base class count: its public subclasses inherit them). ``self``/``cls`` need no hint.
numba's compiled functions (decorated with `pmmw.jit.njit`/`inline` or a module's alias of them,
``_jit = njit()``) are left out: numba types them itself and ignores annotations.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# Hinted beyond mypy's list (their public signatures are held to the same rule; mypy does not
# check their bodies yet): none at present, every hinted module is in mypy's list.
HINTED: tuple[str, ...] = ()

NUMBA_DECORATORS = {"njit", "inline", "jit", "vectorize", "guvectorize"}


def _name(node: ast.expr) -> str:
    if isinstance(node, ast.Call):
        node = node.func
    if isinstance(node, ast.Attribute):
        return node.attr
    return node.id if isinstance(node, ast.Name) else ""


def _numba_aliases(tree: ast.Module) -> set[str]:
    """Module-level names bound to a numba decorator, e.g. ``_jit = njit()``."""
    return {
        t.id
        for n in tree.body
        if isinstance(n, ast.Assign) and isinstance(n.value, ast.Call) and _name(n.value) in NUMBA_DECORATORS
        for t in n.targets
        if isinstance(t, ast.Name)
    }


def _is_public(name: str) -> bool:
    return not name.startswith("_") or (name.startswith("__") and name.endswith("__"))


def missing_hints(source: str, where: str = "<module>") -> list[str]:
    """``"where:line Class.name: param, ..., return"`` for each public def lacking a hint."""
    tree = ast.parse(source)
    numba = NUMBA_DECORATORS | _numba_aliases(tree)
    out = []

    def check(fn: ast.FunctionDef | ast.AsyncFunctionDef, owner: str, method: bool) -> None:
        decorators = {_name(d) for d in fn.decorator_list}
        if decorators & numba or not _is_public(fn.name):
            return
        a = fn.args
        params = [*a.posonlyargs, *a.args]
        if method and "staticmethod" not in decorators and params:
            params = params[1:]  # self or cls
        params += [*a.kwonlyargs, *(p for p in (a.vararg, a.kwarg) if p is not None)]
        lacking = [p.arg for p in params if p.annotation is None]
        if fn.returns is None:
            lacking.append("return")
        if lacking:
            out.append(f"{where}:{fn.lineno} {owner}{fn.name}: {', '.join(lacking)}")

    def walk(body: list[ast.stmt], owner: str, in_class: bool) -> None:
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                check(node, owner, in_class)
            elif isinstance(node, ast.ClassDef) and not owner:
                walk(node.body, f"{node.name}.", True)
            elif isinstance(node, (ast.If, ast.Try)):  # definitions under `if`/`try` at the same level
                walk(node.body, owner, in_class)
                walk(node.orelse, owner, in_class)

    walk(tree.body, "", False)
    return out


def _checked_files() -> list[Path]:
    # ``files = [...]`` of [tool.mypy] (read by hand: tomllib is Python >= 3.11)
    section = (ROOT / "pyproject.toml").read_text().split("[tool.mypy]", 1)[1]
    listed = re.findall(r'"([^"]+)"', re.search(r"^files = \[(.*?)\]", section, re.S | re.M).group(1))
    paths = []
    for entry in [*listed, *HINTED]:
        p = ROOT / entry
        paths += sorted(p.rglob("*.py")) if p.is_dir() else [p]
    return paths


def test_every_public_signature_is_hinted():
    files = _checked_files()
    assert len(files) > 20  # the list was read (physics, atmosphere, units, ...)
    lacking = [m for p in files for m in missing_hints(p.read_text(), str(p.relative_to(ROOT)))]
    assert lacking == []


def test_the_check_reports_a_def_without_hints():
    """Control: a module with unhinted public defs is reported, one line per def naming what lacks
    a hint; private helpers, numba kernels (direct or through an alias) and ``self`` are not."""
    source = """
import numpy as np
from pmmw.jit import njit

_jit = njit()


def interface(eps1, eps2: complex, cos1=0.0):
    return eps1


def hinted(x: float, *args: float, scale: float = 1.0, **kw: int) -> float:
    return x


def _helper(x):
    return x


@_jit
def _loop(a, out):
    out[:] = a


@njit(cache=True)
def kernel(a):
    return a


class Model:
    def __init__(self, alpha):
        self.alpha = alpha

    def sample(self, n: int) -> np.ndarray:
        return np.zeros(n)

    def pdf(self, m: np.ndarray, *, tangent=None) -> np.ndarray:
        return m

    @staticmethod
    def make(spec) -> "Model":
        return Model(spec)

    @property
    def name(self):
        return "model"
"""
    assert missing_hints(source, "m.py") == [
        "m.py:8 interface: eps1, cos1, return",
        "m.py:31 Model.__init__: alpha, return",
        "m.py:37 Model.pdf: tangent",
        "m.py:41 Model.make: spec",
        "m.py:45 Model.name: return",
    ]
    fixed = source.replace("def interface(eps1, eps2: complex, cos1=0.0):", "def interface(e: float) -> float:")
    assert not any("interface" in m for m in missing_hints(fixed))
