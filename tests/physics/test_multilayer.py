"""`pmmw.physics.multilayer` against the independent `tmm` package (S. Byrnes).

tmm uses the same exp(-i w t) convention (n = n' + i n'', Im kz > 0 decaying), the same r_s and
the same r_p sign (Born & Wolf r_par, equal to our H-field ratio), and the same transmitted-power
formulas; its t_p is the E-field ratio, ours the H-field ratio: t_p(H) = t_p(E) n_exit / n_0.
It solves the stack by 2x2 transfer matrices per layer, a different algorithm from ours.
"""

import numpy as np
import pytest
import tmm

from pmmw.physics.fresnel import interface
from pmmw.physics.multilayer import stack

C0 = 299_792_458.0
DEG = np.pi / 180.0

# Double precision, same physics, different algorithms: agreement to ~1e-13 is typical; 1e-9
# relative (with a 1e-12 floor for powers that pass through zero) leaves room for the phase
# error of thick lossless layers (beta ~ 1e3 rad -> ~1e-13 absolute).
RTOL, ATOL = 1e-9, 1e-12


def k0_of(f):
    return 2 * np.pi * f / C0


def tmm_ref(eps, d, theta, f):
    """tmm's s and p results for one ray: dicts with r, t, R, T."""
    n = np.sqrt(np.asarray(eps, dtype=complex))  # principal branch, Im n >= 0
    d_list = [np.inf, *d, np.inf]
    lam = C0 / f
    return {pol: tmm.coh_tmm(pol, n, d_list, theta, lam) for pol in "sp"}


def compare(eps, d, thetas, f, amplitudes=True):
    """Our stack for all angles at once against tmm one angle at a time."""
    eps = np.asarray(eps, dtype=complex)
    res = stack(eps, np.asarray(d, float), np.cos(thetas), k0_of(f))
    n_ratio = np.sqrt(eps[-1]) / np.sqrt(eps[0])
    for i, th in enumerate(thetas):
        ref = tmm_ref(eps, d, th, f)
        np.testing.assert_allclose(res.Rs[i], ref["s"]["R"], rtol=RTOL, atol=ATOL)
        np.testing.assert_allclose(res.Ts[i], ref["s"]["T"], rtol=RTOL, atol=ATOL)
        np.testing.assert_allclose(res.Rp[i], ref["p"]["R"], rtol=RTOL, atol=ATOL)
        np.testing.assert_allclose(res.Tp[i], ref["p"]["T"], rtol=RTOL, atol=ATOL)
        if amplitudes:
            np.testing.assert_allclose(res.rs[i], ref["s"]["r"], rtol=RTOL, atol=ATOL)
            np.testing.assert_allclose(res.rp[i], ref["p"]["r"], rtol=RTOL, atol=ATOL)
            np.testing.assert_allclose(res.ts[i], ref["s"]["t"], rtol=RTOL, atol=ATOL)
            np.testing.assert_allclose(res.tp[i], ref["p"]["t"] * n_ratio, rtol=RTOL, atol=ATOL)
    return res


def test_denim_on_skin_95ghz():
    """(a) 0.8 mm denim (1.61+0.121j) on dry skin (5.9+9.4j) at 95 GHz, 0..85 deg vs tmm."""
    th = np.arange(0, 86, 5.0) * DEG
    res = compare([1.0, 1.61 + 0.121j, 5.9 + 9.4j], [0.8e-3], th, 95e9)
    # the denim absorbs a little: A > 0, and the bookkeeping closes
    assert np.all(res.As > 0) and np.all(res.Ap > 0)
    np.testing.assert_allclose(res.Rs + res.Ts + res.As, 1.0, atol=1e-15)


@pytest.mark.parametrize("seed", range(40))
def test_random_three_layer_stacks(seed):
    """(b) Random 3-layer stacks (5 media), 30-300 GHz, incident from air or lossless glass.

    Layers: eps' in [1, 20], eps'' 0 or in [1e-3, 10], 0-5 mm; substrates likewise. From glass
    (eps 2.25) the angles reach beyond the critical angles of low-index layers (evanescent layers,
    frustrated total internal reflection).
    """
    rng = np.random.default_rng(seed)
    eps0 = 1.0 if seed % 2 == 0 else 2.25

    def medium():
        loss = 0.0 if rng.random() < 0.3 else 10 ** rng.uniform(-3, 1)
        return rng.uniform(1, 20) + 1j * loss

    eps = [eps0, medium(), medium(), medium(), medium()]
    d = rng.uniform(0, 5e-3, 3)
    f = rng.uniform(30e9, 300e9)
    th = np.sort(rng.uniform(0, 88, 6)) * DEG
    compare(eps, d, th, f)


def test_lossless_glass_slab():
    """(c) 6 mm glass (2.25) in air at 35 GHz: R + T = 1 to 1e-14 and tmm agreement."""
    th = np.linspace(0, 89, 90) * DEG
    res = compare([1.0, 2.25, 1.0], [6e-3], th, 35e9)
    np.testing.assert_allclose(res.Rs + res.Ts, 1.0, atol=1e-14)
    np.testing.assert_allclose(res.Rp + res.Tp, 1.0, atol=1e-14)
    np.testing.assert_allclose(res.As, 0.0, atol=1e-14)


def test_frustrated_tir_gap():
    """Glass / 1 mm air gap / glass beyond the critical angle: tunnelling agrees with tmm."""
    th = np.array([45.0, 50.0, 60.0, 75.0]) * DEG
    res = compare([2.25, 1.0, 2.25], [1e-3], th, 95e9)
    assert np.all(res.Ts > 1e-6) and np.all(res.Ts < 0.5)
    np.testing.assert_allclose(res.Rs + res.Ts, 1.0, atol=1e-14)


def test_thick_water_layer_is_half_space():
    """50 mm water (6.65+9.4j) on concrete at 95 GHz reflects as a water half-space.

    exp(-2 k0 Im(q) d) ~ 1e-225: the substrate is invisible, R equals the bare water interface to
    1e-13 (rounding); tmm clamps such layers and returns T ~ 1e-31 instead of ~1e-225, so only R is
    compared with it. Our T is tiny, finite and not negative.
    """
    th = np.linspace(0, 89, 30) * DEG
    eps = np.array([1.0, 6.65 + 9.4j, 5.5 + 0.5j])
    res = stack(eps, [0.05], np.cos(th), k0_of(95e9))
    half = interface(np.ones(th.size), np.full(th.size, 6.65 + 9.4j), np.cos(th))
    np.testing.assert_allclose(res.Rs, half.Rs, rtol=1e-13)
    np.testing.assert_allclose(res.Rp, half.Rp, rtol=1e-13)
    for i, t in enumerate(th):
        ref = tmm_ref(eps, [0.05], t, 95e9)
        np.testing.assert_allclose(res.Rs[i], ref["s"]["R"], rtol=RTOL)
        np.testing.assert_allclose(res.Rp[i], ref["p"]["R"], rtol=RTOL)
    for a in res:
        assert np.all(np.isfinite(a))
    assert np.all((res.Ts >= 0) & (res.Ts < 1e-100)) and np.all((res.Tp >= 0) & (res.Tp < 1e-100))


def test_one_metre_lossy_layer_300ghz():
    """1 m of eps 5+2j at 300 GHz (exp(-2 k0 Im q d) underflows): finite, R = half-space R."""
    c = np.linspace(0, 1, 11)
    res = stack(np.array([1.0, 5 + 2j, 3.0]), [1.0], c, k0_of(300e9))
    half = interface(np.ones(c.size), np.full(c.size, 5 + 2j), c)
    for a in res:
        assert np.all(np.isfinite(a))
    np.testing.assert_allclose(res.Rs, half.Rs, rtol=1e-13)
    np.testing.assert_allclose(res.Rp, half.Rp, rtol=1e-13)
    np.testing.assert_array_equal(res.Ts, 0.0)


def random_rays(rng, n, lossy_incident):
    eps1 = rng.uniform(1, 10, n) + 1j * (rng.uniform(0, 5, n) if lossy_incident else 0)
    eps2 = rng.uniform(1, 50, n) + 1j * rng.choice([0.0, 1.0], n) * 10 ** rng.uniform(-3, 7, n)
    c = rng.uniform(0, 1, n)
    c[:5] = [0.0, 1.0, 0.0, 1.0, 1e-300]
    eps2[2] = eps1[2]  # index-matched at grazing
    return eps1, eps2, c


@pytest.mark.parametrize("lossy_incident", [False, True])
def test_two_media_equals_interface_exactly(lossy_incident):
    """L == 2 is fresnel.interface bit for bit (same helpers, no layer step)."""
    rng = np.random.default_rng(7)
    eps1, eps2, c = random_rays(rng, 500, lossy_incident)
    a = stack(np.stack([eps1, eps2], axis=1), np.zeros((500, 0)), c, k0_of(95e9))
    b = interface(eps1, eps2, c)
    for x, y, name in zip(a, b, a._fields):
        np.testing.assert_array_equal(x, y, err_msg=name)


@pytest.mark.parametrize("lossy_incident", [False, True])
def test_zero_thickness_layer_vanishes(lossy_incident):
    """A layer of thickness 0 is the identity: the stack equals the stack without it (1e-15).

    The layer step is exactly the identity at d = 0 and the power-of-two rescaling is exact, so
    the agreement is to rounding (it is in fact bitwise in practice); this includes layers at
    exactly grazing incidence and layers index-matched to the incident medium (q = 0 there).
    """
    rng = np.random.default_rng(11)
    n = 400
    eps1, eps2, c = random_rays(rng, n, lossy_incident)
    layer = rng.uniform(1, 30, n) + 1j * rng.uniform(0, 30, n)
    layer[:50] = eps1[:50]
    coat = rng.uniform(1, 10, n) + 1j * rng.uniform(0, 1, n)
    k0 = k0_of(140e9)
    d = np.stack([np.zeros(n), np.full(n, 1e-3)], 1)
    with_zero = stack(np.stack([eps1, layer, coat, eps2], 1), d, c, k0)
    without = stack(np.stack([eps1, coat, eps2], 1), np.full((n, 1), 1e-3), c, k0)
    for x, y, name in zip(with_zero, without, with_zero._fields):
        np.testing.assert_allclose(x, y, rtol=1e-15, atol=1e-300, err_msg=name)
    # and a zero-thickness single layer on its own gives the bare interface
    only = stack(np.stack([eps1, layer, eps2], 1), np.zeros((n, 1)), c, k0)
    bare = interface(eps1, eps2, c)
    for x, y, name in zip(only, bare, only._fields):
        np.testing.assert_allclose(x, y, rtol=1e-15, atol=1e-300, err_msg=name)


def test_metal_substrate_lossless_coating():
    """Perfect conductor under lossless coatings: R = 1 to 1e-12, T = A = 0 (nothing absorbed)."""
    th = np.linspace(0, 90, 181) * DEG
    c = np.clip(np.cos(th), 0, 1)
    for eps_layers, d in [([2.25], [1e-3]), ([4.0, 1.5], [0.3e-3, 2e-3]), ([1.0], [5e-3])]:
        eps = np.array([1.0, *eps_layers, 99.0])  # exit eps ignored for a metal
        res = stack(eps, d, c, k0_of(95e9), substrate="metal")
        np.testing.assert_allclose(res.Rs, 1.0, atol=1e-12)
        np.testing.assert_allclose(res.Rp, 1.0, atol=1e-12)
        np.testing.assert_array_equal(res.Ts, 0.0)
        np.testing.assert_array_equal(res.Tp, 0.0)
        np.testing.assert_array_equal(res.ts, 0.0)
        np.testing.assert_allclose(res.As, 0.0, atol=1e-12)


def test_metal_substrate_bare_and_sign():
    """Bare metal (L = 2 or a zero-thickness coating): rs = -1, rp = +1 exactly (seed sec. 2.2.9)."""
    c = np.array([1.0, 0.5, 0.1])
    for eps, d in [(np.array([1.0, 5.0]), np.zeros(0)), (np.array([1.0, 3 + 1j, 5.0]), [0.0])]:
        res = stack(eps, d, c, k0_of(35e9), substrate="metal")
        np.testing.assert_allclose(res.rs, -1.0, atol=1e-15)
        np.testing.assert_allclose(res.rp, 1.0, atol=1e-15)


def test_metal_substrate_lossy_coating_against_good_conductor():
    """Lossy coating on metal: R + A = 1, A > 0; and equal to tmm with a very good conductor.

    tmm has no perfect conductor; eps = 1 + 1e14j (|n| = 1e7) deviates from it by ~1/|n| in r,
    hence 1e-5 on R.
    """
    th = np.linspace(0, 85, 18) * DEG
    eps = np.array([1.0, 1.61 + 0.121j, 3 + 0.5j, 1 + 1e14j])
    d = [0.8e-3, 0.2e-3]
    res = stack(eps, d, np.cos(th), k0_of(95e9), substrate="metal")
    assert np.all(res.As > 0) and np.all(res.Ap > 0)
    np.testing.assert_allclose(res.Rs + res.As, 1.0, atol=1e-14)
    np.testing.assert_allclose(res.Rp + res.Ap, 1.0, atol=1e-14)
    for i, t in enumerate(th):
        ref = tmm_ref(eps, d, t, 95e9)
        np.testing.assert_allclose(res.Rs[i], ref["s"]["R"], atol=1e-5)
        np.testing.assert_allclose(res.Rp[i], ref["p"]["R"], atol=1e-5)
        np.testing.assert_allclose(res.rs[i], ref["s"]["r"], atol=1e-5)
        np.testing.assert_allclose(res.rp[i], ref["p"]["r"], atol=1e-5)


def test_layer_at_its_critical_angle_is_regular():
    """A layer with q = 0 exactly (eps0 = 4, cos1 = 0.5: kpar2 = 3 = eps_layer) is finite.

    The Gamma form of Rouard's recursion is 0/0 there; the admittance form is regular. The value
    is the limit of tmm's from both sides (tmm itself divides by zero at the exact angle): the
    dependence on the angle is like sqrt(delta), so 1e-9 rad off gives ~1e-4.
    """
    eps = np.array([4.0, 3.0, 2.0 + 0.1j])
    d = [2e-3]
    f = 95e9
    res = stack(eps, d, np.array([0.5]), k0_of(f))
    for a in res:
        assert np.all(np.isfinite(a))
    th = np.arccos(0.5)
    for delta in (1e-9, -1e-9):
        ref = tmm_ref(eps, d, th + delta, f)
        np.testing.assert_allclose(res.Rs[0], ref["s"]["R"], atol=1e-3)
        np.testing.assert_allclose(res.Rp[0], ref["p"]["R"], atol=1e-3)
        np.testing.assert_allclose(res.Ts[0], ref["s"]["T"], atol=1e-3)


def test_grazing_degenerate_stacks_are_finite():
    """Exactly grazing incidence with layers/substrate of the incident permittivity (q = 0).

    R = 1, T = 0 unless everything is index-matched (then T = 1); never NaN.
    """
    k0 = k0_of(95e9)
    cases = [
        (np.array([1.0, 2.0, 1.0, 1.0]), [1e-3, 2e-3], "dielectric", 1.0),
        (np.array([1.0, 2.0, 1.0, 1.0]), [1e-3, 2e-3], "metal", 1.0),
        (np.array([1.0, 1.0, 1.0]), [1e-3], "dielectric", 0.0),
        (np.array([1.0, 1.0, 1.0]), [1e-3], "metal", 1.0),
        (np.array([2.25, 2.25, 2.25 + 1j]), [1e-3], "dielectric", 1.0),
    ]
    for eps, d, sub, r_power in cases:
        res = stack(eps, d, np.array([0.0]), k0, substrate=sub)
        for a in res:
            assert np.all(np.isfinite(a)), (eps, sub)
        np.testing.assert_array_equal(res.Rs, r_power)
        np.testing.assert_array_equal(res.Rp, r_power)
        np.testing.assert_array_equal(res.Ts + res.Rs + res.As, 1.0)


def test_broadcasting_as_the_integrator_calls_it():
    """eps (1, L) and thickness (1, L-2) broadcast against cos1 (N,); dtypes and shapes."""
    c = np.linspace(0, 1, 7)
    res = stack(np.array([[1.0, 2.25 + 0.1j, 5.0]]), np.array([[1e-3]]), c, k0_of(95e9))
    assert res.rs.shape == (7,) and res.rs.dtype == np.complex128 and res.Rs.dtype == np.float64
    ref = stack(np.tile([1.0, 2.25 + 0.1j, 5.0], (7, 1)), np.full((7, 1), 1e-3), c, k0_of(95e9))
    for x, y in zip(res, ref):
        np.testing.assert_array_equal(x, y)


def test_invalid_arguments():
    k0 = k0_of(95e9)
    c = np.array([1.0])
    with pytest.raises(ValueError):
        stack(np.array([1.0]), np.zeros(0), c, k0)
    with pytest.raises(ValueError):
        stack(np.array([1.0, 2.0, 3.0]), np.zeros(2), c, k0)
    with pytest.raises(ValueError):
        stack(np.array([1.0, 2.0, 3.0]), [-1e-3], c, k0)
    with pytest.raises(ValueError):
        stack(np.array([1.0, 2.0]), np.zeros(0), c, k0, substrate="blackbody")
    with pytest.raises(ValueError):
        stack(np.array([1.0, 2.0]), np.zeros(0), c, 0.0)
