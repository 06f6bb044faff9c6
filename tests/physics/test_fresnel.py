"""`pmmw.physics.fresnel` against textbook closed forms written here with angles.

The reference computes the refraction angle by Snell's law (complex for lossy media) and the
Fresnel formulas in terms of n and cos(theta) (Born & Wolf sec. 1.5, Hecht sec. 4.6); it shares no
code with the module, which works with normal wave-vector components and admittances.
"""

import numpy as np
import pytest

from pmmw.physics.fresnel import Fresnel, interface, normal_component

DEG = np.pi / 180.0


def textbook(eps1, eps2, theta):
    """Closed-form Fresnel amplitudes and (lossless medium 1) power coefficients.

    r_p is in the convention (n2 cos i - n1 cos t)/(n2 cos i + n1 cos t) (Born & Wolf's r_par,
    equal to the H-field ratio of Murakowski 2014 eq. 2.24b; at normal incidence r_p = -r_s). The branch
    of cos t is the physical one: the transmitted field must decay into medium 2,
    Im(n2 cos t) >= 0, and run forward when it does not decay.
    """
    n1, n2 = np.sqrt(complex(eps1)), np.sqrt(complex(eps2))
    ci = np.cos(theta)
    sin_t = n1 * np.sin(theta) / n2  # Snell, Murakowski 2014 eq. 2.17
    ct = np.sqrt(1.0 - sin_t**2 + 0j)
    kz = n2 * ct
    flip = (kz.imag < 0) | ((kz.imag == 0) & (kz.real < 0))
    ct = np.where(flip, -ct, ct)
    rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)
    rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct)
    ts = 2 * n1 * ci / (n1 * ci + n2 * ct)
    tp_e = 2 * n1 * ci / (n2 * ci + n1 * ct)  # E-field ratio
    # Transmitted flux (Born & Wolf 1.5 (21), lossy medium 2: Re(n2 cos t) and Re(conj(n2) cos t))
    Ts = abs(ts) ** 2 * (n2 * ct).real / (n1 * ci).real
    Tp = abs(tp_e) ** 2 * (np.conj(n2) * ct).real / (np.conj(n1) * ci).real
    return rs, rp, ts, tp_e, abs(rs) ** 2, abs(rp) ** 2, Ts, Tp


def one(eps1, eps2, theta):
    """interface() for scalar inputs, as 0-d results."""
    f = interface(np.array([eps1]), np.array([eps2]), np.array([np.cos(theta)]))
    return Fresnel(*(a[0] for a in f))


# ---------------------------------------------------------------------------------------------
# normal_component: branch
# ---------------------------------------------------------------------------------------------


def test_normal_component_branch():
    """Exact cases: propagating real, evanescent +i, -0.0 imaginary parts, lossy and flipped.

    Exact equality where the answer is an exactly representable root; 1e-15 otherwise (rounding).
    """
    q = normal_component(
        np.array([4.0, 4.0, complex(4.0, -0.0), complex(-1.0, -0.0), 2.25]), np.array([0.0, 5.0, 0.0, 0.0, 2.25])
    )
    np.testing.assert_array_equal(q, [2.0, 1j, 2.0, 1j, 0.0])
    assert not np.any(np.signbit(q.imag)) and not np.any(np.signbit(q.real))
    # lossy: principal root (first quadrant)
    q = normal_component(5.5 + 0.5j, 0.25)
    np.testing.assert_allclose(q, np.sqrt(5.25 + 0.5j), rtol=1e-15)
    # complex kpar2 (lossy incident medium) with Im(eps - kpar2) < 0: the two branches differ
    q = normal_component(2.0 + 0.0j, 1.0 + 0.5j)
    assert q.imag > 0 and q.real < 0
    np.testing.assert_allclose(q**2, 1.0 - 0.5j, rtol=1e-15)
    q_out = normal_component(2.0 + 0.0j, 1.0 + 0.5j, branch="outgoing")
    assert q_out.real > 0 and q_out.imag < 0
    assert q_out == -q
    # ... and agree everywhere else, including the TIR cut
    z_eps = np.array([4.0, 4.0, 5.5 + 0.5j, 1.0, complex(1.0, -0.0)])
    z_k = np.array([1.0, 5.0, 3.0, 1.0, 2.0])
    np.testing.assert_array_equal(normal_component(z_eps, z_k), normal_component(z_eps, z_k, "outgoing"))
    with pytest.raises(ValueError):
        normal_component(1.0, 0.5, branch="up")


def test_normal_component_rounding_snap():
    """A rounding-level negative Im(eps - kpar2) of a real argument keeps Re q >= 0 (no flip)."""
    q = normal_component(4.0 + 1e-17j, 1.0 + 2e-17j)  # Im diff -1e-17 ~ 1 ulp of 4
    assert q.real > 0 and q.imag == 0.0
    q = normal_component(1.0 + 1e-17j, 4.0 + 2e-17j)  # evanescent side
    assert q.imag > 0


# ---------------------------------------------------------------------------------------------
# interface against the textbook
# ---------------------------------------------------------------------------------------------

ANGLES = [0.0, 10.0, 30.0, 45.0, 60.0, 75.0, 80.0, 85.0, 89.0, 89.99]


@pytest.mark.parametrize("eps2", [2.25, 5.5 + 0.5j, 6.65 + 9.4j, 1.61 + 0.121j, 80.0 + 1e3j])
@pytest.mark.parametrize("theta", ANGLES)
def test_against_textbook_from_air(eps2, theta):
    """Amplitudes and powers, air to lossless and lossy media: rtol 1e-12, atol 1e-14.

    Both are exact formulas in double precision; they differ only by rounding (a few 1e-16,
    amplified at most ~100x near grazing where q1 = cos theta is small).
    """
    ref = textbook(1.0, eps2, theta * DEG)
    f = one(1.0, eps2, theta * DEG)
    n2 = np.sqrt(complex(eps2))
    np.testing.assert_allclose(f.rs, ref[0], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(f.rp, ref[1], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(f.ts, ref[2], rtol=1e-12, atol=1e-14)
    # our tp is the H-field ratio: H = n E (vacuum units), so tp_H = tp_E n2 / n1
    np.testing.assert_allclose(f.tp, ref[3] * n2, rtol=1e-12, atol=1e-14)
    for got, want in zip((f.Rs, f.Rp, f.Ts, f.Tp), ref[4:]):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-14)
    # from a lossless medium nothing is absorbed at the surface (up to rounding of 1 - R - T)
    assert f.As < 1e-15 and f.Ap < 1e-15


@pytest.mark.parametrize("theta", [0.0, 20.0, 40.0, 41.0, 45.0, 60.0, 89.0])
def test_against_textbook_from_glass(theta):
    """Glass (2.25) to air and to a lossy medium, below and beyond the critical angle (41.8 deg).

    rtol 1e-12 / atol 1e-14: exact formulas, rounding only.
    """
    for eps2 in (1.0, 1.5 + 0.2j):
        ref = textbook(2.25, eps2, theta * DEG)
        f = one(2.25, eps2, theta * DEG)
        np.testing.assert_allclose([f.rs, f.rp, f.ts], ref[:3], rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(f.tp, ref[3] * np.sqrt(eps2 + 0j) / 1.5, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose([f.Rs, f.Rp, f.Ts, f.Tp], ref[4:], rtol=1e-12, atol=1e-14)


def test_concrete_95ghz_numbers():
    """PHYSICS.md's independently computed concrete (5.5+0.5j) Rs/Rp, quoted to 4 decimals: 1e-4."""
    table = {
        0: (0.1629, 0.1629),
        30: (0.2051, 0.1238),
        60: (0.3945, 0.0139),
        80: (0.7221, 0.1448),
        89: (0.9678, 0.8343),
    }
    th = np.array(sorted(table)) * DEG
    f = interface(np.ones(th.size), np.full(th.size, 5.5 + 0.5j), np.cos(th))
    want = np.array([table[k] for k in sorted(table)])
    np.testing.assert_allclose(f.Rs, want[:, 0], atol=1e-4)
    np.testing.assert_allclose(f.Rp, want[:, 1], atol=1e-4)
    np.testing.assert_allclose(f.Rs + f.Ts, 1.0, atol=1e-14)
    np.testing.assert_allclose(f.Rp + f.Tp, 1.0, atol=1e-14)


@pytest.mark.parametrize("eps1, eps2", [(1.0, 2.25), (1.0, 5.5), (2.25, 1.0), (1.0, 80.0), (3.0, 1.2)])
def test_brewster(eps1, eps2):
    """At arctan(sqrt(eps2/eps1)), lossless: Rp < 1e-20 (rp vanishes to rounding, ~1e-16)."""
    th = np.arctan(np.sqrt(eps2 / eps1))
    f = one(eps1, eps2, th)
    assert f.Rp < 1e-20
    assert f.Rs > 1e-3


def test_lossless_energy_conservation_all_angles():
    """R + T = 1 to 1e-14 for lossless media at every angle, 0 to 90 deg including 89.99 deg.

    R and T are each rounded to ~1e-16; the sum of two such terms is exact to a few ulp.
    """
    th = np.concatenate([np.linspace(0, 90, 1801), [89.99, 89.999999]]) * DEG
    cos1 = np.clip(np.cos(th), 0, 1)
    for eps1, eps2 in [(1.0, 2.25), (2.25, 1.0), (1.0, 1e7), (4.0, 3.9), (1.0, 1.0)]:
        f = interface(np.full(th.size, eps1), np.full(th.size, eps2), cos1)
        np.testing.assert_allclose(f.Rs + f.Ts, 1.0, rtol=0, atol=1e-14)
        np.testing.assert_allclose(f.Rp + f.Tp, 1.0, rtol=0, atol=1e-14)
        np.testing.assert_allclose(f.As, 0.0, atol=1e-14)
        np.testing.assert_allclose(f.Ap, 0.0, atol=1e-14)


def test_lossy_medium2_energy_conservation():
    """From a lossless medium into a lossy one the flux is conserved too: R + T = 1 to 1e-14.

    This checks the Re{} factors of seed eq. 2.34 (T for p uses Re(q/eps), not Re(q)/Re(eps)).
    """
    th = np.linspace(0, 89.99, 500) * DEG
    for eps2 in [5.5 + 0.5j, 6.65 + 9.4j, 1 + 1e7j, 3 + 300j]:
        f = interface(np.ones(th.size), np.full(th.size, eps2), np.cos(th))
        np.testing.assert_allclose(f.Rs + f.Ts, 1.0, atol=1e-14)
        np.testing.assert_allclose(f.Rp + f.Tp, 1.0, atol=1e-14)


def test_total_internal_reflection():
    """Glass (2.25) to air beyond the critical angle 41.81 deg: R = 1 to 1e-15, T = 0 exactly.

    The transmitted q2 is purely imaginary (evanescent) so Re q2 = 0 and T is exactly 0.
    """
    th = np.array([41.9, 45.0, 60.0, 80.0, 89.9, 90.0]) * DEG
    f = interface(np.full(th.size, 2.25), np.ones(th.size), np.clip(np.cos(th), 0, 1))
    np.testing.assert_allclose(f.Rs, 1.0, atol=1e-15)
    np.testing.assert_allclose(f.Rp, 1.0, atol=1e-15)
    np.testing.assert_array_equal(f.Ts, 0.0)
    np.testing.assert_array_equal(f.Tp, 0.0)
    np.testing.assert_allclose(np.abs(f.rs), 1.0, atol=1e-15)


def test_normal_incidence_rp_is_minus_rs():
    """rp = -rs at normal incidence (seed eq. 2.24 with the H-field ratio), to 1e-15 (rounding)."""
    eps2 = np.array([2.25, 5.5 + 0.5j, 6.65 + 9.4j, 1 + 1e7j, 0.5 + 0j])
    f = interface(np.ones(eps2.size), eps2, np.ones(eps2.size))
    np.testing.assert_allclose(f.rp, -f.rs, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(f.Rp, f.Rs, rtol=1e-15)


def test_perfect_conductor_limit():
    """eps2 = 1 + 1e7j: rs -> -1, rp -> +1 within 1e-3 up to 45 deg.

    The deviation is first order in 1/n2: |1 + rs| ~ 2 cos/|n2|, |1 - rp| ~ 2/(|n2| cos) (~9e-4
    at 45 deg with |n2| = 3162); beyond, rp is checked against that bound. At grazing rp turns to
    -1 for any finite conductivity (the metal and grazing limits do not commute), one reason the
    integrator treats metals apart.
    """
    th = np.array([0.0, 20.0, 45.0]) * DEG
    f = interface(np.ones(th.size), np.full(th.size, 1 + 1e7j), np.cos(th))
    np.testing.assert_allclose(f.rs, -1.0, atol=1e-3)
    np.testing.assert_allclose(f.rp, 1.0, atol=1e-3)
    th = np.linspace(0, 85, 18) * DEG
    f = interface(np.ones(th.size), np.full(th.size, 1 + 1e7j), np.cos(th))
    n2 = abs(np.sqrt(1 + 1e7j))
    assert np.all(np.abs(1 + f.rs) <= 1.1 * 2 * np.cos(th) / n2)
    assert np.all(np.abs(1 - f.rp) <= 1.1 * 2 / (n2 * np.cos(th)))


def test_grazing_is_finite():
    """cos1 = 0 exactly: R = 1, T = 0, r = -1 (no NaN), and an index-matched exit passes all."""
    eps1 = np.array([1.0, 2.25, 5.5 + 0.5j, 1.0, 2.25, 5 + 1j])
    eps2 = np.array([2.25, 1.0, 1.0, 1.0, 2.25, 5 + 1j])
    f = interface(eps1, eps2, np.zeros(6))
    for a in f:
        assert np.all(np.isfinite(a))
    np.testing.assert_array_equal(f.Rs, [1, 1, 1, 0, 0, 0])
    np.testing.assert_array_equal(f.Ts, [0, 0, 0, 1, 1, 1])
    np.testing.assert_array_equal(f.rs[:3], -1.0)
    np.testing.assert_array_equal(f.rp[:3], -1.0)
    np.testing.assert_array_equal(f.As + f.Rs + f.Ts, 1.0)


def test_index_matched_near_grazing_passes_everything():
    """eps2 == eps1 at cos1 = 1e-10 ... 1e-300: r = 0, T = 1 to 1e-15.

    With q2 = sqrt(eps2 - eps1 (1 - cos1^2)) the 1 - cos1^2 rounds to 1, q2 = 0 and the matched
    interface would reflect totally; pmmw forms q2^2 = (eps2 - eps1) + eps1 cos1^2 instead.
    """
    c = np.array([1e-5, 1e-10, 1e-100, 1e-200, 1e-300, 5e-324])
    for eps in (1.0, 2.25, 5.5 + 0.5j):
        f = interface(np.full(c.size, eps), np.full(c.size, eps), c)
        np.testing.assert_allclose(np.abs(f.rs), 0.0, atol=1e-15)
        np.testing.assert_allclose(np.abs(f.rp), 0.0, atol=1e-15)
        np.testing.assert_allclose(f.Ts, 1.0, atol=1e-15)
        np.testing.assert_allclose(f.Tp, 1.0, atol=1e-15)


def test_lossy_incident_medium_bookkeeping():
    """From a lossy medium: the thesis's rule (sec. 2.2.4) applied to the raw flux ratios.

    The raw powers |r|^2 and |t|^2 Re(q2)/Re(q1) are recomputed here from textbook amplitudes with
    q2 the forward-running root (principal square root, seed eq. 2.20). Where they sum above 1
    the result is rescaled to R + T = 1 (A = 0); below 1 they are returned as they are and
    A = 1 - R - T > 0. rtol 1e-13: rounding of a few operations, near grazing amplified.
    """
    th = np.linspace(0, 90, 901) * DEG
    c = np.clip(np.cos(th), 0, 1)
    seen_over = seen_under = False
    for eps1, eps2 in [(5 + 3j, 1.0), (1 + 2j, 1.0), (2 + 0.5j, 6 + 0.1j), (6.65 + 9.4j, 1.61 + 0.121j)]:
        f = interface(np.full(th.size, eps1), np.full(th.size, eps2), c)
        n1 = np.sqrt(eps1)
        q1 = n1 * c
        q2 = np.sqrt(eps2 - eps1 * np.sin(th) ** 2 + 0j)
        for r, t, y1, y2, R, T, A in (
            ((q1 - q2) / (q1 + q2), 2 * q1 / (q1 + q2), q1, q2, f.Rs, f.Ts, f.As),
            (
                (eps2 * q1 - eps1 * q2) / (eps2 * q1 + eps1 * q2),
                2 * eps2 * q1 / (eps2 * q1 + eps1 * q2),
                q1 / eps1,
                q2 / eps2,
                f.Rp,
                f.Tp,
                f.Ap,
            ),
        ):
            ok = c > 0
            raw_R = np.where(ok, np.abs(r) ** 2, 1.0)
            raw_T = np.where(ok, np.abs(t) ** 2 * y2.real / np.where(ok, y1.real, 1), 0.0)
            raw_T = np.maximum(raw_T, 0.0)
            tot = raw_R + raw_T
            over = tot > 1
            seen_over |= bool(np.any(tot > 1 + 1e-3))
            seen_under |= bool(np.any(tot < 1 - 1e-3))
            np.testing.assert_allclose(R, np.where(over, raw_R / tot, raw_R), rtol=1e-13, atol=1e-15)
            np.testing.assert_allclose(T, np.where(over, raw_T / tot, raw_T), rtol=1e-13, atol=1e-15)
            np.testing.assert_allclose(A, np.where(over, 0.0, 1 - tot), atol=1e-14)
            assert np.all((R >= 0) & (R <= 1) & (T >= 0) & (T <= 1) & (A >= 0) & (A <= 1))
            np.testing.assert_allclose(R + T + A, 1.0, rtol=0, atol=1e-15)
    assert seen_over and seen_under, "both branches of the thesis's rule must be exercised"


def test_lossy_incident_medium_continuous_off_normal():
    """Leaving a lossy body into air, R is continuous at normal incidence (to 1e-6 at 0.01 deg).

    With the decaying root for the transmitted wave, Im(1 - eps1 sin^2) < 0 flips q2 backwards
    at any angle > 0 and the surface would reflect totally; the outgoing root does not.
    """
    th = np.array([0.0, 0.01, 0.1]) * DEG
    f = interface(np.full(3, 5 + 3j), np.ones(3), np.cos(th))
    np.testing.assert_allclose(f.Rs, f.Rs[0], atol=1e-5)
    np.testing.assert_allclose(f.Rs[1], f.Rs[0], atol=1e-6)
    assert f.Ts[2] > 0.7


def test_broadcasting_and_dtypes():
    """Scalars broadcast against (N,) rays; complex128 amplitudes and float64 powers."""
    f = interface(1.0, np.array([2.25, 5.5 + 0.5j]), np.array([[1.0], [0.5]]))
    assert f.rs.shape == (2, 2) and f.rs.dtype == np.complex128 and f.Rs.dtype == np.float64


def test_compiled_square_root_is_the_principal_root():
    """The interface's complex square root (`fresnel._sqrt1`, written without hypot) against
    cmath.sqrt, the reference: to 4 ulp (relative 1e-15) on 20000 random values over 60 decades
    of magnitude and all four quadrants, and exactly (signs of zeros included) on the branch cut
    and the special values it hands to cmath (zero, 1e-300, 1e300, inf, NaN)."""
    import cmath

    from pmmw.physics.fresnel import _sqrt1

    rng = np.random.default_rng(5)
    mag = 10.0 ** rng.uniform(-30, 30, (2, 20000))
    z = rng.choice([-1.0, 1.0], (2, 20000)) * mag
    for x, y in zip(*z):
        got, want = _sqrt1(complex(x, y)), cmath.sqrt(complex(x, y))
        assert abs(got - want) <= 1e-15 * abs(want), (x, y, got, want)
    special = [
        complex(-4.0, 0.0),
        complex(-4.0, -0.0),
        complex(4.0, -0.0),
        complex(0.0, 0.0),
        complex(-0.0, -0.0),
        complex(-1e-300, 0.0),
        complex(1e300, -1e300),
        complex(np.inf, 1.0),
        complex(-np.inf, 1.0),
        complex(np.nan, 0.0),
        complex(3.0, -1e-170),
    ]
    for v in special:
        got, want = _sqrt1(v), cmath.sqrt(v)
        for a, b in ((got.real, want.real), (got.imag, want.imag)):
            assert (
                (np.isnan(a) and np.isnan(b))
                or (a == b and np.copysign(1, a) == np.copysign(1, b))
                or abs(a - b) <= 1e-15 * abs(want)
            ), (v, got, want)


def test_compiled_reciprocal_is_safe_over_the_whole_range():
    """`fresnel._reciprocal1`, the one division behind each pair of r and t (scaled by the larger
    part first, for the (B, C) of thick stacks): against Python's complex division, the
    reference, to 2 ulp (relative 4e-16) on 20000 random values over 600 decades, where
    |z|^2 of an unscaled formula would overflow or underflow for a third of them."""
    from pmmw.physics.fresnel import _reciprocal1

    rng = np.random.default_rng(11)
    mag = 10.0 ** rng.uniform(-300, 300, (2, 20000))
    z = rng.choice([-1.0, 1.0], (2, 20000)) * mag
    for x, y in zip(*z):
        v = complex(x, y)
        got, want = _reciprocal1(v), 1.0 / v
        assert abs(got - want) <= 4e-16 * abs(want), (v, got, want)
