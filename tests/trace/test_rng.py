"""The rays' random numbers (`pmmw.rng`): the generator against an independent reference, its
uniformity, and a pixel's value independent of how the image is cut into tiles and workers."""

from __future__ import annotations

from pathlib import Path

import numba
import numpy as np
import pytest
from scipy import stats

from pmmw import rng
from pmmw.pipeline import make_job, resolve
from pmmw.trace import pool

REPO = Path(__file__).resolve().parents[2]
M64 = (1 << 64) - 1


def _mix64(x: int) -> int:
    """splitmix64's finalizer with plain Python integers, as Steele et al. 2014 print it
    (``mix64``, after the state's increment by the golden gamma), reduced mod 2**64 by hand."""
    x = (x + 0x9E3779B97F4A7C15) & M64
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & M64
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & M64
    return x ^ (x >> 31)


def test_the_finalizer_is_splitmix64_with_its_published_constants():
    """Exact (integers): the module's constants are the published ones, and its finalizer of a
    few inputs (0, 1, 2**64 - 1 and two arbitrary ones) equals the Python-integer reference; the
    first output of the reference for state 0 is the widely tabulated 0xE220A8397B1DCDAF
    (splitmix64's first number from seed 0), which checks the reference itself."""
    assert int(rng.GOLDEN) == 0x9E3779B97F4A7C15
    assert int(rng.MIX1) == 0xBF58476D1CE4E5B9
    assert int(rng.MIX2) == 0x94D049BB133111EB
    assert _mix64(0) == 0xE220A8397B1DCDAF
    mix = numba.njit(lambda x: rng.splitmix64(x))
    for x in (0, 1, M64, 0x0123456789ABCDEF, 42):
        assert int(mix(np.uint64(x))) == _mix64(x)


def test_keys_and_uniforms_match_a_python_integer_reference():
    """Exact: `ray_keys`, `child_keys` and `uniforms` (compiled) against their definitions in
    the module's docstring written here with Python integers mod 2**64: a ray's key is
    mix(id XOR mix(seed * FNV + 0)), a child's mix(key XOR mix(2**63 | branch)), a uniform the top 53
    bits of mix(key XOR mix(depth << 8 | purpose)) over 2**53 (exact in float64)."""
    seed, ids = 7, np.array([0, 1, 5, 123456789], np.int64)
    keys = rng.ray_keys(seed, ids)
    want = [_mix64(int(i) ^ _mix64((seed * 0x100000001B3) & M64)) for i in ids]
    assert [int(k) for k in keys] == want
    kids = rng.child_keys(keys, rng.Branch.TRANSMITTED)
    assert [int(k) for k in kids] == [_mix64(k ^ _mix64((1 << 63) | 1)) for k in want]
    depth = np.array([0, 3, 31, 2], np.int32)
    u = rng.uniforms(keys, depth, rng.Purpose.MASKING_REFLECTED, rng.Purpose.SURVIVAL)
    for c, purpose in enumerate((rng.Purpose.MASKING_REFLECTED, rng.Purpose.SURVIVAL)):
        ref = [(_mix64(k ^ _mix64((int(d) << 8) | int(purpose))) >> 11) / 2.0**53 for k, d in zip(want, depth)]
        assert u[:, c].tolist() == ref


# The purposes `uniform1` is given; PIXEL_U .. LENS_PHI are the camera's `hash_uniform1` streams.
_RAY_PURPOSES = [p for p in rng.Purpose if p >= rng.Purpose.ARRIVAL_ROULETTE]


def test_a_million_uniforms_are_uniform():
    """Kolmogorov-Smirnov test of 1e6 uniforms (one per camera-ray key of a render, one purpose)
    against U(0, 1), and of 1e6 more across purposes and depths of one key set's children. The
    draws are fixed (a hash), so the test is deterministic; p > 1e-3 is the level at which a
    uniform generator would fail once in a thousand seeds (the KS statistic's resolution at
    n = 1e6 is ~1e-3 in the CDF, far above float64 rounding), so a pass says no deviation
    larger than ~2e-3 in the CDF."""
    keys = rng.ray_keys(1, np.arange(1_000_000))
    u = rng.uniforms(keys, np.zeros(keys.size, np.int32), rng.Purpose.ARRIVAL_ROULETTE)
    assert stats.kstest(u, "uniform").pvalue > 1e-3
    kids = rng.child_keys(keys[:111_112], rng.Branch.REFLECTED)  # x 9 purposes: 1,000,008 uniforms
    depth = np.arange(kids.size, dtype=np.int32) % 32
    v = rng.uniforms(kids, depth, *_RAY_PURPOSES).ravel()
    assert stats.kstest(v, "uniform").pvalue > 1e-3
    # control: the same test does see a 1 % stretch of the same numbers
    assert stats.kstest(np.minimum(u * 1.01, 1.0), "uniform").pvalue < 1e-3


def test_two_purposes_of_one_ray_are_independent():
    """Pearson's chi-square test of independence of the facet draw's two uniforms (``FACET_U1``,
    ``FACET_U2``) of the same ray, over 2**20 camera-ray keys at depths 0 .. 31: their pairs
    counted on a 32 x 32 grid (1024 expected per cell, far above the 5 the chi-square
    approximation needs; 31**2 degrees of freedom). The draws are fixed (a hash), so the test is
    deterministic; p > 1e-3 is the level an independent pair would fail once in a thousand key
    sets. The control: U2 replaced by (U1 + 1e-3) mod 1, a pair that is uniform in each
    coordinate but dependent, fails the same test."""
    keys = rng.ray_keys(3, np.arange(1 << 20))
    depth = np.arange(keys.size, dtype=np.int32) % 32
    u = rng.uniforms(keys, depth, rng.Purpose.FACET_U1, rng.Purpose.FACET_U2)

    def pvalue(u1, u2):
        counts = np.histogram2d(u1, u2, bins=32, range=[[0.0, 1.0], [0.0, 1.0]])[0]
        return stats.chi2_contingency(counts, correction=False).pvalue

    assert pvalue(u[:, 0], u[:, 1]) > 1e-3
    assert pvalue(u[:, 0], (u[:, 0] + 1e-3) % 1.0) < 1e-3  # control: dependent


def _image(config, tile, workers, *overrides):
    res = resolve(
        REPO / "configs" / config,
        ["imager.resolution=[20, 12]", f"render.tile={tile}", "render.spp=4", "render.target_error=null", *overrides],
    )
    job = make_job(res, res.scenario.frequencies[0])
    img = np.full((12, 20, 4), np.nan)
    for r in pool.render_tiles(job, workers=workers):
        x0, y0, x1, y1 = r.box
        img[y0:y1, x0:x1] = r.mean
    return img


@pytest.mark.parametrize(
    "config, overrides",
    [
        ("cinderblocks_rough_35ghz.yaml", ()),  # GGX facets and masking, re-hits, roulette
        ("landing_95ghz.yaml", ("render.strategy=stochastic",)),  # smooth: branch choice, roulette
    ],
)
def test_a_pixel_is_the_same_whatever_the_tile_size_and_the_worker_count(config, overrides):
    """Exact (bit for bit): each ray's numbers come from its key (`pmmw.rng`), so the image of
    ``render.tile`` 8 and 16 with 1 and 2 workers is one array. Without adaptive sampling: its
    neighbour rule looks at the pixels of a tile, so the sample counts depend on the tiles
    by design. The control: the same render with ``render.seed`` 2 (the default is 1) is not the
    same array, so the equality is one the random numbers could break."""
    ref = _image(config, 8, 1, *overrides)
    assert np.isfinite(ref).all()
    assert not np.array_equal(_image(config, 8, 1, *overrides, "render.seed=2"), ref)  # control
    for tile, workers in ((16, 1), (8, 2), (16, 2)):
        np.testing.assert_array_equal(_image(config, tile, workers, *overrides), ref, err_msg=f"{tile} {workers}")
