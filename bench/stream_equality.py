"""Are two versions of the tracer's random streams the same estimator? Per-pixel tests over seeds.

Re-keying the random numbers (`pmmw.rng`) changes every image bit for bit, so the change is
proved as an estimator: the same small images of two shipped configs (smooth: landing_95ghz,
as shipped and with the ``stochastic`` branch choice; rough: cinderblocks_rough_35ghz) rendered with ``SEEDS`` seeds by each version, and per pixel and
channel (Ex2, Ey2, U, V):

* the means: Welch's t-test of the two sets of per-seed values (each value a pixel mean of
  ``SPP`` samples, the seeds independent);
* the variances: the Brown-Forsythe test (Levene's with medians; robust to the non-normal
  values of a few samples), and the pooled ratio of the variances over the image.

The thresholds, set before any result was seen: a family-wise level of 1 % per config and test,
Bonferroni over its (pixel, channel) tests (p < 0.01 / N rejects); a pixel whose values are
constant in both versions (the sky, deterministic) must be equal in both. Control: the new
version's values times 1.02 (every emission scaled by 2 %, which scales the image) must be
rejected by the test of the means.

Usage (each render in the tree whose code it measures, with that tree as the current directory)::

    cd OLD_TREE && python NEW_TREE/bench/stream_equality.py render /tmp/old.npz
    cd NEW_TREE && python bench/stream_equality.py render /tmp/new.npz
    python bench/stream_equality.py compare /tmp/old.npz /tmp/new.npz
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

SMALL = ["imager.resolution=[16, 12]"]
#: label: (config, overrides); the landing's default (``split``) draws only for Russian roulette,
#: its ``stochastic`` one for every branch choice too
CONFIGS = {
    "landing_95ghz": ("landing_95ghz", SMALL),
    "landing_95ghz_stochastic": ("landing_95ghz", [*SMALL, "render.strategy=stochastic"]),
    "cinderblocks_rough_35ghz": ("cinderblocks_rough_35ghz", SMALL),
}
SEEDS = 32
SPP = 16
ALPHA = 0.01
CONTROL = 1.02


def render(out):
    sys.path.insert(0, os.getcwd())  # the current tree's pmmw, not this file's
    from pmmw.pipeline import make_job, resolve
    from pmmw.trace import pool

    arrays = {}
    for name, (config, overrides) in CONFIGS.items():
        imgs = []
        for seed in range(1, SEEDS + 1):
            res = resolve(
                Path("configs") / f"{config}.yaml",
                [*overrides, f"render.spp={SPP}", "render.target_error=null", f"render.seed={seed}"],
            )
            job = make_job(res, res.scenario.frequencies[0])
            img = np.full((job.camera.height, job.camera.width, 4), np.nan)
            for r in pool.render_tiles(job, workers=1):
                x0, y0, x1, y1 = r.box
                img[y0:y1, x0:x1] = r.mean
            imgs.append(img.reshape(-1, 4))
        arrays[name] = np.stack(imgs)  # (seeds, pixels, 4)
    np.savez(out, **arrays)


def _tests(old, new):
    """(smallest p of the means, of the variances, tests N, pooled variance ratio, unequal constants)."""
    from scipy import stats

    var_o, var_n = old.var(axis=0, ddof=1), new.var(axis=0, ddof=1)
    const = (var_o == 0.0) & (var_n == 0.0)
    unequal = int(np.count_nonzero(const & (old[0] != new[0])))
    o, n = old[:, ~const], new[:, ~const]  # (seeds, tests)
    p_mean = stats.ttest_ind(o, n, axis=0, equal_var=False).pvalue
    p_var = np.array([stats.levene(o[:, k], n[:, k], center="median").pvalue for k in range(o.shape[1])])
    return float(np.nanmin(p_mean)), float(np.nanmin(p_var)), o.shape[1], float(var_n.sum() / var_o.sum()), unequal


def compare(old_file, new_file):
    old, new = np.load(old_file), np.load(new_file)
    ok = True
    for name in CONFIGS:
        o, n = old[name], new[name]
        pm, pv, count, ratio, unequal = _tests(o, n)
        level = ALPHA / count
        passed = pm >= level and pv >= level and unequal == 0
        cm, _, _, _, _ = _tests(o, n * CONTROL)
        control_fails = cm < level  # by the means (not by the constant pixels alone)
        ok &= passed and control_fails
        print(
            f"{name}: {count} tests, level {level:.2e}; means: min p {pm:.3g}; variances: min p {pv:.3g},"
            f" pooled ratio new/old {ratio:.3f}; constant pixels unequal: {unequal} -> {'equal' if passed else 'DIFFER'};"
            f" control x{CONTROL}: min p {cm:.3g} -> {'rejected' if control_fails else 'NOT REJECTED'}"
        )
    return 0 if ok else 1


if __name__ == "__main__":
    if sys.argv[1] == "render":
        render(sys.argv[2])
    else:
        sys.exit(compare(sys.argv[2], sys.argv[3]))
