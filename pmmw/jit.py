"""The numba decorators of pmmw's compiled code, and a guard against stale on-disk caches.

Compiled functions are cached on disk (numba ``cache=True``: next to their source, in
``__pycache__``, or in numba's user cache), so only the first run after an install compiles them.
numba recompiles a cached function when *its own* source file changes, but a cached function
that calls compiled code of another file (the tracer's kernels call `pmmw.physics.fresnel`
and `pmmw.physics.roughness`) keeps the callee's old machine code: edit ``fresnel.py`` and
the tracer would go on with the old Fresnel coefficients. `clear_stale_caches` (run when this
module is imported, before any compiled function is loaded) hashes every source file listed in
`SOURCES`; when the hash differs from the one recorded with the caches, it deletes pmmw's cached
files so that everything recompiles once. ``NUMBA_DISABLE_JIT=1`` runs the same code as Python.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numba

__all__ = ["SOURCES", "clear_stale_caches", "is_cached", "inline", "njit"]

ROOT = Path(__file__).resolve().parent
#: Every module with compiled code (paths relative to the package).
SOURCES = (
    "atmosphere/model.py",
    "physics/fresnel.py",
    "physics/multilayer.py",
    "physics/roughness.py",
    "physical_optics/kernels.py",
    "rng.py",
    "scene/bump.py",
    "scene/camera.py",
    "scene/sky.py",
    "trace/intersect.py",
    "trace/kernels.py",
    "surface/kernels.py",
)
_STAMP = ROOT / "__pycache__" / "numba-sources.sha256"


def njit(**options):
    """`numba.njit` with pmmw's defaults: cached on disk, NumPy's floating-point error model (a
    division by zero gives inf or NaN, as the array code it replaces, instead of raising)."""
    return numba.njit(**{"cache": True, "error_model": "numpy", **options})


def inline(**options):
    """`njit` for small helpers called from other compiled code. LLVM inlines them where it pays;
    numba's own inlining (``inline="always"``) re-typed and re-lowered a helper at every call site
    and took about half of the first compile (docs/benchmarks_command.md), so pmmw does not use it."""
    return njit(**options)


def _digest() -> str:
    h = hashlib.sha256()
    for rel in SOURCES:
        h.update(rel.encode())
        h.update((ROOT / rel).read_bytes())
    return h.hexdigest()


def is_cached(rel: str, function: str | None = None) -> bool:
    """Whether the compiled code of the source ``rel`` (one of `SOURCES`; with ``function``, of
    that function of it) is cached on disk next to it, so that loading it takes a second rather
    than compiling it (about 20 s for the tracer's kernels on 2 cores, once after an
    install or an update). False also where numba caches elsewhere (a read-only install): the
    caller then says it may compile."""
    path = ROOT / rel
    pattern = f"{path.stem}.{function}-*.nbi" if function else f"{path.stem}.*.nbi"
    return any((path.parent / "__pycache__").glob(pattern))


def clear_stale_caches() -> bool:
    """Delete pmmw's numba cache files (``*.nbi``, ``*.nbc`` of `SOURCES` in their
    ``__pycache__``) when the sources changed since the caches were written. Returns whether it
    deleted anything. A read-only install (caches elsewhere, sources never edited) is left alone."""
    try:
        digest = _digest()
        if _STAMP.exists() and _STAMP.read_text().strip() == digest:
            return False
        removed = False
        for rel in SOURCES:
            path = ROOT / rel
            for f in (path.parent / "__pycache__").glob(f"{path.stem}.*.nb[ic]"):
                f.unlink(missing_ok=True)
                removed = True
        _STAMP.parent.mkdir(exist_ok=True)
        tmp = _STAMP.with_suffix(".tmp")
        tmp.write_text(digest + "\n")
        tmp.replace(_STAMP)
        return removed
    except OSError:
        return False


clear_stale_caches()
