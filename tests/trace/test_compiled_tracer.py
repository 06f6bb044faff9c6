"""The compiled bounce loop (`pmmw.trace.kernels`) against the vectorized one it replaces for
smooth scenes (`Integrator._bounce` with ``compiled=False``), and the compiled steps of rough
surfaces against the roughness models' array code.

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

from pmmw import pipeline
from pmmw.physics import roughness
from pmmw.surface.records import WaveArrays
from pmmw.trace.integrator import Integrator
from pmmw.trace.intersect import make_intersector

ROOT = Path(__file__).resolve().parents[2]
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
    job = _job(
        name,
        "imager.resolution=[24, 18]",
        "render.spp=2",
        "render.strategy=split",
        "render.termination=temperature",
        "render.target_error=null",
    )
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
    job = _job(
        "cinderblocks_35ghz",
        "imager.resolution=[24, 24]",
        "render.spp=64",
        f"render.strategy={strategy}",
        "render.split_depth=1",
        "render.termination=roulette",
        "render.threshold=0.05",
        "render.target_error=null",
    )
    a, b = _tiles(job, False), _tiles(job, True)
    z, bound, ratio = _z_test(a, b)
    assert z < bound, (z, bound)
    assert 0.8 < ratio < 1.25, ratio
    for r in b:
        r.mean *= 1.05
    assert _z_test(a, b)[0] > bound


def test_roulette_at_arrival_keeps_the_estimator():
    """A ray that a segment's absorption left below the threshold plays Russian roulette where it
    arrives (`kernels.arrive`), before its interaction, instead of only its children after it.
    Both are unbiased: with and without the early roulette the means agree pixel by pixel (1 %
    Bonferroni bound, as above) and the pooled variances within 25 %, at a threshold (0.05) that
    makes roulette frequent. The same test rejects a 5 % bias."""
    job = _job(
        "cinderblocks_35ghz",
        "imager.resolution=[24, 24]",
        "render.spp=64",
        "render.termination=roulette",
        "render.threshold=0.05",
        "render.target_error=null",
    )
    isect = make_intersector(job.vertices, job.faces)
    runs = []
    for early in (False, True):
        integ = Integrator(job, isect)
        assert integ.roulette  # on with ``termination: roulette``
        integ.roulette = early
        runs.append([integ.render_tile(t) for t in job.tiles()])
    z, bound, ratio = _z_test(*runs)
    assert z < bound, (z, bound)
    assert 0.8 < ratio < 1.25, ratio
    for r in runs[1]:
        r.mean *= 1.05
    assert _z_test(*runs)[0] > bound


def test_roulette_of_a_rough_faces_children_keeps_the_estimator():
    """On rough faces the children that leave play Russian roulette inside the interaction
    (`kernels.scatter` ``MASKED``, `kernels.settle`). The rough cinderblocks at a threshold that
    makes it frequent (0.05) against practically none (1e-9: three times the rays) agree: the
    pooled difference of all pixels' Ex2 and Ey2 within 4 of its standard error (the per-pixel
    test above has tails here: a few pixels owe their mean to rare bright paths that their
    standard error does not see), and the pooled variances within 25 %. A 1 % bias is rejected."""
    runs = []
    for threshold in ("0.05", "1e-9"):
        job = _job(
            "cinderblocks_rough_35ghz",
            "imager.resolution=[24, 24]",
            "render.spp=64",
            "render.termination=roulette",
            f"render.threshold={threshold}",
            "render.target_error=null",
        )
        integ = Integrator(job, make_intersector(job.vertices, job.faces))
        assert not integ.surfaces._rough_other  # the one-pass rough interaction
        runs.append([integ.render_tile(t) for t in job.tiles()])
    assert sum(r.rays for r in runs[1]) > 2 * sum(r.rays for r in runs[0])

    def pooled_z(a, b, bias=1.0):
        ma, mb = _image(a, "mean")[:, :2], _image(b, "mean")[:, :2] * bias
        var = _image(a, "stderr")[:, :2] ** 2 + _image(b, "stderr")[:, :2] ** 2
        return float((mb - ma).sum() / np.sqrt(var.sum()))

    assert abs(pooled_z(*runs)) < 4.0
    assert 0.8 < _z_test(*runs)[2] < 1.25
    assert abs(pooled_z(*runs, bias=1.01)) > 4.0


def test_rough_scenes_take_the_vectorized_path():
    job = _job("cinderblocks_rough_35ghz", "imager.resolution=[8, 8]")
    integ = Integrator(job, make_intersector(job.vertices, job.faces))
    assert integ.compiled is False
    smooth = _job("cinderblocks_35ghz", "imager.resolution=[8, 8]")
    assert Integrator(smooth, make_intersector(smooth.vertices, smooth.faces)).compiled is True


def test_rough_kernels_equal_the_models_array_code(monkeypatch):
    """On rough faces with compiled masking a whole interaction is one pass of `kernels.scatter`
    (``MASKED``: the GGX facet draw `roughness.ggx_draw1`, the coefficients, the Smith masking
    test `roughness.smith_g1`, the re-hits' bookkeeping). With the models' array code in their
    place (the base class's `sample_normals` and `masking`, the masking computed outside the
    kernel as for a model without compiled code, so the steps run one after the other:
    `Surfaces._scatter_settle`) the same random numbers give the same image to 1e-9 K (rounding
    only), on the shipped rough scene with its bump map (mirrored wrong-side children): GGX
    isotropic and anisotropic, and Beckmann (its facets drawn by its array code in both)."""
    for spec in (
        "{model: ggx, alpha: 0.15}",
        "{model: ggx, alpha_x: 0.1, alpha_y: 0.5, orientation_deg: 30}",
        "{model: beckmann, alpha: 0.2}",
    ):
        job = _job(
            "cinderblocks_rough_35ghz",
            "imager.resolution=[16, 12]",
            "render.spp=2",
            "render.target_error=null",
            f"materials.desert_sand.roughness={spec}",
        )
        isect = make_intersector(job.vertices, job.faces)
        fast = Integrator(job, isect)
        codes = fast.surfaces._rough.code
        assert ((codes == roughness.GGX_CODE) | (codes == roughness.BECKMANN_CODE)).any()
        assert not fast.surfaces._rough_other
        a = [fast.render_tile(t) for t in job.tiles()]
        with monkeypatch.context() as mp:
            mp.setattr(roughness.GGX, "sample_normals", roughness._Microfacet.sample_normals)
            mp.setattr(roughness.GGX, "masking", roughness._Microfacet.masking)
            slow = Integrator(job, isect)
            sf = slow.surfaces
            code = sf._rough.code
            sf._rough = sf._rough._replace(code=np.where(code != roughness.NOT_ROUGH, roughness.OTHER_CODE, code))
            sf._rough_other = True
            b = [slow.render_tile(t) for t in job.tiles()]
        for field in ("mean", "truncated"):
            np.testing.assert_allclose(_image(b, field), _image(a, field), rtol=0, atol=1e-9, err_msg=field)
        assert sum(r.rays for r in a) == sum(r.rays for r in b)


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
        subprocess.run(
            [sys.executable, "-c", script, str(Path(__file__).resolve().parent), str(path)],
            check=True,
            env=env,
            cwd=ROOT,
        )
        out[jit] = np.load(path)
    np.testing.assert_allclose(out["1"], out["0"], rtol=0, atol=1e-9)


def _reference_coefficients(job, cur, fm, other, leaving, cos1):
    """The interface rules over arrays, one group of rays at a time: under coherent films the
    stack from the incident medium through them (innermost first for a ray leaving the body) to
    the far medium (a blackbody index-matched to the innermost film, a metal as the stack's
    perfect conductor), emitting at the films' temperature; a bare perfect conductor at the
    body's; a bare interface (a thin sheet and a blackbody index-matched to the incident medium)
    at the incident medium's. q2 where the bare interface gives it, NaN elsewhere."""
    from pmmw.physics import fresnel, multilayer
    from pmmw.trace.job import BLACKBODY, METAL, THIN

    media = job.media
    n = cos1.size
    out = {k: np.empty(n, complex) for k in ("rs", "rp", "ts", "tp")}
    out.update({k: np.empty(n) for k in ("Rs", "Rp", "Ts", "Tp", "As", "Ap")})
    t_abs, q2 = np.empty(n), np.full(n, np.nan + 0j)
    key = (fm * 2 + leaving) * 64 + cur
    for kv in np.unique(key):
        g = np.flatnonzero(key == kv)
        k, c, o, lv = int(fm[g[0]]), int(cur[g[0]]), int(other[g[0]]), bool(leaving[g[0]])
        kind, films, eps1 = media.kind[k], media.coating[k], media.eps[c]
        far = eps1 if kind in (THIN, BLACKBODY) else media.eps[o]
        if films is not None:
            f_eps, f_d = (films.eps[::-1], films.thickness[::-1]) if lv else (films.eps, films.thickness)
            e2 = films.eps[-1] if kind == BLACKBODY else far
            eps = np.concatenate([[eps1], f_eps, [e2]])
            coeff = multilayer.stack(
                eps[None, :], f_d[None, :], cos1[g], job.k0, substrate="metal" if kind == METAL else "dielectric"
            )
            t_abs[g] = films.temperature
        elif kind == METAL:
            coeff = fresnel.perfect_conductor(g.size)
            t_abs[g] = media.temperature[k]
        else:
            coeff, q = fresnel.interface(np.full(g.size, eps1), np.full(g.size, far), cos1[g], with_q2=True)
            t_abs[g], q2[g] = media.temperature[c], q
        for name in out:
            out[name][g] = getattr(coeff, name)
    from pmmw.physics.fresnel import Fresnel

    return Fresnel(**out), t_abs, q2


def test_kernel_coefficients_equal_the_vectorized_assembly():
    """`kernels.coefficients` (what `kernels.scatter` uses per ray: films reversed for a ray
    leaving the body, a blackbody index-matched to the innermost film, the far medium's normal
    component, the emission temperature) against the same rules assembled here over arrays from
    `multilayer.stack`, `fresnel.interface` and `fresnel.perfect_conductor`. Media: bare
    and coated dielectrics (lossy films, one and three), coated metal, blackbody, opaque body
    and thin sheet, a lossy incident medium; rays entering and leaving, cosines 0..1. Equal to
    1e-12 relative (the same arithmetic in another order)."""
    import trimesh

    from pmmw.trace import kernels
    from tests.scenes import UniformSky, looking_down_at, make_job, material

    box = trimesh.creation.box(extents=[1, 1, 1])
    films1 = [(2.5 + 0.3j, 1.2e-3, 305.0)]
    films3 = [(2.0 + 0.01j, 0.4e-3, 300.0), (9.0 + 4.0j, 0.05e-3, 320.0), (3.0 + 0.2j, 2e-3, 290.0)]
    specs = [
        material(eps=3 + 0.1j),
        material(eps=6 + 2j, coating=films1),
        material(eps=40 + 30j, coating=films3),
        material(kind="metal", coating=films3),
        material(kind="blackbody", coating=films1),
        material(kind="opaque", eps=4 + 1j, coating=films1),
        material(kind="thin", eps=3 + 0.5j, thickness=1e-3),
        material(eps=1.5 + 0.4j),
    ]
    job = make_job([(box, s) for s in specs], looking_down_at(30.0), UniformSky(10.0, 290.0), 95e9)
    integ = Integrator(job, make_intersector(job.vertices, job.faces))
    rng = np.random.default_rng(5)
    n = 4000
    fm = rng.integers(1, len(specs) + 1, n)
    leaving = (rng.random(n) < 0.5) & np.isin(job.media.kind[fm], [0])  # dielectrics only are left
    lossy_in = len(specs)  # rays entering from the lossy medium (index of the last spec)
    cur = np.where(leaving, fm, np.where(rng.random(n) < 0.2, lossy_in, 0))
    other = np.where(leaving, 0, fm)
    cos1 = rng.random(n)
    cos1[:20] = 0.0
    cos1[20:40] = 1.0
    ref, t_ref, q2_ref = _reference_coefficients(job, cur, fm, other, leaving, cos1)
    amp, power, q2, t_abs = np.empty((n, 4), complex), np.empty((n, 6)), np.empty(n, complex), np.empty(n)
    kernels.coefficients(
        cur, fm, other, leaving, cos1, integ.surfaces._media, integ.surfaces._films, amp, power, q2, t_abs
    )
    for a, name in enumerate(("rs", "rp", "ts", "tp")):
        np.testing.assert_allclose(amp[:, a], getattr(ref, name), rtol=1e-12, atol=1e-15, err_msg=name)
    for a, name in enumerate(("Rs", "Rp", "Ts", "Tp", "As", "Ap")):
        np.testing.assert_allclose(power[:, a], getattr(ref, name), rtol=1e-12, atol=1e-15, err_msg=name)
    films = integ._media[4][fm]
    metal = job.media.kind[fm] == 1
    np.testing.assert_array_equal(t_abs[films | metal], t_ref[films | metal])  # films' or the body's
    np.testing.assert_array_equal(t_abs[~films & ~metal], job.media.temperature[cur[~films & ~metal]])
    bare = ~np.isnan(q2_ref)
    np.testing.assert_allclose(q2[bare], q2_ref[bare], rtol=1e-12, atol=0)
    assert films.sum() > 1000 and leaving[films].any() and (cur == lossy_in).any()


def test_tangents_are_world_x_projected_onto_the_face():
    """`kernels.tangents`: unit, perpendicular to the normal, and in the plane spanned by the
    normal and world X (world Y when the normal is within 26 degrees of X), to rounding."""
    from pmmw.trace import kernels

    rng = np.random.default_rng(2)
    n = rng.normal(size=(5000, 3))
    n[:3] = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.95, 0.0, 0.312]]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    t = np.empty_like(n)
    kernels.tangents(n, t)
    axis = np.where((np.abs(n[:, 0]) > 0.9)[:, None], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(np.linalg.norm(t, axis=1), 1.0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.einsum("ij,ij->i", t, n), 0.0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.einsum("ij,ij->i", t, np.cross(n, axis)), 0.0, rtol=0, atol=1e-14)
    assert np.all(np.einsum("ij,ij->i", t, axis) > 0.0)


def test_tally_equals_the_array_sums():
    """`kernels.tally` (a tile's per-pixel sums) against the same sums in numpy: a first chunk of
    3 samples sets the shift (its mean), a second of 2 samples on a subset of the pixels adds to
    the shifted sums, squares and the replicates (sample number mod 2). Rounding only (1e-12)."""
    from pmmw.trace import kernels

    rng = np.random.default_rng(5)
    npx, reps = 7, 2
    ref, s1, s2 = np.zeros((npx, 4)), np.zeros((npx, 4)), np.zeros((npx, 4))
    r1, count, trunc = np.zeros((npx, reps, 4)), np.zeros(npx, np.int64), np.zeros((npx, 2))
    depth, material = np.full(npx, np.inf), np.full(npx, -1.0)
    want = {
        k: v.copy()
        for k, v in dict(ref=ref, s1=s1, s2=s2, r1=r1, count=count, trunc=trunc, depth=depth, material=material).items()
    }
    done = 0
    for active, nb in ((np.arange(npx), 3), (np.array([1, 4, 6]), 2)):
        n = active.size * nb
        vals, cut = rng.normal(300.0, 20.0, (n, 4)), rng.random((n, 2))
        first_t = np.where(rng.random(n) < 0.3, np.inf, rng.random(n) * 100.0)
        first_m = rng.integers(-1, 4, n).astype(float)
        if done == 0:
            first_t[:nb] = np.inf  # pixel 0 sees the sky with every first sample
        kernels.tally(active, vals, cut, first_t, first_m, done, reps, ref, s1, s2, r1, count, trunc, depth, material)
        v = vals.reshape(active.size, nb, 4)
        want["trunc"][active] += cut.reshape(active.size, nb, 2).sum(axis=1)
        if done == 0:
            want["ref"][active] = v.mean(axis=1)
            want["depth"][active] = first_t.reshape(active.size, nb).mean(axis=1)
            want["material"][active] = first_m.reshape(active.size, nb)[:, 0]
        dv = v - want["ref"][active][:, None, :]
        want["s1"][active] += dv.sum(axis=1)
        want["s2"][active] += (dv * dv).sum(axis=1)
        want["count"][active] += nb
        for r in range(reps):
            want["r1"][active, r] += dv[:, (r - done) % reps :: reps].sum(axis=1)
        done += nb
    got = dict(ref=ref, s1=s1, s2=s2, r1=r1, count=count, trunc=trunc, depth=depth, material=material)
    for k in want:
        np.testing.assert_allclose(got[k], want[k], rtol=1e-12, atol=1e-9, err_msg=k)
    assert np.isinf(depth[0])  # a pixel whose first samples all saw the sky keeps inf


def test_tile_means_are_the_sample_statistics():
    """`kernels.tile_means` (a tile's results from its `tally` sums) against the statistics of the
    raw samples in numpy: the mean, the standard error of the mean (sample standard deviation /
    sqrt(n); 0 for one sample), and the mean of the even-numbered samples minus that of the
    odd-numbered ones (0 with one sample). Per-pixel counts 1, 2, 3 and 8, values around 300 K
    with a spread of 20 K, so that the shifted sums' rounding stays below 1e-10 K."""
    from pmmw.trace import kernels

    rng = np.random.default_rng(11)
    counts = np.array([1, 2, 3, 8, 5])
    samples = [rng.normal(300.0, 20.0, (n, 4)) for n in counts]
    npx = counts.size
    ref, s1, s2 = np.zeros((npx, 4)), np.zeros((npx, 4)), np.zeros((npx, 4))
    r1, count, trunc = np.zeros((npx, 2, 4)), np.zeros(npx, np.int64), np.zeros((npx, 2))
    depth, material = np.full(npx, np.inf), np.full(npx, -1.0)
    for px, v in enumerate(samples):  # one pixel at a time, all its samples in one chunk
        n = v.shape[0]
        kernels.tally(
            np.array([px]),
            v,
            np.zeros((n, 2)),
            np.ones(n),
            np.zeros(n),
            0,
            2,
            ref,
            s1,
            s2,
            r1,
            count,
            trunc,
            depth,
            material,
        )
    mean, err, diff = np.empty((npx, 4)), np.empty((npx, 4)), np.empty((npx, 4))
    kernels.tile_means(ref, s1, s2, r1, count, mean, err, diff)
    alone = np.empty((npx, 4))
    kernels.stderr(s1, s2, count, alone)
    np.testing.assert_array_equal(alone, err)
    for px, v in enumerate(samples):
        n = v.shape[0]
        np.testing.assert_allclose(mean[px], v.mean(axis=0), rtol=0, atol=1e-10)
        want_err = v.std(axis=0, ddof=1) / np.sqrt(n) if n > 1 else np.zeros(4)
        np.testing.assert_allclose(err[px], want_err, rtol=0, atol=1e-10)
        want_diff = v[0::2].mean(axis=0) - v[1::2].mean(axis=0) if n > 1 else np.zeros(4)
        np.testing.assert_allclose(diff[px], want_diff, rtol=0, atol=1e-10)


def test_sky_emission_kernel_equals_the_jones_algebra():
    """`kernels.sky_emit` against the array algebra of `pmmw.physics.jones`: the Jones matrix
    re-expressed in the sky's (h, v) basis (`rebase`, h = unit(z x k), v = k x h) and its Stokes
    terms for columns (Th, Tv) (`stokes_terms`), summed per sample; unpolarized, Tv in both
    columns. Random rays (one straight up, where h falls back to the ray's s), random complex
    Jones matrices, two rays per sample. Tolerance: rounding (1e-12 K)."""
    from pmmw.physics.jones import rebase, stokes_terms
    from pmmw.surface import Wave
    from pmmw.trace import kernels

    rng = np.random.default_rng(3)
    n = 200
    d = rng.normal(size=(n, 3))
    d[0] = [0.0, 0.0, 1.0]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    x = np.cross(d, rng.normal(size=(n, 3)))
    s = x / np.linalg.norm(x, axis=1, keepdims=True)
    p = np.cross(-d, s)
    m = rng.normal(size=(n, 2, 2)) + 1j * rng.normal(size=(n, 2, 2))
    sid = np.arange(n) // 2
    wave = Wave(
        o=np.zeros((n, 3)),
        d=d,
        s=s,
        p=p,
        m=m,
        sid=sid,
        depth=np.zeros(n, np.int32),
        stack=np.zeros((n, 8), np.int16),
        top=np.zeros(n, np.int32),
        last_t=np.zeros(n),
        key=np.zeros(n, np.uint64),
    )
    rows = np.arange(0, n, 1)[rng.random(n) < 0.7]
    rows = np.union1d(rows, [0])
    tv, th = rng.uniform(2.0, 300.0, rows.size), rng.uniform(2.0, 300.0, rows.size)
    k = -d[rows]
    h = np.cross(np.array([0.0, 0.0, 1.0]), k)
    norm = np.linalg.norm(h, axis=1, keepdims=True)
    h = np.where(norm > 1e-12, h / np.where(norm > 1e-12, norm, 1.0), s[rows])
    v = np.cross(k, h)
    for polarized in (True, False):
        acc = np.zeros((n // 2, 4))
        kernels.sky_emit(rows, wave.arrays(), tv, th if polarized else tv, polarized, acc)
        want = np.zeros((n // 2, 4))
        if polarized:
            terms = stokes_terms(rebase(m[rows], s[rows], p[rows], h, v), th, tv)
        else:
            terms = stokes_terms(m[rows], tv, tv)
        np.add.at(want, sid[rows], terms)
        np.testing.assert_allclose(acc, want, rtol=0, atol=1e-12 * np.abs(want).max())


def test_crossing_a_rough_coating_layer_is_beer_lambert():
    """`kernels.cross_layer` against Beer-Lambert over the slant path (Murakowski 2014 eq. 2.37,
    2.38): each ray's Jones matrix scaled by sqrt(tau), tau = exp(-alpha t / |cos|) with the
    cosine against the layer's normal (kept above 1e-6: a ray along the layer loses everything),
    and what it loses emitted at the layer's temperature, T (1 - tau) times its rows' powers in
    Ex2 and Ey2. Random directions, normals and Jones matrices; tolerance: rounding (1e-12 K of
    emissions up to ~1e3 K, 1e-15 of amplitudes)."""
    from pmmw.trace import kernels

    rng = np.random.default_rng(1)
    n = 200
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    rows = rng.permutation(n)  # ray c's normal is normals[rows[c]]
    along = int(np.flatnonzero(rows == 0)[0])  # this ray runs along its layer
    normals[0] = np.cross(d[along], [0.0, 0.0, 1.0])
    normals[0] /= np.linalg.norm(normals[0])
    m = rng.normal(size=(n, 2, 2)) + 1j * rng.normal(size=(n, 2, 2))
    wave = WaveArrays(
        np.zeros((n, 3)),
        d,
        np.zeros((n, 3)),
        np.zeros((n, 3)),
        m.copy(),
        np.arange(n),
        np.zeros(n, np.int32),
        np.zeros((n, 8), np.int16),
        np.zeros(n, np.int32),
        np.zeros(n),
        np.zeros(n, np.uint64),
    )
    acc = np.zeros((n, 4))
    alpha, thickness, temp = 50.0, 2e-3, 300.0
    kernels.cross_layer(wave, normals, rows, alpha, thickness, temp, acc)
    cos = np.maximum(np.abs(np.sum(d * normals[rows], axis=1)), 1e-6)
    tau = np.exp(-alpha * thickness / cos)
    assert tau[along] == 0.0 and tau.max() > 0.8
    np.testing.assert_allclose(wave[4], m * np.sqrt(tau)[:, None, None], rtol=0, atol=1e-15 * np.abs(m).max())
    rows_power = np.abs(m) ** 2
    np.testing.assert_allclose(acc[:, 0], temp * (1 - tau) * rows_power[:, 0].sum(axis=1), rtol=0, atol=1e-12)
    np.testing.assert_allclose(acc[:, 1], temp * (1 - tau) * rows_power[:, 1].sum(axis=1), rtol=0, atol=1e-12)
