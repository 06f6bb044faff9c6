"""Microfacet models (pmmw.physics.roughness): normalization, Smith masking against
independent quadratures, exact visible-normal sampling, Stryjewski et al. 2009's ensemble average against a
high-precision direct integration (mpmath), the registry and its user errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as hst

from pmmw.errors import UserError, UserErrors
from pmmw.physics import roughness as R

Z = np.array([0.0, 0.0, 1.0])
X = np.array([1.0, 0.0, 0.0])

# Quadrature tolerance for smooth integrands on the grids below (Gauss-Legendre in theta,
# periodic trapezoid in phi): far below the Monte Carlo tolerances and the effects tested.
QUAD_TOL = 1e-6

MODELS = {
    "as_iso": lambda: R.AshikhminShirley(15, 15),
    "as_aniso": lambda: R.AshikhminShirley(30, 5, orientation_deg=20),
    "phong_0": lambda: R.BlinnPhong(0),
    "phong_1e3": lambda: R.BlinnPhong(1e3),
    "ggx": lambda: R.GGX(0.3),
    "ggx_aniso": lambda: R.GGX(alpha_x=0.2, alpha_y=0.6, orientation_deg=-35),
    "beckmann": lambda: R.Beckmann(0.3),
    "beckmann_aniso": lambda: R.Beckmann(alpha_x=0.5, alpha_y=0.15),
}


def _direction(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def _sphere_quadrature(n_theta=400, n_phi=256, theta_max=math.pi / 2, power=1.0):
    """Nodes and weights (solid angle) on the cap theta < theta_max; ``power`` > 1 crowds the
    theta nodes toward the pole (for narrow lobes)."""
    x, w = np.polynomial.legendre.leggauss(n_theta)
    s = 0.5 * (x + 1.0)
    th = theta_max * s**power
    dth = theta_max * power * s ** (power - 1.0) * 0.5 * w
    ph = (np.arange(n_phi) + 0.5) * 2.0 * np.pi / n_phi
    T, P = np.meshgrid(th, ph, indexing="ij")
    dirs = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1).reshape(-1, 3)
    weights = (np.sin(T) * dth[:, None] * (2.0 * np.pi / n_phi)).reshape(-1)
    return dirs, weights


def _power_for(model):
    narrow = isinstance(model, R.AshikhminShirley) and max(model.ex, model.ey) > 100
    return 3.0 if narrow else 1.0


# ---------------------------------------------------------------------------------------------
# Distributions and masking
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(MODELS))
def test_distribution_is_normalized_over_projected_area(name):
    model = MODELS[name]()
    m, w = _sphere_quadrature(power=_power_for(model))
    total = np.sum(model.D(Z, X, m) * m[:, 2] * w)
    assert total == pytest.approx(1.0, abs=1e-5)


@pytest.mark.parametrize("name", sorted(MODELS))
@pytest.mark.parametrize(
    "theta, phi", [(0.0, 0.0), (30.0, 40.0), (60.0, 115.0), (80.0, 0.0), (89.0, 40.0), (100.0, 115.0), (135.0, 40.0)]
)
def test_projected_area_matches_quadrature(name, theta, phi):
    """A(w) = int (w.m)+ D(m) dw_m: closed forms (and the anisotropic Ashikhmin-Shirley table)
    against brute-force quadrature, on both sides of the horizon."""
    model = MODELS[name]()
    m, w = _sphere_quadrature(n_theta=400, n_phi=384, power=_power_for(model))
    wo = _direction(theta, phi)
    ref = np.sum(np.maximum(m @ wo, 0.0) * model.D(Z, X, m) * w)
    got = model.projected_area(Z, X, wo[None, :])[0]
    # the anisotropic AS area is interpolated from a table (1e-4 of A for ex/ey = 6); below the
    # horizon A(w) = A(-w) + w.n inherits the absolute error of A(-w)
    scale = max(ref, ref - wo[2])
    tol = 2e-4 * scale if name == "as_aniso" else 2e-5
    assert got == pytest.approx(ref, abs=tol)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_area_identities_and_masking_range(name):
    model = MODELS[name]()
    rng = np.random.default_rng(5)
    w = rng.normal(size=(500, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    a_pos = model.projected_area(Z, X, w)
    a_neg = model.projected_area(Z, X, -w)
    assert np.allclose(a_pos - a_neg, w[:, 2], atol=1e-12)  # A(w) - A(-w) = w.n
    assert model.projected_area(Z, X, Z[None, :])[0] == pytest.approx(1.0, abs=1e-12)
    g1 = model.masking(Z, X, w)
    assert np.all((g1 >= 0.0) & (g1 <= 1.0))
    assert np.all(g1[w[:, 2] <= 0.0] == 0.0)


def test_anisotropic_table_accuracy_against_its_exact_integral():
    """The tabulated correction against the exact one-dimensional integral at random points."""
    rng = np.random.default_rng(1)
    for (ex, ey), tol in (((30, 15), 1e-5), ((1000, 10), 5e-4), ((0, 50), 2e-3)):
        table = R._ASProjectedArea(ex, ey)
        c = rng.random(2000) ** 2
        ph = rng.random(2000) * 0.5 * np.pi
        s = np.sqrt(1.0 - c * c)
        w = np.stack([s * np.cos(ph), s * np.sin(ph), c], axis=1)
        assert np.max(np.abs(table(w) / table.exact(c, ph) - 1.0)) < tol


def test_shadowing_is_symmetric_and_vanishes_for_hidden_facets():
    model = R.AshikhminShirley(8, 20, orientation_deg=10)
    rng = np.random.default_rng(3)
    n = 400
    wi = rng.normal(size=(n, 3))
    wo = rng.normal(size=(n, 3))
    wi[:, 2], wo[:, 2] = np.abs(wi[:, 2]), np.abs(wo[:, 2])
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    zz, xx = np.tile(Z, (n, 1)), np.tile(X, (n, 1))
    g_io = model.shadowing(zz, h, wi, wo, xx)
    assert np.allclose(g_io, model.shadowing(zz, h, wo, wi, xx), atol=0.0)
    assert np.all((g_io >= 0.0) & (g_io <= 1.0))
    assert np.all(model.shadowing(zz, -h, wi, wo, xx) == 0.0)


def test_torrance_sparrow_and_ashikhmin_pair_limits():
    wi = _direction(40, 180)[None, :]
    wo = _direction(40, 0)[None, :]
    h = np.array([[0.0, 0.0, 1.0]])
    z = Z[None, :]
    assert R.torrance_sparrow(z, h, wi, wo)[0] == pytest.approx(1.0)
    wo_g = _direction(89, 0)[None, :]
    hg = (wi + wo_g) / np.linalg.norm(wi + wo_g)
    expected = 2.0 * hg[0, 2] * wo_g[0, 2] / float(wo_g[0] @ hg[0])  # the binding V-groove term
    assert R.torrance_sparrow(z, hg, wi, wo_g)[0] == pytest.approx(min(1.0, expected))
    g1i, g1o = np.array([0.9]), np.array([0.6])
    # forward specular plane: uncorrelated product; backscatter: fully correlated minimum
    assert R.ashikhmin_pair(g1i, g1o, z, wi, wo)[0] == pytest.approx(0.54)
    assert R.ashikhmin_pair(g1i, g1o, z, wi, wi)[0] == pytest.approx(0.6)


# ---------------------------------------------------------------------------------------------
# Seed 003 eq. 18-23: the ensemble average, stable from m = 0 to 1e6
# ---------------------------------------------------------------------------------------------


def _mean_cos_mpmath(m, alpha):
    """Seed 003 eq. 18 evaluated directly (azimuth integral in closed form, polar by mpmath)."""
    import mpmath as mp

    mp.mp.dps = 25
    m, al = mp.mpf(m), mp.mpf(alpha)
    ca, sa = mp.cos(al), mp.sin(al)

    def f(t):
        a, b = ca * mp.cos(t), sa * mp.sin(t)
        if a >= b:
            inner = 2 * mp.pi * a
        elif a <= -b:
            inner = mp.mpf(0)
        else:
            p0 = mp.acos(-a / b)
            inner = 2 * (a * p0 + b * mp.sin(p0))
        return (m + 1) / (2 * mp.pi) * mp.cos(t) ** m * mp.sin(t) * inner

    pts, k = [mp.mpf(0)], 1 / (8 * mp.sqrt(m + 1))
    while k < mp.pi / 2:
        pts.append(k)
        k *= 2
    if 0 < mp.pi / 2 - al < mp.pi / 2:
        pts.append(mp.pi / 2 - al)
    pts.append(mp.pi / 2)
    return float(mp.quad(f, sorted(set(pts))))


@pytest.mark.parametrize("m", [0, 1, 10, 1e3, 1e6])
def test_blinn_phong_ensemble_average_is_finite_and_accurate(m):
    pytest.importorskip("mpmath")
    for alpha_deg in (0.0, 60.0, 89.9, 90.0):
        ref = _mean_cos_mpmath(m, math.radians(alpha_deg))
        got = float(R.blinn_phong_mean_cos(m, math.cos(math.radians(alpha_deg))))
        assert math.isfinite(got)
        # 1e-9 relative: the incidence-angle cosine itself carries 1e-16, and near grazing the
        # result is ~4e-4 for m = 1e6 (betainc's own accuracy dominates)
        assert got == pytest.approx(ref, rel=1e-9, abs=1e-15)


def test_naive_factorial_form_fails_where_the_stable_form_does_not():
    """Seed 003 eq. 20, A(m) = pi m!/(2^(2m) (m/2)!^2)... as written needs m! beyond float range."""
    with pytest.raises(OverflowError):
        float(math.factorial(5000))
    assert np.isfinite(R.blinn_phong_mean_cos(np.array([5000.0, 1e6, 1e9]), 0.3)).all()


# ---------------------------------------------------------------------------------------------
# Visible-normal sampling
# ---------------------------------------------------------------------------------------------


def _binned_chi2(model, wo, n=100_000, nb_t=10, nb_p=12, seed=0):
    """Chi-square of sampled normals against the integrated pdf over (theta, phi) bins."""
    rng = np.random.default_rng(seed)
    m, w = model.sample_normals(Z, X, np.tile(wo, (n, 1)), rng.random(n), rng.random(n))
    assert np.all(w == 1.0)
    theta_max = math.pi / 2
    th = np.arccos(np.clip(m[:, 2], -1, 1))
    ph = np.arctan2(m[:, 1], m[:, 0]) % (2 * np.pi)
    # bins equal in the model's cosine-weighted measure: theta edges from its D cos quantiles
    md, _ = model.sample_dcos(Z, X, rng.random(50_000), rng.random(50_000))
    edges_t = np.quantile(np.arccos(np.clip(md[:, 2], -1, 1)), np.linspace(0, 1, nb_t + 1))
    edges_t[0], edges_t[-1] = 0.0, theta_max
    edges_p = np.linspace(0, 2 * np.pi, nb_p + 1)
    counts, _, _ = np.histogram2d(th, ph, bins=[edges_t, edges_p])
    expected = np.zeros_like(counts)
    x, wq = np.polynomial.legendre.leggauss(24)
    for i in range(nb_t):
        t = edges_t[i] + (edges_t[i + 1] - edges_t[i]) * 0.5 * (x + 1)
        wt = (edges_t[i + 1] - edges_t[i]) * 0.5 * wq
        for j in range(nb_p):
            p = edges_p[j] + (edges_p[j + 1] - edges_p[j]) * 0.5 * (x + 1)
            wp = (edges_p[j + 1] - edges_p[j]) * 0.5 * wq
            T, P = np.meshgrid(t, p, indexing="ij")
            mm = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
            dens = model.pdf(Z, X, np.tile(wo, (mm.shape[0], 1)), mm).reshape(T.shape)
            expected[i, j] = n * np.sum(dens * np.sin(T) * wt[:, None] * wp[None, :])
    keep = expected > 5
    chi2 = np.sum((counts[keep] - expected[keep]) ** 2 / expected[keep])
    return chi2, int(keep.sum()), counts.sum(), expected.sum()


@pytest.mark.parametrize(
    "name, theta",
    [
        ("as_iso", 0.0),
        ("as_iso", 100.0),
        ("as_aniso", 75.0),
        ("as_aniso", 100.0),
        ("phong_0", 75.0),
        ("phong_0", 100.0),
        ("ggx", 75.0),
        ("ggx", 100.0),
        ("ggx_aniso", 0.0),
        ("ggx_aniso", 100.0),
        ("beckmann", 75.0),
        ("beckmann", 100.0),
    ],
)
def test_sampled_normals_follow_the_visible_normal_distribution(name, theta):
    """Histogram of sample_normals against the analytic D_wo (including wo below the horizon,
    as for a masked ray re-hitting the surface). Chi-square threshold: dof + 6 sqrt(2 dof)."""
    model = MODELS[name]()
    wo = _direction(theta, 25.0)
    chi2, dof, n_in, n_exp = _binned_chi2(model, wo)
    assert n_exp == pytest.approx(n_in, rel=2e-3)  # the pdf integrates to 1 over the bins
    assert chi2 < dof + 6.0 * math.sqrt(2.0 * dof)


def test_sampling_is_deterministic_in_the_uniforms():
    model = R.AshikhminShirley(40, 10)
    rng = np.random.default_rng(9)
    u1, u2 = rng.random(1000), rng.random(1000)
    wo = np.tile(_direction(70, 10), (1000, 1))
    m1, _ = model.sample_normals(Z, X, wo, u1, u2)
    m2, _ = model.sample_normals(Z, X, wo, u1, u2)
    m3, _ = model.sample_normals(Z, X, wo[:500], u1[:500], u2[:500])
    assert np.array_equal(m1, m2) and np.array_equal(m1[:500], m3)


def test_per_ray_frames_equal_one_shared_frame():
    model = R.GGX(alpha_x=0.1, alpha_y=0.4, orientation_deg=30)
    rng = np.random.default_rng(2)
    n = 300
    wo = np.tile(_direction(60, 45), (n, 1))
    u1, u2 = rng.random(n), rng.random(n)
    a, _ = model.sample_normals(Z, X, wo, u1, u2)
    b, _ = model.sample_normals(np.tile(Z, (n, 1)), np.tile(X, (n, 1)), wo, u1, u2)
    assert np.allclose(a, b, atol=1e-14)


def test_rotated_macro_frame_rotates_the_normals():
    """Sampling about a tilted normal is the z-frame result rotated (rigid-motion invariance)."""
    model = R.AshikhminShirley(20, 5)
    c, s = math.cos(0.7), math.sin(0.7)
    rot = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    rng = np.random.default_rng(4)
    n = 500
    u1, u2 = rng.random(n), rng.random(n)
    wo = np.tile(_direction(35, 80), (n, 1))
    m0, _ = model.sample_normals(Z, X, wo, u1, u2)
    m1, _ = model.sample_normals(rot @ Z, rot @ X, wo @ rot.T, u1, u2)
    assert np.allclose(m1, m0 @ rot.T, atol=1e-12)


def test_blender_gloss_follows_the_seed_recipe():
    """tan(theta_m) = r = sqrt(1 - b^(2L)), L = (1 - g)^3 (Murakowski 2014 sec. 2.2.6); gloss 1 is a
    mirror; a drawn facet that faces away from wo is replaced by its mirror image."""
    rng = np.random.default_rng(6)
    n = 100_000
    smooth = R.BlenderGloss(1.0)
    m, w = smooth.sample_normals(Z, X, np.tile(_direction(50, 0), (n, 1)), rng.random(n), rng.random(n))
    assert np.allclose(m, Z) and np.all(w == 1.0)
    model = R.BlenderGloss(0.3)
    L = 0.7**3
    wo = np.tile(_direction(10, 0), (n, 1))  # no facet faces away at 10 degrees (tilts < 45)
    m, _ = model.sample_normals(Z, X, wo, rng.random(n), rng.random(n))
    r = np.hypot(m[:, 0], m[:, 1]) / m[:, 2]
    assert r.max() <= 1.0 + 1e-12
    for q in (0.2, 0.5, 0.8):  # CDF of r: P(r < q) = P(b > (1 - q^2)^(1/2L)) = 1 - (1-q^2)^(1/2L)
        assert np.mean(r < q) == pytest.approx(1.0 - (1.0 - q * q) ** (0.5 / L), abs=0.005)
    wo = np.tile(_direction(80, 0), (n, 1))
    m, w = model.sample_normals(Z, X, wo, rng.random(n), rng.random(n))
    assert np.all(np.einsum("ij,ij->i", m, wo) > 0.0) and np.all(w == 1.0)
    assert model.masking(Z, X, np.array([[0.0, 0.6, 0.8], [0.0, 0.6, -0.8]])).tolist() == [1.0, 0.0]


unit_vectors = hst.tuples(*[hst.floats(-1.0, 1.0, allow_nan=False)] * 3).filter(
    lambda v: 1e-3 < math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
)
model_specs = hst.one_of(
    # exponents from a few values: each anisotropic pair tabulates its masking once (0.2 s)
    hst.builds(
        lambda ex, ey, o: {"model": "ashikhmin_shirley", "ex": ex, "ey": ey, "orientation_deg": o},
        hst.sampled_from([0.0, 0.5, 15.0, 1e3, 1e6]),
        hst.sampled_from([0.0, 2.0, 15.0, 1e4]),
        hst.floats(-360, 360),
    ),
    hst.builds(lambda m: {"model": "blinn_phong", "m": m}, hst.floats(0, 1e6)),
    hst.builds(lambda a, b: {"model": "ggx", "alpha_x": a, "alpha_y": b}, hst.floats(1e-4, 5), hst.floats(1e-4, 5)),
    hst.builds(lambda a: {"model": "beckmann", "alpha": a}, hst.floats(1e-4, 5)),
    hst.builds(lambda g: {"model": "blender_gloss", "gloss": g}, hst.floats(0, 1)),
)


@settings(max_examples=60, deadline=None)
# found by this test: wo 1e-162 from straight below the surface; the facet's squared components
# underflowed and its normal came out 0.937 long
@example(
    spec={"model": "beckmann", "alpha": 2.0},
    n=(1.0, 0.0, 0.0),
    t=(0.0, 0.0, 1.0),
    wos=[(-1.0, 0.0, 7.366482946834361e-163)],
    us=[(0.0, 0.0)] * 8,
)
@example(
    spec={"model": "ggx", "alpha": 2.0},
    n=(1.0, 0.0, 0.0),
    t=(0.0, 0.0, 1.0),
    wos=[(-1.0, 0.0, 7.366482946834361e-163)],
    us=[(0.0, 0.0)] * 8,
)
@given(
    spec=model_specs,
    n=unit_vectors,
    t=unit_vectors,
    wos=hst.lists(unit_vectors, min_size=1, max_size=8),
    us=hst.lists(
        hst.tuples(hst.floats(0, 1, exclude_max=True), hst.floats(0, 1, exclude_max=True)), min_size=8, max_size=8
    ),
)
def test_sample_normals_never_nan_always_unit_weights_finite(spec, n, t, wos, us):
    model = R.make_model(spec)
    nv = np.array(n) / np.linalg.norm(n)
    k = len(wos)
    wo = np.array(wos) / np.linalg.norm(np.array(wos), axis=1, keepdims=True)
    u = np.array(us[:k])
    m, w = model.sample_normals(np.tile(nv, (k, 1)), np.tile(np.array(t), (k, 1)), wo, u[:, 0], u[:, 1])
    assert m.shape == (k, 3) and w.shape == (k,)
    assert np.all(np.isfinite(m)) and np.all(np.isfinite(w))
    assert np.allclose(np.linalg.norm(m, axis=1), 1.0, atol=1e-12)
    assert np.all(w >= 0.0)
    assert np.all(np.einsum("ij,ij->i", m, wo)[w > 0.0] > 0.0)
    g = model.masking(np.tile(nv, (k, 1)), np.tile(np.array(t), (k, 1)), wo)
    assert np.all(np.isfinite(g)) and np.all((g >= 0.0) & (g <= 1.0))


# ---------------------------------------------------------------------------------------------
# Registry and user errors
# ---------------------------------------------------------------------------------------------


def test_registry_holds_the_issue_models():
    assert set(R.REGISTRY) == {"ashikhmin_shirley", "blinn_phong", "ggx", "beckmann", "blender_gloss"}
    for name, ctor in R.REGISTRY.items():
        assert set(R.PARAMETERS[name])  # every model documents its parameters
        assert callable(ctor)


@pytest.mark.parametrize(
    "spec, cls",
    [
        ({"model": "ashikhmin_shirley", "ex": 15, "ey": 15, "orientation_deg": 0}, R.AshikhminShirley),
        ({"model": "blinn_phong", "m": 1e3}, R.BlinnPhong),
        ({"model": "ggx", "alpha": 0.3}, R.GGX),
        ({"model": "beckmann", "alpha_x": 0.2, "alpha_y": 0.4}, R.Beckmann),
        ({"model": "blender_gloss", "gloss": 0.8}, R.BlenderGloss),
    ],
)
def test_make_model_builds_each_model(spec, cls):
    model = R.make_model(spec, file="scene.yaml", key="materials.sand.roughness")
    assert type(model) is cls and model.name == spec["model"]
    assert isinstance(model, R.MicrofacetModel)


def test_unknown_model_lists_the_known_ones():
    with pytest.raises(UserError) as ex:
        R.make_model({"model": "cook_torrance"}, file="s.yaml", key="materials.x.roughness")
    msg = str(ex.value)
    assert "s.yaml" in msg and "materials.x.roughness.model" in msg
    for name in R.REGISTRY:
        assert name in msg


@pytest.mark.parametrize(
    "spec, key, words",
    [
        ({"model": "ashikhmin_shirley", "ex": 15}, "r.ey", "missing ey"),
        ({"model": "ashikhmin_shirley", "ex": -1, "ey": 2}, "r.ex", ">= 0"),
        ({"model": "ashikhmin_shirley", "ex": "15", "ey": 2}, "r.ex", "expected a number"),
        ({"model": "ashikhmin_shirley", "ex": True, "ey": 2}, "r.ex", "expected a number"),
        ({"model": "blinn_phong", "m": float("nan")}, "r.m", "must be"),
        ({"model": "blinn_phong", "m": 3, "alpha": 1}, "r.alpha", "unknown parameter 'alpha'"),
        ({"model": "ggx", "alpha": 0}, "r.alpha", "> 0"),
        ({"model": "ggx"}, "r.alpha", "missing alpha"),
        ({"model": "ggx", "alpha": 0.1, "alpha_x": 0.2, "alpha_y": 0.3}, "r.alpha_x", "not both"),
        ({"model": "blender_gloss", "gloss": 1.5}, "r.gloss", "<= 1"),
        ({"ex": 3}, "r.model", "missing `model:`"),
    ],
)
def test_bad_parameters_name_their_key(spec, key, words):
    with pytest.raises(UserError) as ex:
        R.make_model(spec, file="f.yaml", key="r")
    assert key in str(ex.value) and words in str(ex.value)


def test_several_problems_are_reported_together():
    with pytest.raises(UserErrors) as ex:
        R.make_model({"model": "ashikhmin_shirley", "ex": -1, "ey": "x", "foo": 1}, key="r")
    assert len(ex.value.errors) == 3


def test_a_roughness_entry_must_be_a_mapping():
    with pytest.raises(UserError, match="mapping"):
        R.make_model("ggx", file="f.yaml", key="materials.a.roughness")


@pytest.mark.parametrize(
    "model",
    [
        R.GGX(alpha=0.15),
        R.GGX(alpha_x=0.1, alpha_y=0.6, orientation_deg=30.0),
        R.Beckmann(alpha=0.3),
        R.Beckmann(alpha_x=0.2, alpha_y=0.5, orientation_deg=-20.0),
    ],
    ids=repr,
)
def test_compiled_draw_and_masking_equal_the_array_code(model):
    """The renderer's per-ray GGX draw and GGX/Beckmann masking are compiled (`smith_g1`,
    `_ggx_sample_rows`); the base class's array code (`local_frame`, `_ggx_vndf_local`, the
    projected areas) is their reference, over random macro normals, tangents (50 parallel to
    the normal: the frame's fallback axis) and directions on both sides. Tolerances: masking
    1e-13 (a few operations' rounding); normals 1e-11 (the draw divides by |m|, small near
    grazing, which amplifies rounding: 6e-13 seen); weights exactly."""
    rng = np.random.default_rng(7)
    k = 20_000
    n = rng.normal(size=(k, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    t = rng.normal(size=(k, 3))
    t[:50] = 2.0 * n[:50]
    w = rng.normal(size=(k, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    u1, u2 = rng.random(k), rng.random(k)
    np.testing.assert_allclose(model.masking(n, t, w), R._Microfacet.masking(model, n, t, w), rtol=0, atol=1e-13)
    np.testing.assert_allclose(
        model.masking(n[0], t[0], w), R._Microfacet.masking(model, n[0], t[0], w), rtol=0, atol=1e-13
    )
    m, weight = model.sample_normals(n, t, w, u1, u2)
    m_ref, weight_ref = R._Microfacet.sample_normals(model, n, t, w, u1, u2)
    np.testing.assert_allclose(m, m_ref, rtol=0, atol=1e-11)
    np.testing.assert_array_equal(weight, weight_ref)
    assert np.all(R.GGX(alpha=0.15).masking(n, None, n) == 1.0)  # G1(n) = 1: A(n) = n.n


def test_the_compiled_draw_keeps_a_tiny_facet_unit():
    """`ggx_draw1` (the tracer's draw) at the case the property test found: the facet's components
    are 1e-162, whose squares underflow. Control: numpy's plain norm of such a vector is 6 % off,
    so the scaling is what keeps it unit. Tolerance 1e-15: one rounding of a unit vector."""
    mx, my, mz, w = R.ggx_draw1(
        (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (-1.0, 0.0, 7.366482946834361e-163), 0.0, 0.0, 2.0, 2.0, 0.0
    )
    assert abs(math.sqrt(mx * mx + my * my + mz * mz) - 1.0) < 1e-15 and w in (0.0, 1.0)
    tiny = np.array([2.9465931787337443e-162, 0.0, 0.0])
    assert abs(np.linalg.norm(tiny) / tiny[0] - 1.0) > 0.05
