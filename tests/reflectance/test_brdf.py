"""`pmmw brdf` (pmmw.reflectance): energy balance, reciprocity, Monte Carlo against the analytic
model order by order, rough-to-smooth convergence, the Optics Express 2016 copper case (0.8692) and the
numbers of its literal variants, NIST SCATMECH (pySCATMECH, slow, skipped when absent), the
outputs and the user errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from pmmw import reflectance as B
from pmmw.errors import UserError
from pmmw.physics import fresnel
from pmmw.physics import roughness as R

COPPER_N = 0.23 + 3.46j  # Optics Express 2016 sec. 4.2, 635 nm
Q_RECIP = np.diag([1.0, 1.0, -1.0, 1.0])  # Mueller reciprocity: M(wo->wi) = Q M(wi->wo)^T Q


def _copper(model=None):
    return B.Stack(layers=(B.StackLayer(eps=COPPER_N**2, roughness=model),))


def _mc(stack, theta_i, samples, seed=0, phi_i=0.0):
    res = B.run_brdf(stack=stack, incidence=theta_i, azimuth=phi_i, samples=samples, seed=seed)
    return res.summary["methods"]["mc"], res


def _flat_fresnel_mueller(n, theta_i):
    """Normalized m12, m33, m34 of a flat interface in this module's (h, v) = (s, p) basis."""
    c = np.array([math.cos(math.radians(theta_i))])
    f = fresnel.interface(np.array([1.0 + 0j]), np.array([n * n]), c)
    rs, rp = f.rs[0], f.rp[0]
    tot = abs(rs) ** 2 + abs(rp) ** 2
    cross = rs * np.conj(rp)
    return (abs(rs) ** 2 - abs(rp) ** 2) / tot, 2 * cross.real / tot, -2 * cross.imag / tot


# ---------------------------------------------------------------------------------------------
# Energy
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", [R.AshikhminShirley(15, 15), R.GGX(0.5), R.BlinnPhong(0)])
@pytest.mark.parametrize("theta_i", [0.0, 60.0, 85.0])
def test_rough_lossless_dielectric_reflects_plus_transmits_one(model, theta_i):
    """Every path keeps its power until it leaves (no discarding; branch choice rescales), so
    R + T = 1 to rounding, path by path; nothing is absorbed."""
    s, _ = _mc(B.Stack(layers=(B.StackLayer(eps=2.25 + 0j, roughness=model),)), theta_i, 20_000)
    assert s["total_reflectance"] + s["total_transmittance"] == pytest.approx(1.0, abs=1e-12)
    assert s["absorptance"] < 1e-12 and s["lost"] == 0.0  # rounding of R + T = 1 per facet
    assert 0.0 < s["total_reflectance"] < 1.0


def test_rough_lossless_multilayer_reflects_plus_transmits_one():
    stack = B.Stack(
        layers=(
            B.StackLayer(eps=1.69 + 0j, roughness=R.AshikhminShirley(30, 30)),
            B.StackLayer(eps=1.96 + 0j, roughness=R.AshikhminShirley(10, 40, orientation_deg=30)),
            B.StackLayer(eps=2.25 + 0j, roughness=R.GGX(0.3)),
        )
    )
    s, _ = _mc(stack, 40.0, 20_000)
    assert s["total_reflectance"] + s["total_transmittance"] == pytest.approx(1.0, abs=1e-12)


def test_rough_perfect_conductor_reflects_everything():
    """White furnace: a rough perfect conductor returns every path with its full power."""
    stack = B.Stack(layers=(B.StackLayer(eps=0j, metal=True, roughness=R.AshikhminShirley(5, 5)),))
    s, _ = _mc(stack, 60.0, 50_000)
    assert s["total_reflectance"] == pytest.approx(1.0, abs=1e-12)


def test_lossy_stack_balances_reflection_absorption():
    """Copper under a lossy, thick, rough dielectric layer: R + A = 1 within the Monte Carlo error
    of R (Russian roulette below the threshold is unbiased but noisy)."""
    stack = B.Stack(
        layers=(
            B.StackLayer(eps=2.5 + 0.05j, thickness=2e-3, roughness=R.AshikhminShirley(10, 10)),
            B.StackLayer(eps=COPPER_N**2, roughness=R.AshikhminShirley(20, 20)),
        ),
        frequency=95e9,
    )
    s, _ = _mc(stack, 30.0, 20_000)
    total = s["total_reflectance"] + s["absorptance"] + s["lost"]
    assert total == pytest.approx(1.0, abs=5 * s["total_reflectance_stderr"] + 1e-3)


@pytest.mark.parametrize("e", [2.0, 15.0])
def test_rough_copper_never_beats_flat_copper(e):
    """Seed 001's copper (n = 0.23 + 3.46i) from normal to grazing incidence: the rough surface
    reflects no more than the flat one beyond 4 standard errors. (Not a law for every conductor:
    docs/brdf.md shows where a convex R(theta) makes rough exceed flat.)"""
    for theta_i in (0.0, 40.0, 70.0, 85.0):
        s, res = _mc(_copper(R.AshikhminShirley(e, e)), theta_i, 20_000)
        assert s["total_reflectance"] <= res.summary["flat_reflectance"] + 4 * s["total_reflectance_stderr"]


def test_smooth_multilayer_matches_the_incoherent_closed_form():
    stack = B.Stack(
        layers=(
            B.StackLayer(eps=2.25 + 0j, thickness=0.01),
            B.StackLayer(eps=4 + 0.5j, thickness=0.003),
            B.StackLayer(eps=COPPER_N**2),
        ),
        frequency=95e9,
    )
    s, res = _mc(stack, 35.0, 100_000)
    assert s["total_reflectance"] == pytest.approx(
        res.summary["flat_reflectance"], abs=5 * s["total_reflectance_stderr"] + 2e-3
    )


def test_coating_on_the_facets_uses_the_multilayer_stack():
    """A quarter-wave film on glass (n = 1.5 on 2.25) at normal incidence: a nearly smooth
    surface reflects the coated-stack value, here 0 (perfect antireflection)."""
    lam = 299_792_458.0 / 95e9
    coated = B.Stack(
        layers=(B.StackLayer(eps=2.25**2 + 0j, roughness=R.BlinnPhong(1e6), coating=((1.5**2 + 0j, lam / 4 / 1.5),)),),
        frequency=95e9,
    )
    s, _ = _mc(coated, 0.0, 5_000)
    assert s["total_reflectance"] < 1e-9
    assert B.flat_reflectance(coated, 0.0) < 1e-12


# ---------------------------------------------------------------------------------------------
# Analytic model: reciprocity, Fresnel limit, agreement with the Monte Carlo order by order
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "model", [R.AshikhminShirley(15, 8, orientation_deg=20), R.GGX(alpha_x=0.2, alpha_y=0.5), R.BlinnPhong(40)]
)
def test_analytic_model_is_reciprocal(model):
    """Single and double terms: M(wo -> wi) = Q M(wi -> wo)^T Q, Q = diag(1, 1, -1, 1), to
    rounding (the double term's two sampling strategies swap under wi <-> wo)."""
    st = _copper(model)
    for (ti, pi_), (to, po) in (((40, 10), (55, 230)), ((65, 300), (30, 80))):
        wi, wo = B._direction(ti, pi_), B._direction(to, po)
        s1, d1 = B.analytic_mueller(st, wi, wo[None], double_samples=64)
        s2, d2 = B.analytic_mueller(st, wo, wi[None], double_samples=64)
        for fwd, rev in ((s1[0], s2[0]), (d1[0], d2[0])):
            assert np.allclose(rev, Q_RECIP @ fwd.T @ Q_RECIP, rtol=1e-9, atol=1e-12 * np.abs(fwd).max())


def test_specular_mueller_of_the_analytic_model_is_the_flat_fresnel_one():
    """At the specular direction the facet is the macro surface: normalized m12, m33, m34 equal
    the flat-surface Fresnel values exactly (single term)."""
    st = _copper(R.AshikhminShirley(15, 15))
    for theta_i in (20.0, 40.0, 70.0):
        wi = B._direction(theta_i, 180.0)
        ws = B._direction(theta_i, 0.0)
        s1, _ = B.analytic_mueller(st, wi, ws[None], double=False)
        m = s1[0] / s1[0, 0, 0]
        m12, m33, m34 = _flat_fresnel_mueller(COPPER_N, theta_i)
        assert (m[0, 1], m[2, 2], m[2, 3]) == pytest.approx((m12, m33, m34), abs=1e-12)


def test_monte_carlo_matches_the_analytic_model_order_by_order():
    """The Monte Carlo's first- and second-order hemispherical reflectances equal the analytic
    single (Smith G1 G1) and double-reflection terms (facet-space quadrature)."""
    st = _copper(R.AshikhminShirley(15, 15))
    wi = B._direction(40.0, 0.0)
    t1, t2 = B.analytic_totals(st, wi, shadowing="smith")
    s, _ = _mc(st, 40.0, 200_000)
    r1, r2, r3 = s["reflectance_by_order"]
    # MC error of each order: a binomial-like spread of path powers <= 0.5/sqrt(N) for order 2
    assert r1 == pytest.approx(t1[0, 0], abs=2e-3)
    assert r2 == pytest.approx(t2[0, 0], abs=2e-3)
    assert 0.0 < r3 < r2 < r1


def test_monte_carlo_maps_match_the_analytic_maps():
    """Power through 10 x 30 degree boxes of the grid, order by order: the Monte Carlo's first
    and second orders against the analytic single and double terms at the cell centres. The
    tolerance is 4 standard deviations of the number of paths in the box (Poisson)."""
    n = 200_000
    res = B.run_brdf(n="0.23+3.46j", incidence=40, ex=5, ey=5, samples=n)
    by_order = res.methods["mc"].parts["by_order"]
    proj = B.projected_solid_angle()
    st = _copper(R.AshikhminShirley(5, 5))
    _, ph, w = B.grid_directions()
    for r0, c0 in ((5, 0), (20, 90), (30, 180), (50, 180), (60, 270), (70, 0)):
        rows, cols = np.arange(r0, r0 + 10), np.arange(c0 - 15, c0 + 15) % 360
        box = np.ix_(rows, cols)
        s1, d2 = B.analytic_mueller(
            st, B._direction(40, 0), w[box].reshape(-1, 3), phi_o=ph[box].reshape(-1), double_samples=128
        )
        for order, an_map in ((0, s1), (1, d2)):
            an = np.sum(an_map[:, 0, 0] * proj[box].reshape(-1))
            mc = np.sum(by_order[order][box][..., 0, 0] * proj[box])
            paths = max(an * n, 1.0)  # path powers are close to 1 here
            assert mc == pytest.approx(an, rel=4.0 / math.sqrt(paths) + 0.01)


@pytest.mark.parametrize("model", [R.AshikhminShirley(15, 15), R.GGX(0.3)])
def test_blinn_and_ashikhmin_shadowing_options_differ_only_off_plane(model):
    st = _copper(model)
    wi = B._direction(40, 180)
    wo = np.array([B._direction(60, 0), B._direction(60, 180), B._direction(60, 90)])
    sm, _ = B.analytic_mueller(st, wi, wo, shadowing="smith", double=False)
    ash, _ = B.analytic_mueller(st, wi, wo, shadowing="ashikhmin", double=False)
    non, _ = B.analytic_mueller(st, wi, wo, shadowing="none", double=False)
    assert ash[0, 0, 0] == pytest.approx(sm[0, 0, 0], rel=1e-12)  # forward plane: product
    assert ash[1, 0, 0] >= sm[1, 0, 0]  # backscatter side: min(G1, G1) >= G1 G1
    assert np.all(non[:, 0, 0] >= sm[:, 0, 0])


# ---------------------------------------------------------------------------------------------
# Rough -> smooth
# ---------------------------------------------------------------------------------------------


def test_rough_converges_to_smooth_as_the_exponent_grows():
    flat = B.flat_reflectance(_copper(), math.radians(40))
    wi = B._direction(40.0, 0.0)
    gaps = []
    for e in (10.0, 1e2, 1e4, 1e6):
        t1, t2 = B.analytic_totals(_copper(R.AshikhminShirley(e, e)), wi)
        gaps.append(abs(t1[0, 0] + t2[0, 0] - flat))
    assert gaps[-1] < 1e-4 and all(np.diff(gaps) < 0.0)
    s, res = _mc(_copper(R.BlinnPhong(1e6)), 40.0, 20_000)
    assert s["total_reflectance"] == pytest.approx(flat, abs=1e-4)
    # the Monte Carlo's power lands in the specular cell
    spec = res.summary["methods"]["mc"]["specular"]["cell"]
    cell_power = res.methods["mc"].stokes[0][tuple(spec)] * B.projected_solid_angle()[tuple(spec)]
    assert cell_power == pytest.approx(flat, rel=1e-3)
    m12, m33, m34 = _flat_fresnel_mueller(COPPER_N, 40.0)
    sp = res.summary["methods"]["mc"]["specular"]
    assert (sp["m12"], sp["m33"], sp["m34"]) == pytest.approx((m12, m33, m34), abs=2e-3)


# ---------------------------------------------------------------------------------------------
# Seed 001's copper case: 0.8692, 0.926 and 0.873
# ---------------------------------------------------------------------------------------------


def _seed_literal(samples, shadowing, rng):
    """Seed 001's model read literally: normals from its eq. 9 sampling formula (density
    (e+1)/(2 pi) cos^e, no projected-area weighting), reflected with the unpolarized Fresnel
    factor; rays going below the horizon are traced again (new facet) until they leave or fall
    below tau = 0.05 (`shadowing="none"`), or, with Torrance-Sparrow shadowing, facets are
    weighted by their projected area and rays below the horizon are discarded."""
    e, th = 15.0, math.radians(40.0)
    n2 = COPPER_N**2

    def fres(c):
        c = np.clip(np.abs(c), 0.0, 1.0)
        q2 = np.sqrt(n2 - (1 - c * c))
        rs, rp = (c - q2) / (c + q2), (n2 * c - q2) / (n2 * c + q2)
        return 0.5 * (np.abs(rs) ** 2 + np.abs(rp) ** 2)

    def normals(n):
        phi = 2 * np.pi * rng.random(n)
        ct = rng.random(n) ** (1.0 / (e + 1.0))
        st = np.sqrt(1 - ct * ct)
        return np.stack([st * np.cos(phi), st * np.sin(phi), ct], 1)

    d = np.tile([-math.sin(th), 0.0, -math.cos(th)], (samples, 1))
    if shadowing == "torrance_sparrow":
        m = normals(samples)
        c = -(d * m).sum(1)
        r = d + 2 * c[:, None] * m
        g = R.torrance_sparrow(np.tile([0, 0, 1.0], (samples, 1)), m, -d, r)
        w = np.maximum(c, 0) / math.cos(th) * (e + 2) / (e + 1)  # D(m)/p(m) and (wi.m)+/cos_i
        return float(np.mean(fres(c) * w * g * (r[:, 2] > 0)))
    w, total = np.ones(samples), 0.0
    for _ in range(50):
        m = normals(len(w))
        c = -(d * m).sum(1)
        r = d + 2 * c[:, None] * m
        w = w * fres(c)
        up = r[:, 2] > 0
        total += w[up].sum()
        keep = ~up & (w > 0.05)
        d, w = r[keep], w[keep]
        if not len(w):
            break
    return total / samples


def test_seed_001_copper_literal_variants_reproduce_0926_and_0873():
    """Two readings of Optics Express 2016: the literal model without shadowing gives ~0.926
    (0.925 here), with Torrance-Sparrow shadowing and discarded below-horizon rays ~0.873."""
    rng = np.random.default_rng(1)
    assert _seed_literal(400_000, "none", rng) == pytest.approx(0.925, abs=2e-3)
    assert _seed_literal(400_000, "torrance_sparrow", rng) == pytest.approx(0.873, abs=2e-3)
    # the same 0.873 from the analytic model with SCATMECH's shadow function (no Monte Carlo)
    t1, _ = B.analytic_totals(
        _copper(R.AshikhminShirley(15, 15)), B._direction(40, 0), shadowing="torrance_sparrow", double=False
    )
    assert t1[0, 0] == pytest.approx(0.8728, abs=3e-4)


def test_seed_001_copper_total_reflectance_fast():
    """Ours for Optics Express 2016's copper case (ex = ey = 15, 40 degrees): 0.9266, against the paper's
    0.8692 (docs/brdf.md explains the difference); 50k paths give +-1e-4."""
    s, res = _mc(_copper(R.AshikhminShirley(15, 15)), 40.0, 50_000)
    assert s["total_reflectance"] == pytest.approx(0.9266, abs=5e-4)
    assert s["total_reflectance"] < res.summary["flat_reflectance"]


@pytest.mark.slow
def test_seed_001_copper_total_reflectance_1e6():
    res = B.run_brdf(n="0.23+3.46j", incidence=40, ex=15, ey=15, samples=1_000_000, method="both")
    mc = res.summary["methods"]["mc"]
    an = res.summary["methods"]["analytic"]
    assert mc["total_reflectance"] == pytest.approx(0.92664, abs=1e-4)
    assert an["single_reflectance"] == pytest.approx(0.88498, abs=3e-4)
    assert an["double_reflectance"] == pytest.approx(0.03976, abs=3e-4)
    r1, r2, r3 = mc["reflectance_by_order"]
    assert r1 == pytest.approx(an["single_reflectance"], abs=5e-4)
    assert r2 == pytest.approx(an["double_reflectance"], abs=5e-4)
    assert mc["total_reflectance"] == pytest.approx(an["total_reflectance"] + r3, abs=5e-4)


# ---------------------------------------------------------------------------------------------
# NIST SCATMECH (pySCATMECH compiles from source: slow, optional)
# ---------------------------------------------------------------------------------------------


def _scatmech_models(e=15.0):
    brdf = pytest.importorskip("pySCATMECH.brdf")
    # SCATMECH's facet model takes the slope density P(s) = D(theta) cos^4(theta), here
    # (e+2)/(2 pi) (1 + s^2)^-(e+4)/2 for our D = (e+2)/(2 pi) cos^e (Table_Slope_Distribution)
    table = f"@x:({e + 2.0!r}/(2*3.141592653589793))*(1+x^2)^({-(e + 4.0) / 2.0!r})"
    params = {
        "lambda": 0.635,
        "substrate": f"({COPPER_N.real},{COPPER_N.imag})",
        "type": 0,
        "sdf": "Table_Slope_Distribution_Function",
        "sdf.T": table,
    }
    facet = brdf.BRDF_Model("Facet_BRDF_Model", params)
    shadowed = brdf.BRDF_Model("Shadowed_Facet_BRDF_Model", dict(params, shadow="Torrance_Sparrow_Shadow_Function"))
    return facet, shadowed


# SCATMECH's Stokes V has the opposite sign of pmmw's (jones.py): M_ours = S M_scatmech S.
_V_FLIP = np.diag([1.0, 1.0, 1.0, -1.0])


@pytest.mark.slow
def test_scatmech_in_plane_and_off_plane_mueller_brdf():
    """Copper, n = 0.23+3.46i, 40 degrees, Phong exponent 15: the whole Mueller BRDF of our
    analytic single-reflection term equals SCATMECH's Facet_BRDF_Model (no shadowing) and
    Shadowed_Facet_BRDF_Model (Torrance-Sparrow) to 1e-9 relative, in and out of the plane."""
    facet, shadowed = _scatmech_models()
    st = _copper(R.AshikhminShirley(15, 15))
    # SCATMECH's source is at azimuth 180 degrees and its specular direction at 0, as here
    wi = B._direction(40.0, 180.0)
    for ths, phs in [(40, 0), (0, 0), (20, 0), (60, 0), (80, 0), (30, 180), (70, 180), (50, 40), (70, 130)]:
        wo = B._direction(ths, phs)[None, :]
        ours_none, _ = B.analytic_mueller(st, wi, wo, phi_o=np.radians([phs]), shadowing="none", double=False)
        ours_ts, _ = B.analytic_mueller(st, wi, wo, phi_o=np.radians([phs]), shadowing="torrance_sparrow", double=False)
        for ours, model in ((ours_none[0], facet), (ours_ts[0], shadowed)):
            theirs = (
                _V_FLIP @ np.array(model.MuellerBRDF(math.radians(40), math.radians(ths), math.radians(phs))) @ _V_FLIP
            )
            assert np.allclose(ours, theirs, rtol=1e-9, atol=1e-12 * abs(theirs[0, 0]))


@pytest.mark.slow
def test_scatmech_specular_elements_equal_flat_fresnel():
    facet, _ = _scatmech_models()
    for theta_i in (20.0, 40.0, 70.0):
        m = np.array(facet.MuellerBRDF(math.radians(theta_i), math.radians(theta_i), 0.0))
        m = _V_FLIP @ m @ _V_FLIP
        m12, m33, m34 = _flat_fresnel_mueller(COPPER_N, theta_i)
        assert (m[0, 1] / m[0, 0], m[2, 2] / m[0, 0], m[2, 3] / m[0, 0]) == pytest.approx((m12, m33, m34), abs=1e-9)


@pytest.mark.slow
def test_scatmech_hemispherical_integral():
    """SCATMECH's own integrator (angle-uniform grid, 0.005) against our facet-space quadrature:
    Torrance-Sparrow 0.87282 both; without shadowing 0.9059 (their grid converges slowly there,
    the unshadowed BRDF diverges at the horizon)."""
    integ = pytest.importorskip("pySCATMECH.integrate")
    facet, shadowed = _scatmech_models()
    grid = integ.Integrator(0.005, integ.Hemisphere(), type=1)
    r_none = grid.Reflectance(facet, math.radians(40))
    r_ts = grid.Reflectance(shadowed, math.radians(40))
    st = _copper(R.AshikhminShirley(15, 15))
    wi = B._direction(40, 180)
    ours_none, _ = B.analytic_totals(st, wi, shadowing="none", double=False, n_points=1 << 18)
    ours_ts, _ = B.analytic_totals(st, wi, shadowing="torrance_sparrow", double=False, n_points=1 << 18)
    assert ours_ts[0, 0] == pytest.approx(r_ts, abs=5e-5)
    assert ours_none[0, 0] == pytest.approx(r_none, abs=3e-4)


# ---------------------------------------------------------------------------------------------
# Outputs, stack files and user errors
# ---------------------------------------------------------------------------------------------


def test_minimal_call_writes_exr_png_and_json(tmp_path):
    from pmmw.io.exr import read_exr

    res = B.run_brdf(n="0.23+3.46j", incidence=40, ex=15, ey=15, samples=20_000, out=tmp_path, mueller=True)
    summary = json.loads((tmp_path / "brdf.json").read_text())
    assert summary["total_reflectance"] == pytest.approx(res.summary["total_reflectance"])
    assert 0.9 < summary["total_reflectance"] < 0.95
    channels, attrs = read_exr(tmp_path / "brdf_mc.exr")
    assert list(channels)[:6] == ["I", "Q", "U", "V", "DoP", "AoP"]
    assert "M23" in channels and channels["I"].shape == (91, 360)
    assert attrs["pmmw:brdf:total_reflectance"] == pytest.approx(summary["total_reflectance"])
    assert (tmp_path / "brdf_mc.png").stat().st_size > 10_000
    assert (tmp_path / "brdf_inplane.png").exists()
    dop = channels["DoP"]
    assert np.all((dop >= 0) & (dop <= 1 + 1e-6))


def test_eps_is_an_alternative_to_n_and_results_are_deterministic():
    a = B.run_brdf(n="0.23+3.46j", incidence=40, ex=15, ey=15, samples=5_000, seed=3)
    b = B.run_brdf(eps=str(COPPER_N**2), incidence=40, ex=15, ey=15, samples=5_000, seed=3)
    assert np.allclose(a.methods["mc"].mueller, b.methods["mc"].mueller, rtol=1e-12, atol=0)


def test_incident_polarization_is_carried_by_the_mueller_matrix():
    res = B.run_brdf(n="1.5", incidence=60, ex=30, ey=30, samples=20_000, stokes=(1, 1, 0, 0))
    m = res.summary["methods"]["mc"]["hemispherical_mueller"]
    s = res.summary["methods"]["mc"]["hemispherical_stokes"]
    assert s[0] == pytest.approx(m[0][0] + m[0][1])
    assert s[1] > 0.0  # s-polarized light off a dielectric stays mostly s


def test_stack_file(tmp_path):
    f = tmp_path / "stack.yaml"
    f.write_text(
        "frequency: 95 GHz\n"
        "layers:\n"
        "  - {n: 1.5, thickness: 1 mm, roughness: {model: ashikhmin_shirley, ex: 10, ey: 10}}\n"
        "  - n: 0.23+3.46j\n"
        "    roughness: {model: ggx, alpha: 0.2}\n"
        "    coating: [{eps: [2.5, 0.01], thickness: 0.05 mm}]\n"
    )
    st = B.load_stack(f)
    assert len(st.layers) == 2 and st.layers[1].coating and st.frequency == pytest.approx(95e9)
    s = B.run_brdf(stack=f, incidence=30, samples=5_000).summary["methods"]["mc"]
    assert 0.0 < s["total_reflectance"] < 1.0


@pytest.mark.parametrize(
    "text, key",
    [
        ("layers: []\n", "layers"),
        ("layers:\n  - {n: 1.5, colour: red}\n", "layers[0].colour"),
        ("layers:\n  - {n: 1.5, eps: 2}\n", "layers[0]"),
        ("layers:\n  - {n: 1.5-0.1j}\n", "layers[0].n"),
        ("layers:\n  - {n: 1.5, roughness: {model: phong, m: 3}}\n", "layers[0].roughness.model"),
        ("layers:\n  - {kind: metal}\n  - {n: 2}\n", "layers[0]"),
        ("layers:\n  - {n: 1.5, coating: [{n: 2, thickness: 1 mm}]}\n", "layers[0].coating"),
        ("layers:\n  - {material: concrete}\n", "layers[0].material"),
        ("frequency: 95 GHz\nlayers:\n  - {material: no_such_thing}\n", "layers[0].material"),
    ],
)
def test_stack_file_errors_name_file_and_key(tmp_path, text, key):
    f = tmp_path / "s.yaml"
    f.write_text(text)
    with pytest.raises(UserError) as ex:
        B.load_stack(f)
    assert str(f) in str(ex.value) and key in str(ex.value)


@pytest.mark.parametrize(
    "kwargs, where",
    [
        ({"n": "0.2+3j", "eps": "2"}, "--eps"),
        ({"n": "abc"}, "--n"),
        ({"n": "1.5", "incidence": 90}, "--incidence"),
        ({"n": "1.5", "stokes": (1, 2, 0, 0)}, "--stokes"),
        ({"n": "1.5", "method": "exact"}, "--method"),
        ({"n": "1.5", "shadowing": "v_groove"}, "--shadowing"),
        ({"n": "1.5", "ex": -3}, "--ex"),  # run_brdf names the option, not the stack-file key
        ({"n": "1.5", "model": "ggx", "ex": 3}, "--ex"),
        ({"n": "1.5", "gloss": 0.5, "method": "analytic"}, "--method"),
        ({"n": "1.5", "samples": 0}, "--samples"),
    ],
)
def test_option_errors(kwargs, where):
    with pytest.raises(UserError) as ex:
        B.run_brdf(**kwargs)
    assert where in str(ex.value)


def test_roughness_options_map_to_models():
    assert B.roughness_spec_from_options(ex=15) == {"model": "ashikhmin_shirley", "ex": 15, "ey": 15}
    assert B.roughness_spec_from_options(m=1e3) == {"model": "blinn_phong", "m": 1e3}
    assert B.roughness_spec_from_options(alpha=0.2, alpha_y=0.4) == {"model": "ggx", "alpha_x": 0.2, "alpha_y": 0.4}
    assert B.roughness_spec_from_options(model="beckmann", alpha=0.2) == {"model": "beckmann", "alpha": 0.2}
    assert B.roughness_spec_from_options(gloss=0.7) == {"model": "blender_gloss", "gloss": 0.7}
    assert B.roughness_spec_from_options() is None


def test_grid_and_mueller_helpers():
    assert B.projected_solid_angle().sum() == pytest.approx(math.pi, rel=1e-12)
    rng = np.random.default_rng(0)
    j = rng.normal(size=(50, 2, 2)) + 1j * rng.normal(size=(50, 2, 2))
    e = rng.normal(size=(50, 2)) + 1j * rng.normal(size=(50, 2))

    def stokes(f):
        return np.stack(
            [
                np.abs(f[:, 0]) ** 2 + np.abs(f[:, 1]) ** 2,
                np.abs(f[:, 0]) ** 2 - np.abs(f[:, 1]) ** 2,
                2 * (f[:, 0] * np.conj(f[:, 1])).real,
                2 * (f[:, 0] * np.conj(f[:, 1])).imag,
            ],
            1,
        )

    out = np.einsum("nij,nj->ni", j, e)
    assert np.allclose(np.einsum("nij,nj->ni", B.mueller_from_jones(j), stokes(e)), stokes(out))


def test_material_option_uses_the_coating_and_roughness_of_the_database_entry():
    """`--material clothed_skin` is skin under 0.8 mm of denim (a coherent film): its flat
    reflectance equals the `tmm` package's (independent transfer matrices) to 1e-9, and the
    entry's roughness (none: smooth) is used unless roughness options are given."""
    import tmm

    from pmmw.scene.materials import MaterialDB

    db = MaterialDB.load()
    f = 95e9
    skin, denim = db.get("clothed_skin"), db.get("denim_clothing")
    res = B.run_brdf(material="clothed_skin", frequency="95 GHz", incidence=30.0, samples=2000, plots=False)
    lam = 299_792_458.0 / f
    n_list = [1.0, np.sqrt(denim.eps_at(f)), np.sqrt(skin.eps_at(f))]
    d_list = [np.inf, skin.coating[0].thickness, np.inf]
    th = math.radians(30.0)
    r = [tmm.coh_tmm(pol, n_list, d_list, th, lam)["R"] for pol in ("s", "p")]
    assert res.summary["flat_reflectance"] == pytest.approx(sum(r) / 2, abs=1e-9)
    assert res.summary["total_reflectance"] == pytest.approx(sum(r) / 2, abs=1e-9)  # smooth entry
    rough = B.run_brdf(
        material="clothed_skin", frequency="95 GHz", incidence=30.0, samples=2000, alpha=0.3, plots=False
    )
    assert rough.summary["total_reflectance"] != pytest.approx(sum(r) / 2, abs=1e-3)


def test_a_stack_becomes_one_medium_of_the_renderers_tables():
    """`pmmw brdf`'s Monte Carlo traces a stack through the renderer's surface layer: the layers
    above the substrate become its rough coating layers (power attenuation 4 pi Im(n) / lambda
    where a thickness is given, none without one, Optics Express 2016 assumption 3), each with
    its films and roughness; the substrate is a sink (``opaque``) when lossy, ``metal`` when a
    perfect conductor, a dielectric when lossless."""
    from pmmw.surface.media import stack_media
    from pmmw.trace.job import DIELECTRIC, METAL, OPAQUE

    f = 94e9
    top = B.StackLayer(eps=2.25 + 0.05j, roughness=R.GGX(0.3), thickness=2e-3, coating=((3.0 + 0.1j, 1e-4),))
    mid = B.StackLayer(eps=2.0 + 0.01j, roughness=R.Beckmann(0.2))
    for bottom, kind in (
        (B.StackLayer(eps=6.0 + 2.0j, roughness=R.GGX(0.1)), OPAQUE),
        (B.StackLayer(eps=0j, metal=True), METAL),
        (B.StackLayer(eps=4.0 + 0j), DIELECTRIC),
    ):
        media = stack_media(B.Stack(layers=(top, mid, bottom), frequency=f))
        assert list(media.kind) == [DIELECTRIC, kind]
        assert media.rough(1) is bottom.roughness
        layers = media.rough_layers(1)
        assert [x.roughness for x in layers] == [top.roughness, mid.roughness]
        lam = 299_792_458.0 / f
        assert layers[0].alpha == pytest.approx(4.0 * math.pi * np.sqrt(2.25 + 0.05j).imag / lam, rel=1e-12)
        assert layers[0].thickness == 2e-3 and layers[1].alpha == 0.0
        np.testing.assert_array_equal(layers[0].films.eps, [3.0 + 0.1j])
        np.testing.assert_array_equal(layers[0].films.thickness, [1e-4])
        assert layers[1].films is None and media.coating[1] is None
