"""Coherent thin-film stacks (coatings) without overflow, per ray and compiled (Murakowski 2014 2.2.3).

Method
------
Murakowski 2014's transfer matrices (eq. 2.27-2.31) multiply ``exp(-i k0 q d)`` factors that grow without
bound in thick lossy layers. Here the stack is reduced from the exit medium upward (Rouard's
method), carrying for each polarization the input admittance of everything below the current
interface, ``Y_in = C / B``, as the projective pair ``(B, C)`` of tangential fields (U, V)
(U = E, V = H for s; U = H, V = E for p, so that ``r`` and ``t`` are the E-field ratios for s and
the H-field ratios for p, as in `pmmw.physics.fresnel`).

Through layer j (admittance ``Y_j``, phase ``beta_j = k0 q_j d_j`` with Im beta_j >= 0, so
``E_j = exp(2 i beta_j)`` has ``|E_j| <= 1``)::

    [B]      [ (1 + E)/2        (1 - E)/(2 Y) ] [B]
    [C]  <-  [ Y (1 - E)/2      (1 + E)/2     ] [C]

which is ``exp(i beta_j)`` times the characteristic matrix ``[[cos b, -i sin b / Y],
[-i Y sin b, cos b]]``: every entry is bounded, nothing grows. This is the reflection recursion
``Gamma_j = (r + Gamma_{j+1} E)/(1 + r Gamma_{j+1} E)`` written for ``Y_in = Y (1 - Gamma E)/(1 +
Gamma E)`` instead of Gamma. The Gamma form divides 0/0 when a layer sits exactly at its critical
angle (``q_j = 0``, e.g. grazing incidence with a layer of the incident medium's permittivity);
here ``(1 - E)/(2 Y) = -i k0 d w phi1(2 i beta)`` (``w = 1`` for s, ``eps_j`` for p,
``phi1(z) = (e^z - 1)/z``) stays finite and a ``q_j = 0`` layer is regular. A zero-thickness layer
is the identity exactly.

At the top, ``r = (Y1 B - C)/(Y1 B + C)`` and ``t = 2 Y1 U_exit prod_j exp(i beta_j) / (Y1 B +
C)``; the product only decays. (B, C) are rescaled by exact powers of two at each layer, which
``t`` undoes, so no overflow is possible whatever the number of layers.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
import numpy.typing as npt

from pmmw.jit import inline, njit
from pmmw.physics.fresnel import Fresnel, _as_fresnel, _close1, _incident1, _l1, _normal_below1, _yp1

__all__ = ["stack", "stack1"]

_SUBSTRATES = ("dielectric", "metal")
# The stack is reduced per ray, compiled (numba, cached on disk): `stack` loops over rays, and the
# tracer's kernels call `stack1` for faces under coherent films.


@inline()
def _expm1(z):
    """``exp(z) - 1`` for complex z (Re z <= 0 here), accurate for small |z| (no cancellation):
    ``e^x cos y - 1 = expm1(x) cos y - 2 sin^2(y/2)``, ``Im = e^x sin y``."""
    x, y = z.real, z.imag
    s = math.sin(0.5 * y)
    return complex(math.expm1(x) * math.cos(y) - 2.0 * s * s, math.exp(x) * math.sin(y))


@inline()
def _phi1(z, em1):
    """``phi1(z) = (exp(z) - 1)/z`` (1 at z = 0) from ``em1 = expm1(z)``; |phi1| <= 1 for Re z <= 0.
    Small |z|: two terms of the series (error |z|^2/6 < 1e-16), which also avoids dividing tiny
    (subnormal) numbers."""
    if _l1(z) < 1e-8:  # (|z| <= |Re z| + |Im z|)
        return 1.0 + 0.5 * z
    return em1 / z


@inline()
def _rescale(b, c, e):
    """Scale (B, C) by a power of two (exact) so that their largest real or imaginary part is in
    [0.5, 1); add the exponent to e. (Any norm does: the scaling changes no mantissa; this one
    needs no hypot.)"""
    m = max(abs(b.real), abs(b.imag), abs(c.real), abs(c.imag))
    k = math.frexp(m if m > 0.0 else 1.0)[1]
    f = math.ldexp(1.0, -k)
    return b * f, c * f, e + k


@inline()
def _ldexp_c(z, e):
    """``z * 2**e`` for complex z and integer e, exact (no intermediate 2**e overflow)."""
    return complex(math.ldexp(z.real, e), math.ldexp(z.imag, e))


@njit()
def stack1(eps, thickness, cos1, k0, metal):
    """`stack` of one ray: ``eps`` (L,) complex128 from the incident medium to the exit medium,
    ``thickness`` (L-2,) [m], ``metal`` a perfect-conductor bottom. Returns (rs, rp, ts, tp, Rs,
    Rp, Ts, Tp, As, Ap)."""
    n_media = eps.shape[0]
    eps1 = eps[0]
    q1, q1sq = _incident1(eps1, cos1)
    # Murakowski 2014 eq. 2.20. Layers: decaying root, so that |exp(i beta)| <= 1 (a layer's matrix
    # is even in q_j, the sign does not change r or t). Exit half-space: outgoing root, as in
    # `interface` (they differ only under a lossy incident medium).
    # Bottom: (B, C) of the exit half-space, Y_in = C/B (Y = q for s, q/eps for p), and the
    # exit-side U amplitude in the same units.
    if metal:
        # perfect conductor: E_tan = 0, i.e. U = 0 for s (rs = -1) and V = 0 for p (rp = +1)
        bs, cs, bp, cp = 0j, 1.0 + 0j, 1.0 + 0j, 0j
        amp_s, amp_p = 0j, 0j
        ys_exit, yp_exit = 0.0, 0.0
    else:
        eps_exit = eps[n_media - 1]
        q_exit = _normal_below1(eps_exit, eps1, q1sq, False)
        bs, cs, bp, cp = 1.0 + 0j, q_exit, eps_exit, q_exit
        amp_s, amp_p = 1.0 + 0j, eps_exit
        ys_exit, yp_exit = q_exit.real, _yp1(q_exit, eps_exit)
    if n_media > 2:
        exps_s, exps_p = 0, 0
        phase = 0j  # sum of i beta_j; Re <= 0
        for j in range(n_media - 2, 0, -1):  # layers from the bottom up
            epsj, dj = eps[j], thickness[j - 1]
            qj = _normal_below1(epsj, eps1, q1sq, True)
            beta = k0 * qj * dj  # Im beta >= 0 since Im q >= 0 and d >= 0
            z = 2j * beta
            em1 = _expm1(z)  # E - 1, |E| <= 1
            half_1pe = 1.0 + 0.5 * em1  # (1 + E)/2
            # (1 - E)/(2 Y) = -i k0 d w phi1(2 i beta) with w = 1 (s), eps_j (p): finite at q = 0
            g_s = -1j * k0 * dj * _phi1(z, em1)
            g_p = g_s * epsj
            # Y (1 - E)/2 = -Y expm1/2 with Y = q (s), q/eps (p)
            h_s = -0.5 * qj * em1
            h_p = h_s / epsj
            bs, cs = half_1pe * bs + g_s * cs, h_s * bs + half_1pe * cs
            bp, cp = half_1pe * bp + g_p * cp, h_p * bp + half_1pe * cp
            bs, cs, exps_s = _rescale(bs, cs, exps_s)
            bp, cp, exps_p = _rescale(bp, cp, exps_p)
            phase += 1j * beta
        if not metal:
            # t carries prod exp(i beta_j) (|.| <= 1, only decays) and undoes the power-of-two
            # rescaling of (B, C) exactly (ldexp, no 2**e is formed): t = 2 Y1 amp / (Y1 B + C)
            # with (B, C) divided by 2**sum(e), so amp is divided by it too.
            prop = cmath.exp(phase)
            amp_s = _ldexp_c(amp_s * prop, -exps_s)
            amp_p = _ldexp_c(amp_p * prop, -exps_p)
    return _close1(q1, eps1, bs, cs, bp, cp, amp_s, amp_p, ys_exit, yp_exit, metal)


@njit()
def _stack_loop(eps, thickness, cos1, k0, metal, amp, power):
    for i in range(eps.shape[0]):
        rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap = stack1(eps[i], thickness[i], cos1[i], k0, metal)
        amp[i, 0], amp[i, 1], amp[i, 2], amp[i, 3] = rs, rp, ts, tp
        power[i, 0], power[i, 1], power[i, 2], power[i, 3], power[i, 4], power[i, 5] = Rs, Rp, Ts, Tp, As, Ap


def stack(
    eps: npt.ArrayLike, thickness: npt.ArrayLike, cos1: npt.ArrayLike, k0: float, substrate: str = "dielectric"
) -> Fresnel:
    """Reflection, transmission and absorption of a coherent multilayer stack.

    Parameters
    ----------
    eps : array_like, complex128, shape (N, L) or (L,) or broadcastable
        Relative permittivities [-] of the L >= 2 media, from the incident medium ``eps[..., 0]``
        through the layers to the exit medium (substrate) ``eps[..., -1]``.
    thickness : array_like, float64, shape (N, L-2) or (L-2,) or broadcastable
        Layer thicknesses [m], >= 0; layer j (1 <= j <= L-2) has ``thickness[..., j-1]``.
    cos1 : array_like, float64, shape (N,)
        Cosine of the real incidence angle in the incident medium, in [0, 1].
    k0 : float
        Vacuum wavenumber ``2 pi f / c`` [1/m], > 0.
    substrate : {"dielectric", "metal"}
        ``"metal"``: the bottom is a perfect conductor (``rs = -1, rp = +1`` there, T = 0) and
        ``eps[..., -1]`` is ignored.

    Returns
    -------
    Fresnel
        Arrays of shape (N,) (the broadcast ray shape): ``rs, rp`` the stack's amplitude
        reflection, ``ts, tp`` its amplitude transmission into the exit medium (E-field for s,
        H-field for p, as `pmmw.physics.fresnel.interface`), ``Rs, Rp, Ts, Tp`` powers with
        ``T = |t|^2 Re(Y_exit)/Re(Y_1)`` (Murakowski 2014 eq. 2.34 with eq. 2.31's r and t), and
        ``As, Ap = 1 - R - T``: the power absorbed in the layers, emitted at the coating
        temperature (Murakowski 2014 eq. 2.36). R + T > 1 (lossy incident medium) is renormalized as in
        `interface`. With L == 2 this is `interface` bit for bit.

    Raises
    ------
    ValueError
        Fewer than 2 media, a thickness array that does not match L, a negative thickness, a
        non-positive k0, or an unknown substrate.
    """
    if substrate not in _SUBSTRATES:
        raise ValueError(f"substrate must be one of {_SUBSTRATES}, got {substrate!r}")
    if not k0 > 0.0:
        raise ValueError(f"k0 must be > 0 [1/m], got {k0!r}")
    eps = np.asarray(eps, dtype=np.complex128)
    if eps.ndim < 1 or eps.shape[-1] < 2:
        raise ValueError(f"eps needs at least 2 media along its last axis, shape {eps.shape}")
    n_media = eps.shape[-1]
    thickness = np.asarray(thickness, dtype=np.float64)
    if thickness.ndim == 0 or thickness.shape[-1] != n_media - 2:
        raise ValueError(f"thickness must have {n_media - 2} layers along its last axis, shape {thickness.shape}")
    if np.any(thickness < 0.0):
        raise ValueError("layer thicknesses must be >= 0")
    cos1 = np.asarray(cos1, dtype=np.float64)
    shape = np.broadcast_shapes(eps.shape[:-1], thickness.shape[:-1], cos1.shape)
    eps = np.broadcast_to(eps, shape + (n_media,))
    thickness = np.broadcast_to(thickness, shape + (n_media - 2,))
    cos1 = np.broadcast_to(cos1, shape)
    metal = substrate == "metal"

    n = int(np.prod(shape, dtype=np.int64))
    amp, power = np.empty((n, 4), np.complex128), np.empty((n, 6))
    _stack_loop(
        np.ascontiguousarray(eps).reshape(n, n_media),
        np.ascontiguousarray(thickness).reshape(n, n_media - 2),
        np.ascontiguousarray(cos1).reshape(n),
        float(k0),
        metal,
        amp,
        power,
    )
    return _as_fresnel(amp, power, shape)
