"""The tracer's kernels compiled in two processes at once: the first render after an install.

`kernels.warm` compiles (once after an install or an update) or loads every kernel of the
bounce loop, one after the other: about 35 s of one core on this project's 2-core machine for a
smooth scene (docs/benchmarks_command.md has the table per kernel). numba compiles in one thread,
so `compile_kernels` splits the work: a forked process runs `kernels.warm` with the kernels of
`CHILD` alone (the rest replaced by a function that does nothing), which compiles them and writes
them to numba's disk cache, while this process does the same with `PARENT`; then the whole
`kernels.warm` runs here, which loads the child's kernels from the cache (a fraction of a second)
and finds its own compiled already. The kernels' code is numba's either way: the same machine
code, the same numbers.

The two groups were chosen from the measured compile times (each about half of the total), split
so that the big shared code (the Fresnel and coating arithmetic) compiles in one process only;
the small helpers both groups call (the tallies `_add`/`_end`/`_fate`, `_off_surface1`, the ray
keys of `pmmw.rng`) compile in both, each writing the same cache entry. A kernel in neither group compiles in both processes (duplicate work, nothing worse); a name that
no longer exists is skipped. Where ``fork`` is not available (Windows, macOS's default), with one
core, or where the child fails, the kernels compile here one after the other as before: slower,
never wrong.

``python -m pmmw.trace.compile`` compiles the smooth scenes' kernels ahead of a first render
(``make``'s install step): that render then loads them, as later ones do.
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import multiprocessing
import os
import sys
import time

from pmmw.trace import kernels

__all__ = ["CHILD", "PARENT", "compile_kernels", "stubbed"]

log = logging.getLogger("pmmw")

#: The kernels the forked process compiles, as (module, attribute) that `kernels.warm` reads
#: them from: a segment's arrival, the survivors and the wave's compaction, emission, the sky,
#: the camera and the rays' random numbers, the intersector's distances, a tile's sums, the atmosphere's cell walk; for rough
#: scenes the tangents, the rough coating walk and the way off a surface.
CHILD = (
    ("pmmw.trace.kernels", "arrive"),
    ("pmmw.trace.kernels", "ambient_segments"),
    ("pmmw.trace.kernels", "survivors"),
    ("pmmw.trace.kernels", "compact"),
    ("pmmw.trace.kernels", "emit"),
    ("pmmw.trace.kernels", "sky_emit"),
    ("pmmw.trace.kernels", "tally"),
    ("pmmw.trace.kernels", "tile_means"),
    ("pmmw.trace.kernels", "stderr"),
    ("pmmw.trace.kernels", "_plane_distance"),
    ("pmmw.trace.kernels", "cross_layer"),
    ("pmmw.trace.kernels", "tangents"),
    ("pmmw.trace.kernels", "off_surface"),
    ("pmmw.scene.camera", "_pixel_samples"),
    ("pmmw.scene.camera", "_rays_loop"),
    ("pmmw.rng", "_ray_keys"),
    ("pmmw.rng", "_child_keys"),
    ("pmmw.rng", "_uniforms"),
    ("pmmw.scene.sky", "_sky_lookup"),
    ("pmmw.atmosphere.model", "_path_loop"),
)
#: The kernels this process compiles meanwhile: those that compute interface and coating
#: coefficients (`coefficients`, `scatter` in both specializations and `settle` share the
#: Fresnel and coating code, which each process would compile for itself) and the facet draws
#: and bump maps.
PARENT = (
    ("pmmw.trace.kernels", "coefficients"),
    ("pmmw.trace.kernels", "scatter"),
    ("pmmw.trace.kernels", "settle"),
    ("pmmw.physics.roughness", "_ggx_sample_rows"),
    ("pmmw.physics.roughness", "_smith_masking_rows"),
    ("pmmw.scene.bump", "_perturb_rows"),
    ("pmmw.scene.bump", "_shade_rows"),
)


def _nothing(*args, **kwargs):
    return None


@contextlib.contextmanager
def stubbed(names):
    """Within the block, each (module, attribute) of ``names`` is a function that does nothing,
    so that `kernels.warm` neither compiles nor loads it; restored after."""
    saved = []
    try:
        for mod, attr in names:
            module = importlib.import_module(mod)
            if hasattr(module, attr):
                saved.append((module, attr, getattr(module, attr)))
                setattr(module, attr, _nothing)
        yield
    finally:
        for module, attr, value in reversed(saved):
            setattr(module, attr, value)


def _child(stack_size: int, rough: bool) -> None:
    with stubbed(PARENT):
        kernels.warm(stack_size, rough=rough)


def compile_kernels(stack_size: int = 8, rough: bool = True) -> None:
    """`kernels.warm` with its compilation split between this process and a forked one (module
    docstring); without ``fork`` or with one core, `kernels.warm` alone. It always starts the
    child: a caller with the kernels cached calls `kernels.warm` instead (`pool.kernels_to_compile`
    tells which)."""
    if not (sys.platform.startswith("linux") and (os.cpu_count() or 1) > 1):
        kernels.warm(stack_size, rough=rough)
        return
    t0 = time.perf_counter()
    child = multiprocessing.get_context("fork").Process(target=_child, args=(stack_size, rough), daemon=True)
    child.start()
    try:
        with stubbed(CHILD):
            kernels.warm(stack_size, rough=rough)
        t1 = time.perf_counter()
        child.join()
        log.debug(
            "kernels compiled here in %.1f s, in the child in %.1f s (exit %s)",
            t1 - t0,
            time.perf_counter() - t0,
            child.exitcode,
        )
    finally:
        if child.is_alive():  # interrupted here: the child's work is not waited for
            child.terminate()
            child.join()
    kernels.warm(stack_size, rough=rough)  # loads the child's kernels from the cache (or compiles what it did not)


if (
    __name__ == "__main__"
):  # ``python -m pmmw.trace.compile``: the smooth scenes' kernels ahead of a first render (make install)
    compile_kernels(rough=False)
