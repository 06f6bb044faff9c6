"""Property tests of `fresnel.interface` and `multilayer.stack` over extreme inputs (hypothesis).

Ranges: |eps| from 1 to 1e7 with eps'' from 0 to 1e7, incident medium lossless or lossy, cos1 in
[0, 1] including exactly 0 and 1, layers 0 to 1 m thick, 30-300 GHz, dielectric or metal
substrate, and media repeated on purpose (index-matched and exactly-critical layers at grazing).
Whatever the input: every output finite, every power in [0, 1] and R + T + A = 1. The tolerance
1e-12 allows for rounding only: the powers are built to satisfy these exactly up to a few ulp.
"""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pmmw.physics.fresnel import interface
from pmmw.physics.multilayer import stack

C0 = 299_792_458.0
TOL = 1e-12
SETTINGS = settings(max_examples=300, deadline=None)

real_part = st.one_of(st.just(1.0), st.floats(0.0, 7.0).map(lambda e: 10.0**e))
loss = st.one_of(st.just(0.0), st.just(1e7), st.floats(-6.0, 7.0).map(lambda e: 10.0**e))
lossy_eps = st.builds(complex, real_part, loss)
lossless_eps = st.builds(complex, real_part, st.just(0.0))
# exact 0 and 1, uniform, and log-spaced down to 1e-300 (near-grazing, subnormal squares)
cosines = st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 1.0), st.floats(-300, -1).map(lambda e: 10.0**e))
thicknesses = st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 1.0), st.floats(-9, 0).map(lambda e: 10.0**e))
freqs = st.floats(30e9, 300e9)


def check(res, metal=False):
    """Finite outputs, powers in [0, 1], R + T + A = 1 (to TOL)."""
    for name, a in zip(res._fields, res):
        assert np.all(np.isfinite(a)), f"{name} not finite: {a}"
    for R, T, A in ((res.Rs, res.Ts, res.As), (res.Rp, res.Tp, res.Ap)):
        for a in (R, T, A):
            assert np.all((a >= -TOL) & (a <= 1 + TOL)), (R, T, A)
        np.testing.assert_allclose(R + T + A, 1.0, rtol=0, atol=TOL)
        if metal:
            np.testing.assert_array_equal(T, 0.0)


@st.composite
def rays_and_stack(draw):
    """A stack of L media shared by 1-5 rays; media sometimes repeat the incident one."""
    n_media = draw(st.integers(2, 5))
    n_rays = draw(st.integers(1, 5))
    lossy_incident = draw(st.booleans())
    eps = np.empty((n_rays, n_media), complex)
    for i in range(n_rays):
        eps[i, 0] = draw(lossy_eps if lossy_incident else lossless_eps)
        for j in range(1, n_media):
            eps[i, j] = draw(st.one_of(lossy_eps, st.just(eps[i, 0]), st.just(eps[i, j - 1])))
    d = np.array([[draw(thicknesses) for _ in range(n_media - 2)] for _ in range(n_rays)])
    d = d.reshape(n_rays, n_media - 2)
    cos1 = np.array([draw(cosines) for _ in range(n_rays)])
    return eps, d, cos1


@SETTINGS
@given(st.lists(st.tuples(st.one_of(lossy_eps, lossless_eps), lossy_eps, cosines), min_size=1, max_size=8))
def test_interface_is_bounded(rays):
    """fresnel.interface over the whole range, lossy or lossless incident medium."""
    eps1, eps2, c = (np.array(x) for x in zip(*rays))
    check(interface(eps1, eps2, c.astype(float)))


@SETTINGS
@given(rays_and_stack(), freqs, st.sampled_from(["dielectric", "metal"]))
def test_stack_is_bounded(case, f, substrate):
    """multilayer.stack over the whole range, up to three layers, either substrate."""
    eps, d, cos1 = case
    res = stack(eps, d, cos1, 2 * np.pi * f / C0, substrate=substrate)
    check(res, metal=substrate == "metal")


@SETTINGS
@given(rays_and_stack(), freqs)
def test_lossless_stack_conserves_energy(case, f):
    """All media lossless (and the incident one): nothing absorbed, R + T = 1 to 1e-10.

    The extra slack over TOL covers rounding amplified near guided-wave resonances of thick
    lossless layers with permittivity contrasts up to 1e7 (6e-14 is the worst seen in 1.2 million
    random rays).
    """
    eps, d, cos1 = case
    eps = eps.real + 0j
    res = stack(eps, d, cos1, 2 * np.pi * f / C0)
    check(res)
    np.testing.assert_allclose(res.As, 0.0, atol=1e-10)
    np.testing.assert_allclose(res.Ap, 0.0, atol=1e-10)
