"""The compiled bounce loop (`pmmw_cli.trace.kernels`) against the vectorized one it replaces for
smooth scenes (`Integrator._bounce`, still the path of rough ones).

Without randomness in the tracer (``strategy: split``, ``termination: temperature``) the two
compute the same sums in a different order: they agree to rounding. With Russian roulette and
stochastic branch choice they draw different random numbers, so they are compared as estimators:
a per-pixel z-test on the means and a test on the pooled variances, as Mitsuba 3's render tests do.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import norm

from pmmw_cli import pipeline
from pmmw_cli.trace.integrator import Integrator
from pmmw_cli.trace.intersect import make_intersector

ROOT = Path(__file__).resolve().parents[1]
SMOOTH = ["landing_95ghz", "cinderblocks_35ghz", "cwd_outdoor_95ghz", "cwd_indoor_95ghz", "sar_cessna_95ghz"]


def _job(name, *overrides):
    res = pipeline.resolve(ROOT / "configs" / f"{name}.yaml", overrides=list(overrides))
    return pipeline.make_job(res, res.scenario.frequencies[0])


def _tiles(job, compiled):
    integ = Integrator(job, make_intersector(job.vertices, job.faces), compiled=compiled)
    assert integ.compiled is compiled
    return [integ.render_tile(t) for t in job.tiles()]


def _image(results, field):
    return np.concatenate([getattr(r, field).reshape(-1, *getattr(r, field).shape[2:]) for r in results])


@pytest.mark.parametrize("name", SMOOTH)
def test_compiled_equals_vectorized_without_randomness(name):
    """Every per-pixel output agrees to 1e-9 K: both paths add the same emission terms (a few
    hundred per pixel, each below ~300 K, so reordering the sums moves them by ~1e-13 K)."""
    job = _job(name, "imager.resolution=[24, 18]", "render.spp=2", "render.strategy=split",
               "render.termination=temperature", "render.target_error=null")
    a, b = _tiles(job, False), _tiles(job, True)
    for field in ("mean", "truncated"):
        np.testing.assert_allclose(_image(b, field), _image(a, field), rtol=0, atol=1e-9, err_msg=field)
    np.testing.assert_array_equal(_image(b, "depth"), _image(a, "depth"))
    np.testing.assert_array_equal(_image(b, "material"), _image(a, "material"))
    assert sum(r.rays for r in a) == sum(r.rays for r in b)


def _z_test(a, b):
    """Largest per-pixel |z| of Ex2 and Ey2 between two sets of tiles, the Bonferroni bound at
    1 % for that many pixels, and the ratio of pooled variances (b over a)."""
    ma, mb = _image(a, "mean")[:, :2], _image(b, "mean")[:, :2]
    sa, sb = _image(a, "stderr")[:, :2], _image(b, "stderr")[:, :2]
    var = sa**2 + sb**2
    seen = var > 0
    z = np.abs(ma - mb)[seen] / np.sqrt(var[seen])
    bound = norm.isf(0.01 / (2 * z.size))
    return z.max(), bound, float(np.sum(sb**2) / np.sum(sa**2))


@pytest.mark.parametrize("strategy", ["stochastic", "hybrid"])
def test_compiled_and_vectorized_estimators_agree(strategy):
    """Roulette and branch choice: the means agree pixel by pixel (no |z| beyond the 1 %
    Bonferroni bound, about 4.3 for 1152 values; the standard errors treat the low-discrepancy
    samples as independent, which overstates them, so the test is conservative) and the pooled
    variances within 25 % (their own sampling spread at 1152 x 64 samples is a few percent). The
    same test does reject a 5 % bias: it can fail."""
    job = _job("cinderblocks_35ghz", "imager.resolution=[24, 24]", "render.spp=64", f"render.strategy={strategy}",
               "render.split_depth=1", "render.termination=roulette", "render.threshold=0.05",
               "render.target_error=null")
    a, b = _tiles(job, False), _tiles(job, True)
    z, bound, ratio = _z_test(a, b)
    assert z < bound, (z, bound)
    assert 0.8 < ratio < 1.25, ratio
    for r in b:
        r.mean *= 1.05
    assert _z_test(a, b)[0] > bound


def test_rough_scenes_take_the_vectorized_path():
    job = _job("cinderblocks_rough_35ghz", "imager.resolution=[8, 8]")
    integ = Integrator(job, make_intersector(job.vertices, job.faces))
    assert integ.compiled is False
    smooth = _job("cinderblocks_35ghz", "imager.resolution=[8, 8]")
    assert Integrator(smooth, make_intersector(smooth.vertices, smooth.faces)).compiled is True


def test_kernels_run_as_python_without_jit(tmp_path):
    """``NUMBA_DISABLE_JIT=1`` runs the same kernels as Python (for debugging): a small render
    there equals the compiled one to rounding."""
    script = (
        "import sys, numpy as np\n"
        "sys.path.insert(0, sys.argv[1])\n"
        "from test_compiled_tracer import _job, _tiles, _image\n"
        "job = _job('cwd_outdoor_95ghz', 'imager.resolution=[12, 9]', 'render.spp=1', "
        "'render.termination=temperature', 'render.target_error=null')\n"
        "np.save(sys.argv[2], _image(_tiles(job, True), 'mean'))\n"
    )
    out = {}
    for jit in ("0", "1"):
        env = dict(os.environ, NUMBA_DISABLE_JIT=jit)
        path = tmp_path / f"jit{jit}.npy"
        subprocess.run([sys.executable, "-c", script, str(ROOT / "tests"), str(path)], check=True, env=env, cwd=ROOT)
        out[jit] = np.load(path)
    np.testing.assert_allclose(out["1"], out["0"], rtol=0, atol=1e-9)
