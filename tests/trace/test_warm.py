"""`kernels.warm` compiles (or loads) every signature the bounce loop uses, so that forked
workers compile nothing of their own: its dummy arguments come from the records' own types
(`pmmw.surface.records`: ``empty``), and this test renders tiles in one fresh process after
``warm`` and asks every compiled function of the tracer's modules which signatures it has.

The check is exact (a set of signatures, no tolerance). Its control: ``warm(rough=False)``
leaves out the rough faces' kernels, and the same rough render must then find signatures that
warm did not make, so the check can fail.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

_SCRIPT = r"""
import importlib, json, sys
import numba
from numba.core.registry import CPUDispatcher
from pmmw import jit, pipeline
from pmmw.trace import kernels
from pmmw.trace.integrator import Integrator
from pmmw.trace.intersect import make_intersector

rough = sys.argv[1] == "rough"
modules = [importlib.import_module("pmmw." + s[:-3].replace("/", ".")) for s in jit.SOURCES]

def signatures():
    out = {}
    for mod in modules:
        for name, f in vars(mod).items():
            if isinstance(f, CPUDispatcher) and f.__module__ == mod.__name__:
                out[f"{mod.__name__}.{name}"] = sorted(str(s) for s in f.signatures)
    return out

kernels.warm(rough=rough)
before = signatures()
for name, overrides in json.loads(sys.argv[2]):
    res = pipeline.resolve(name, overrides=overrides)
    job = pipeline.make_job(res, res.scenario.frequencies[0])
    integ = Integrator(job, make_intersector(job.vertices, job.faces))
    for t in job.tiles():
        integ.render_tile(t)
after = signatures()
new = {k: sorted(set(v) - set(before.get(k, []))) for k, v in after.items()}
print(json.dumps({k: v for k, v in new.items() if v}))
"""

_SMALL = ["imager.resolution=[12, 8]", "render.spp=2", "render.target_error=null"]
_LAYERS = (
    "materials.desert_sand={roughness: {model: ashikhmin_shirley, ex: 15, ey: 15}, coating: [{material: denim, "
    "thickness: 2 mm, temperature: 300 K, roughness: {model: ggx, alpha: 0.2}}]}"
)
# smooth, coated, hybrid branch choice; GGX rough with a bump map (compiled masking); a rough
# coating layer on a model whose masking is array code (the facet steps one after the other)
_SCENES = [
    ("landing_95ghz", _SMALL),
    ("cwd_outdoor_95ghz", [*_SMALL, "render.strategy=hybrid"]),
    ("cinderblocks_rough_35ghz", _SMALL),
    ("cinderblocks_35ghz", [*_SMALL, _LAYERS]),
]


def _new_signatures(rough, scenes):
    if os.environ.get("NUMBA_DISABLE_JIT") == "1":
        pytest.skip("nothing is compiled under NUMBA_DISABLE_JIT")
    arg = json.dumps([(str(ROOT / "configs" / f"{n}.yaml"), o) for n, o in scenes])
    run = subprocess.run(
        [sys.executable, "-c", _SCRIPT, "rough" if rough else "smooth", arg],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(run.stdout.strip().splitlines()[-1])


def test_a_render_after_warm_compiles_nothing_new():
    assert _new_signatures(True, _SCENES) == {}


def test_control_warm_without_the_rough_kernels_misses_the_rough_render():
    new = _new_signatures(False, [_SCENES[2]])
    # the MASKED specialization and the bump maps' shading (a kernel loaded from numba's cache
    # brings its callees' code with it: the kernels the tracer calls are the ones that show)
    assert {"pmmw.surface.kernels.scatter", "pmmw.scene.bump._shade_rows"} <= set(new)
