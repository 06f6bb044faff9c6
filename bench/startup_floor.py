#!/usr/bin/env python3
"""The floor of `pmmw render`'s start-up: what any render needs before its first ray, step by step.

usage: python bench/startup_floor.py     (from the repository root, with numba's kernels cached:
                                          after one render, or `python -m pmmw.trace.compile`)

Prints, for one fresh process, the seconds after the process started (from `/proc`,
`pmmw.timings`) and each step's seconds, each after the ones before it: numpy, numba, embreex,
typer + pydantic + PyYAML (the command line's and the scenario's libraries), pmmw's kernel modules,
numba's first call of a cached kernel (its typing and target contexts are set up then) and the
other kernels of a smooth scene's bounce loop from numba's cache (`kernels.warm`). Compare with
the *first ray* of `pmmw render SCENARIO --timings` (docs/benchmarks_command.md, "Start-up to the
first ray"). Run it several times: a single run on a shared machine says little.
"""

import time

t0 = time.perf_counter()
import numpy as np  # noqa: E402

t1 = time.perf_counter()
import numba  # noqa: E402, F401

t2 = time.perf_counter()
import embreex.rtcore_scene  # noqa: E402, F401

t3 = time.perf_counter()
import pydantic  # noqa: E402, F401
import typer  # noqa: E402, F401
import yaml  # noqa: E402, F401

t4 = time.perf_counter()
from pmmw.trace import kernels  # noqa: E402

t5 = time.perf_counter()
kernels.stderr(np.zeros((1, 4)), np.zeros((1, 4)), np.ones(1, np.int64), np.zeros((1, 4)))
t6 = time.perf_counter()
kernels.warm(8, rough=False)
t7 = time.perf_counter()

from pmmw import timings  # noqa: E402

steps = {
    "numpy": t1 - t0,
    "numba": t2 - t1,
    "embreex": t3 - t2,
    "typer, pydantic, PyYAML": t4 - t3,
    "pmmw's kernel modules": t5 - t4,
    "numba's first cached call": t6 - t5,
    "the other kernels": t7 - t6,
}
print(f"{'all loaded at':<28s}{timings._since_start():7.3f} s after the process started")
for step, seconds in steps.items():
    print(f"{step:<28s}{seconds:7.3f} s")
