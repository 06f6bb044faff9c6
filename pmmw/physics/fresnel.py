"""Fresnel coefficients of one smooth interface, vectorized over rays (Murakowski 2014 sec. 2.2.1-2.2.4).

Conventions (docs/ARCHITECTURE.md, docs/PHYSICS.md)
-----------------------------------------------------------
* Time dependence exp(-i w t); relative permittivity eps = eps' + i eps'' with eps'' >= 0 lossy.
* Every ray is a homogeneous wave (Murakowski 2014 sec. 2.2.4): in the incident medium 1 its direction
  is real and makes the real angle theta_1 with the surface normal, ``cos1 = cos(theta_1)``.
* Normal wave-vector components in units of k0: ``q1 = n1 cos1`` with ``n1 = sqrt(eps1)``
  (Im n1 >= 0), and in any other medium j ``q_j = sqrt(eps_j - kpar2)`` with
  ``kpar2 = eps1 sin^2(theta_1)`` (phase matching, Murakowski 2014 eq. 2.18-2.20), branch Im q_j >= 0
  (the wave decays away from the interface; evanescent under total internal reflection) when
  the incident medium is lossless. Under a lossy incident medium kpar2 is complex and Im q >= 0
  can pick a backward-running wave; the medium the wave is transmitted into then takes the
  outgoing root Re q >= 0 (Murakowski 2014 eq. 2.20: kt points the same way as ki), see `normal_component`.
* Admittances: ``Y = q`` for s, ``Y = q / eps`` for p. ``r = (Y1 - Y2)/(Y1 + Y2)`` and
  ``t = 1 + r``, evaluated as ``2 Y1/(Y1 + Y2)`` (no cancellation near r = -1): the E-field ratio
  for s and the H-field ratio for p (Murakowski 2014 eq. 2.24, 2.25), so that at normal incidence
  ``rp = -rs`` and a perfect conductor has ``rs = -1, rp = +1``. This pairs with ``p = k x s``
  (`pmmw.physics.jones`).
* Powers are fluxes through the interface: ``R = |r|^2``, ``T = |t|^2 Re(Y2)/Re(Y1)``
  (Murakowski 2014 eq. 2.34 with its Re{} factors). From a lossy medium 1 the homogeneous-wave picture can
  give ``R + T != 1``: above 1, R and T are scaled down to sum to 1 (Murakowski 2014 sec. 2.2.4); below
  1, the remainder ``A = 1 - R - T`` is absorbed (and emitted) at the surface.

The private helpers ``_incident``, ``_normal_below`` and ``_close`` are shared with
`pmmw.physics.multilayer`, so that a two-medium stack is bit for bit this interface.
"""

from __future__ import annotations

import cmath
import math
from typing import Literal, NamedTuple, overload

import numpy as np
import numpy.typing as npt

from pmmw.arrays import ComplexArray
from pmmw.jit import inline, njit

__all__ = ["Fresnel", "normal_component", "interface"]


# Tolerance on Im(eps - kpar2), in units of |eps| + |kpar2|, below which a negative imaginary part
# is taken as rounding noise of an exactly real argument (a few ulp of the subtraction).
_ROUNDING = 8.0 * np.finfo(np.float64).eps
# Below this, cos1 counts as exactly grazing: cos1^2 would underflow (and the angle is 1e-150 rad).
_TINY_COS = 1e-150


class Fresnel(NamedTuple):
    """Amplitude and power coefficients for s and p, arrays of the broadcast ray shape.

    Attributes
    ----------
    rs, rp : ndarray, complex128
        Amplitude reflection: E-field ratio for s, H-field ratio for p (Murakowski 2014 eq. 2.24).
    ts, tp : ndarray, complex128
        Amplitude transmission into the exit medium, same field as r (Murakowski 2014 eq. 2.25).
        Zero where nothing is transmitted (metal substrate, exactly grazing incidence).
    Rs, Rp : ndarray, float64
        Reflected power fraction, in [0, 1] (Murakowski 2014 eq. 2.34a, b).
    Ts, Tp : ndarray, float64
        Transmitted power fraction, in [0, 1] (Murakowski 2014 eq. 2.34c, d).
    As, Ap : ndarray, float64
        Absorbed power fraction ``1 - R - T`` (>= 0), emitted by the surface or coating
        (Murakowski 2014 eq. 2.36). ``R + T + A == 1`` to rounding.

    Notes
    -----
    After the thesis's renormalization (sec. 2.2.4) ``R`` may differ from ``|r|^2`` (and ``T``
    from the ``|t|^2`` flux): use the powers for weights and the amplitudes only for phases.
    """

    rs: np.ndarray
    rp: np.ndarray
    ts: np.ndarray
    tp: np.ndarray
    Rs: np.ndarray
    Rp: np.ndarray
    Ts: np.ndarray
    Tp: np.ndarray
    As: np.ndarray
    Ap: np.ndarray


def normal_component(eps: npt.ArrayLike, kpar2: npt.ArrayLike, branch: str = "decaying") -> ComplexArray:
    """Normal wave-vector component ``q = sqrt(eps - kpar2)`` on an explicit branch.

    Parameters
    ----------
    eps : array_like, complex128, broadcastable
        Relative permittivity of the medium [-].
    kpar2 : array_like, complex128, broadcastable
        Squared tangential wave-vector component in units of k0^2, ``(n1 sin theta_1)^2`` [-];
        complex when the incident medium is lossy.
    branch : {"decaying", "outgoing"}
        ``"decaying"``: Im q >= 0, and Re q >= 0 where Im q == 0 (the field decays away from the
        interface). ``"outgoing"``: Re q >= 0, and Im q >= 0 where Re q == 0 (the wave runs away
        from the interface: "kt pointing in the same direction as ki", Murakowski 2014 eq. 2.20).
        The two agree whenever Im(eps - kpar2) >= 0, which always holds for a lossless incident
        medium (kpar2 real) and a passive medium (Im eps >= 0); evanescent waves (eps real,
        kpar2 > eps) are ``+i sqrt(kpar2 - eps)`` on both. They differ only under a lossy
        incident medium (see ``interface``: a half-space the wave enters needs "outgoing").

    Returns
    -------
    ndarray, complex128, broadcast shape
        ``q`` [-]. No negative zeros.
    """
    if branch not in ("decaying", "outgoing"):
        raise ValueError(f"branch must be 'decaying' or 'outgoing', got {branch!r}")
    eps = np.asarray(eps, dtype=np.complex128)
    kpar2 = np.asarray(kpar2, dtype=np.complex128)
    return _root(eps - kpar2, _l1_norm(eps) + _l1_norm(kpar2), branch)


def _l1_norm(z):
    """|Re z| + |Im z| of arrays: a bound on |z| within a factor sqrt(2), as `_l1` of one value."""
    return np.abs(z.real) + np.abs(z.imag)


# The per-ray arithmetic below is compiled (numba, cached on disk; ``NUMBA_DISABLE_JIT=1`` runs it as
# Python): scalar functions, and loops over flat arrays that the vectorized helpers call.
_jit = njit()
_inline = inline()  # one-ray helpers called from compiled code: LLVM inlines them where it pays
# (`pmmw.jit.inline`; numba's own IR inlining re-typed them at every call site)


@_inline
def _l1(z):
    """|Re z| + |Im z|: bounds |z| (to a factor sqrt(2)) without the hypot behind abs()."""
    return abs(z.real) + abs(z.imag)


@_inline
def _sqrt1(z):
    """The principal square root of one complex value (Re >= 0; on the cut +i sqrt for Im z =
    +0.0, -i sqrt for -0.0, as cmath.sqrt): t = sqrt((|x| + |z|)/2) and y / 2t, each branch
    without cancellation. cmath.sqrt, which guards against overflow with hypot and scaling, is
    kept where that matters (|x|, |y| outside 1e-150..1e150, zero, inf or NaN); here it costs
    a fourth of that."""
    x, y = z.real, z.imag
    big = max(abs(x), abs(y))
    if not 1e-150 < big < 1e150:
        return cmath.sqrt(z)
    t = math.sqrt(0.5 * (abs(x) + math.sqrt(x * x + y * y)))
    if x >= 0.0:
        return complex(t, y / (2.0 * t))
    return complex(abs(y) / (2.0 * t), math.copysign(t, y))


@_inline
def _root1(z, scale, decaying):
    """``sqrt(z)`` of one value on a branch (see `normal_component`); ``scale`` bounds |terms| of z
    (their `_l1` norms)."""
    zi = z.imag
    # A slightly negative (or -0.0) Im z from rounding an exactly real argument would put z just
    # below the branch cut: under TIR the principal root would then be -i sqrt (growing), and
    # the "decaying" flip would make a propagating wave run backwards. Snap it to +0.0.
    if math.copysign(1.0, zi) < 0.0 and zi >= -_ROUNDING * scale:
        zi = 0.0
    q = _sqrt1(complex(z.real, zi))  # principal root: Re q >= 0, +i sqrt on the cut
    if decaying and q.imag < 0.0:
        # Im z < 0 remains only under a lossy incident medium (complex kpar2): take Im q >= 0
        # (Re q may then be negative).
        q = -q
    return complex(q.real + 0.0, q.imag + 0.0)  # no negative zeros


@_jit
def _root_loop(z, scale, decaying, out):
    for i in range(z.shape[0]):
        out[i] = _root1(z[i], scale[i], decaying)


def _root(z, scale, branch):
    """``sqrt(z)`` on ``branch`` (see `normal_component`); ``scale`` bounds |terms| of z [-]."""
    z, scale = np.broadcast_arrays(np.asarray(z, np.complex128), np.asarray(scale, np.float64))
    out = np.empty(z.shape, np.complex128)
    _root_loop(
        np.ascontiguousarray(z).ravel(), np.ascontiguousarray(scale).ravel(), branch == "decaying", out.reshape(-1)
    )
    return out


@_inline
def _incident1(eps1, cos1):
    """`_incident` of one ray: (q1, q1sq)."""
    c = min(max(cos1, 0.0), 1.0)
    if c < _TINY_COS:
        c = 0.0
    n1 = _root1(eps1, _l1(eps1), True)
    return n1 * c, eps1 * (c * c)


@_jit
def _incident_loop(eps1, cos1, q1, q1sq):
    for i in range(eps1.shape[0]):
        q1[i], q1sq[i] = _incident1(eps1[i], cos1[i])


def _incident(eps1, cos1):
    """Incident-side quantities of a homogeneous ray.

    Parameters
    ----------
    eps1 : ndarray, complex128
        Permittivity of the incident medium [-].
    cos1 : ndarray, float64
        Cosine of the (real) incidence angle [-]; clipped to [0, 1] against rounding, and
        flushed to exactly 0 below 1e-150 (where its square would underflow).

    Returns
    -------
    q1 : ndarray, complex128
        ``n1 cos1`` [-], n1 the principal root (Im n1 >= 0).
    q1sq : ndarray, complex128
        ``eps1 cos1^2`` [-]; other media have ``q_j^2 = (eps_j - eps1) + q1sq``.
    """
    eps1, cos1 = np.broadcast_arrays(np.asarray(eps1, np.complex128), np.asarray(cos1, np.float64))
    q1, q1sq = np.empty(eps1.shape, np.complex128), np.empty(eps1.shape, np.complex128)
    _incident_loop(
        np.ascontiguousarray(eps1).ravel(), np.ascontiguousarray(cos1).ravel(), q1.reshape(-1), q1sq.reshape(-1)
    )
    return q1, q1sq


@_inline
def _normal_below1(eps, eps1, q1sq, decaying):
    return _root1((eps - eps1) + q1sq, _l1(eps) + _l1(eps1), decaying)


def _normal_below(eps, eps1, q1sq, branch):
    """``q = sqrt(eps - eps1 sin^2 theta1)`` of a medium reached from medium 1.

    Written ``(eps - eps1) + eps1 cos^2`` rather than ``eps - kpar2``: near grazing incidence
    ``1 - cos^2`` rounds to 1 and a medium index-matched to medium 1 would get q = 0 instead of
    q1 (and reflect everything); this form gives it q1 (r = 0) to rounding.

    Parameters
    ----------
    eps, eps1, q1sq : ndarray, complex128, broadcastable
        Permittivity of the medium, of the incident medium, and ``eps1 cos1^2`` [-].
    branch : {"decaying", "outgoing"}

    Returns
    -------
    ndarray, complex128
    """
    eps, eps1, q1sq = np.broadcast_arrays(*(np.asarray(a, np.complex128) for a in (eps, eps1, q1sq)))
    return _root((eps - eps1) + q1sq, _l1_norm(eps) + _l1_norm(eps1), branch)


@_inline
def _yp1(q, eps):
    """Re(q / eps): the p admittance's real part (NaN for eps = 0)."""
    return (q * _reciprocal1(eps)).real if eps != 0.0 else np.nan


@_jit
def _yp_loop(q, eps, out):
    for i in range(q.shape[0]):
        out[i] = _yp1(q[i], eps[i])


def _admittance_p(q, eps):
    """``Re(q / eps)`` [-] of arrays (the exit medium's p admittance), as `interface` computes it."""
    q, eps = np.broadcast_arrays(np.asarray(q, np.complex128), np.asarray(eps, np.complex128))
    out = np.empty(q.shape)
    _yp_loop(np.ascontiguousarray(q).ravel(), np.ascontiguousarray(eps).ravel(), out.reshape(-1))
    return out


@_inline
def _powers1(r, t, y1, y2, opaque):
    """R, T, A of one polarization (Murakowski 2014 eq. 2.34, sec. 2.2.4), each in [0, 1] with
    ``R + T + A == 1`` to rounding; ``y1``, ``y2`` are Re of the incident and exit admittances."""
    R = r.real * r.real + r.imag * r.imag
    T = 0.0
    if not opaque:
        if y1 > 0.0:
            T = (t.real * t.real + t.imag * t.imag) * y2 / y1
        else:
            # Exactly grazing (Re Y1 = 0) the flux ratio is 0/0; its limit from a lossless
            # medium 1 is 1 - R (R = 1 unless the exit is index-matched, then everything continues).
            T = 1.0 - R
        # Re Y2 < 0 is possible only under a lossy incident medium (p: Re(q2/eps2) with q2 in
        # the fourth quadrant): the homogeneous-wave flux is then meaningless, count none.
        T = max(T, 0.0)
    total = R + T
    if total > 1.0:  # Murakowski 2014 sec. 2.2.4: "if it occurs, we scale R and T such that R + T = 1"
        R, T = R / total, T / total
    return R, T, max(1.0 - R - T, 0.0)


@_inline
def _amplitudes1(q1, y1eps, b, c, amp, opaque, metal_r):
    """r and t of one polarization from the input admittance C / B below (`_close`);
    ``y1eps`` is Y1 times the factor that makes Y1 B - C polynomial (1 for s, eps1 for p)."""
    num, den = q1 * b - y1eps * c, q1 * b + y1eps * c
    if den == 0.0:
        # the 0/0 of an exactly matched grazing configuration: its limit
        if opaque:
            return complex(metal_r, 0.0), 0j
        return 0j, (amp / b if b != 0.0 else 1.0 + 0j)
    if q1 == 0.0:
        # Exactly grazing (q1 = 0): r = -C/C, which complex division may round to 0.999...; the
        # limit is r = -1, t = 0 (R = 1, T = 0). Passive media give den != 0 everywhere else.
        return -1.0 + 0j, 0j
    inv = _reciprocal1(den)
    return num * inv, 2.0 * q1 * amp * inv


@_inline
def _reciprocal1(z):
    """``1 / z`` of a nonzero complex number, scaled by its larger part first so that neither
    |z|^2 overflows nor underflows (the (B, C) of thick stacks are scaled, not bounded): two real
    divisions, and one reciprocal serves both r and t (a complex division per quotient costs more)."""
    a, b = z.real, z.imag
    big = max(abs(a), abs(b))
    inv_big = 1.0 / big
    a, b = a * inv_big, b * inv_big
    k = inv_big / (a * a + b * b)
    return complex(a * k, -b * k)


@_inline
def _close1(q1, eps1, bs, cs, bp, cp, amp_s, amp_p, yexit_s, yexit_p, opaque):
    """`_close` of one ray: (rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap)."""
    # s: Y1 = q1; r = (Y1 B - C)/(Y1 B + C), t = 2 Y1 amp/(Y1 B + C) (Murakowski 2014 eq. 2.24a, 2.25a)
    rs, ts = _amplitudes1(q1, 1.0 + 0j, bs, cs, amp_s, opaque, -1.0)
    # p: Y1 = q1/eps1, numerator and denominator multiplied by eps1 (Murakowski 2014 eq. 2.24b, 2.25b)
    rp, tp = _amplitudes1(q1, eps1, bp, cp, amp_p, opaque, 1.0)
    Rs, Ts, As = _powers1(rs, ts, q1.real, yexit_s, opaque)
    y1p = _yp1(q1, eps1)
    Rp, Tp, Ap = _powers1(rp, tp, y1p, yexit_p, opaque)
    return rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap


@_jit
def _close_loop(q1, eps1, bs, cs, bp, cp, amp_s, amp_p, yexit_s, yexit_p, opaque, amp, power):
    for i in range(q1.shape[0]):
        rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap = _close1(
            q1[i], eps1[i], bs[i], cs[i], bp[i], cp[i], amp_s[i], amp_p[i], yexit_s[i], yexit_p[i], opaque
        )
        amp[i, 0], amp[i, 1], amp[i, 2], amp[i, 3] = rs, rp, ts, tp
        power[i, 0], power[i, 1], power[i, 2], power[i, 3], power[i, 4], power[i, 5] = Rs, Rp, Ts, Tp, As, Ap


def _as_fresnel(amp, power, shape):
    """`Fresnel` of the columns of (n, 4) amplitudes and (n, 6) powers, reshaped to ``shape``."""
    cols = [amp[:, k].reshape(shape) for k in range(4)] + [power[:, k].reshape(shape) for k in range(6)]
    return Fresnel(*cols)


def _close(q1, eps1, bs, cs, bp, cp, amp_s, amp_p, yexit_s, yexit_p, opaque):
    """Amplitudes and powers from the input admittance of what lies below the incident medium.

    The structure below the incident medium is described by the projective pair ``(B, C)``:
    tangential (U, V) fields at its top for a unit U at the exit, ``Y_in = C / B`` (Macleod's
    notation; U = E, V = H for s and U = H, V = E for p). For a bare interface ``(B, C) =
    (1, q2)`` for s and ``(eps2, q2)`` for p.

    Parameters
    ----------
    q1, eps1 : ndarray, complex128, shape (...)
        Incident-side normal component and permittivity [-].
    bs, cs, bp, cp : ndarray, complex128, shape (...)
        ``(B, C)`` for s and p, any common scale: ``Y_in = C / B`` with the admittances of the
        module docstring (``Y = q`` for s, ``Y = q/eps`` for p). ``B = 0`` is an infinite
        admittance (perfect conductor, s).
    amp_s, amp_p : ndarray, complex128, shape (...)
        Exit-side U amplitude in the units of (B, C), times the layers' propagation factors:
        ``t = 2 Y1 amp / (Y1 B + C)``. Zero for a metal substrate.
    yexit_s, yexit_p : ndarray, float64, shape (...)
        ``Re Y`` of the exit medium, ``Re q`` and ``Re(q/eps)`` [-].
    opaque : bool
        The exit is a perfect conductor: T = 0.

    Returns
    -------
    Fresnel
    """
    cplx = np.broadcast_arrays(*(np.asarray(a, np.complex128) for a in (q1, eps1, bs, cs, bp, cp, amp_s, amp_p)))
    shape = cplx[0].shape
    real = [np.broadcast_to(np.asarray(a, np.float64), shape) for a in (yexit_s, yexit_p)]
    flat = [np.ascontiguousarray(a).ravel() for a in (*cplx, *real)]
    n = flat[0].shape[0]
    amp, power = np.empty((n, 4), np.complex128), np.empty((n, 6))
    _close_loop(*flat, bool(opaque), amp, power)
    return _as_fresnel(amp, power, shape)


@_inline
def interface1(eps1, eps2, cos1):
    """`interface` of one ray, compiled: (rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2)."""
    one = 1.0 + 0j
    q1, q1sq = _incident1(eps1, cos1)
    q = _normal_below1(eps2, eps1, q1sq, False)  # outgoing branch, see `interface`
    rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap = _close1(q1, eps1, one, q, eps2, q, one, eps2, q.real, _yp1(q, eps2), False)
    return rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q


@_inline
def conductor1():
    """A perfect conductor's coefficients (one ray, any angle): rs = -1, rp = +1 (the E-field
    and H-field ratios, module docstring), nothing transmitted or absorbed; same tuple as
    `interface1` with q2 = NaN."""
    return (-1.0 + 0j, 1.0 + 0j, 0j, 0j, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, complex(np.nan, 0.0))


def perfect_conductor(n: int) -> Fresnel:
    """`conductor1` for n rays, as a `Fresnel` of arrays of shape (n,)."""
    return Fresnel(*(np.full(n, v) for v in conductor1()[:10]))


@_jit
def _interface_loop(eps1, eps2, cos1, amp, power, q2):
    for i in range(eps1.shape[0]):
        rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2[i] = interface1(eps1[i], eps2[i], cos1[i])
        amp[i, 0], amp[i, 1], amp[i, 2], amp[i, 3] = rs, rp, ts, tp
        power[i, 0], power[i, 1], power[i, 2], power[i, 3], power[i, 4], power[i, 5] = Rs, Rp, Ts, Tp, As, Ap


@overload
def interface(
    eps1: npt.ArrayLike, eps2: npt.ArrayLike, cos1: npt.ArrayLike, with_q2: Literal[False] = False
) -> Fresnel: ...


@overload
def interface(
    eps1: npt.ArrayLike, eps2: npt.ArrayLike, cos1: npt.ArrayLike, with_q2: Literal[True]
) -> tuple[Fresnel, ComplexArray]: ...


def interface(
    eps1: npt.ArrayLike, eps2: npt.ArrayLike, cos1: npt.ArrayLike, with_q2: bool = False
) -> Fresnel | tuple[Fresnel, ComplexArray]:
    """Fresnel coefficients of a smooth interface from medium 1 into medium 2.

    Parameters
    ----------
    eps1 : array_like, complex128, shape (N,) or broadcastable
        Relative permittivity of the incident medium [-] (may be lossy).
    eps2 : array_like, complex128, shape (N,) or broadcastable
        Relative permittivity of the far medium [-].
    cos1 : array_like, float64, shape (N,) or broadcastable
        Cosine of the real angle between the ray and the surface normal in medium 1, in [0, 1]
        (values a rounding error outside are clipped; below 1e-150 it is exactly grazing).

    Returns
    -------
    Fresnel
        Arrays of the broadcast shape (N,): ``rs, rp, ts, tp`` complex128, ``Rs, Rp, Ts, Tp, As,
        Ap`` float64. Total internal reflection gives ``R = 1, T = 0``; exactly grazing
        incidence (cos1 = 0) gives ``r = -1, R = 1, T = 0`` unless eps2 == eps1 (then
        ``r = 0, T = 1``); ``A > 0`` only for a lossy medium 1.
    q2 : ndarray, complex128
        Only with ``with_q2``: the exit medium's normal component (outgoing branch), which
        refraction reuses.
    """
    eps1, eps2, cos1 = np.broadcast_arrays(
        np.asarray(eps1, np.complex128), np.asarray(eps2, np.complex128), np.asarray(cos1, np.float64)
    )
    shape = eps1.shape
    n = eps1.size
    amp, power, q2 = np.empty((n, 4), np.complex128), np.empty((n, 6)), np.empty(n, np.complex128)
    # q2^2 = eps2 - eps1 sin^2 (Murakowski 2014 eq. 2.20), the transmitted wave runs forward. Under a
    # lossy incident medium the decaying root can run backwards (Re q2 < 0: negative flux, R > 1
    # and a jump to total reflection just off normal incidence); "outgoing" is continuous with
    # the lossless case. (B, C) of a bare half-space: Y_in = q2 (s), q2/eps2 (p); t = 1 + r
    # (Murakowski 2014 eq. 2.25).
    _interface_loop(*(np.ascontiguousarray(a).ravel() for a in (eps1, eps2, cos1)), amp, power, q2)
    coeffs = _as_fresnel(amp, power, shape)
    return (coeffs, q2.reshape(shape)) if with_q2 else coeffs
