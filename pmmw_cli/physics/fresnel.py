"""Fresnel coefficients of one smooth interface, vectorized over rays (Murakowski 2014 sec. 2.2.1-2.2.4).

Conventions (docs/ARCHITECTURE.md, shared/spec/PHYSICS.md)
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
  (`pmmw_cli.physics.jones`).
* Powers are fluxes through the interface: ``R = |r|^2``, ``T = |t|^2 Re(Y2)/Re(Y1)``
  (Murakowski 2014 eq. 2.34 with its Re{} factors). From a lossy medium 1 the homogeneous-wave picture can
  give ``R + T != 1``: above 1, R and T are scaled down to sum to 1 (Murakowski 2014 sec. 2.2.4); below
  1, the remainder ``A = 1 - R - T`` is absorbed (and emitted) at the surface.

The private helpers ``_incident``, ``_normal_below`` and ``_close`` are shared with
`pmmw_cli.physics.multilayer`, so that a two-medium stack is bit for bit this interface.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

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


def normal_component(eps, kpar2, branch="decaying"):
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
    return _root(eps - kpar2, np.abs(eps) + np.abs(kpar2), branch)


def _root(z, scale, branch):
    """``sqrt(z)`` on ``branch`` (see `normal_component`); ``scale`` bounds |terms| of z [-]."""
    # A slightly negative (or -0.0) Im z from rounding an exactly real argument would put z just
    # below the branch cut: under TIR the principal root would then be -i sqrt (growing), and
    # the "decaying" flip would make a propagating wave run backwards. Snap it to +0.0.
    noise = np.signbit(z.imag) & (z.imag >= -_ROUNDING * scale)
    zz = np.empty_like(z)
    zz.real = z.real
    zz.imag = np.where(noise, 0.0, z.imag)
    q = np.sqrt(zz)  # principal root: Re q >= 0, Im q has the sign of Im zz, +i sqrt on the cut
    if branch == "decaying":
        # Im zz < 0 remains only under a lossy incident medium (complex kpar2): take Im q >= 0
        # (Re q may then be negative).
        q = np.where(q.imag < 0.0, -q, q)
    return q + 0.0  # turns -0.0 parts into +0.0


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
    c = np.clip(np.asarray(cos1, dtype=np.float64), 0.0, 1.0)
    c = np.where(c < _TINY_COS, 0.0, c)
    n1 = normal_component(eps1, 0.0)
    return n1 * c, eps1 * (c * c)


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
    return _root((eps - eps1) + q1sq, np.abs(eps) + np.abs(eps1), branch)


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
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # s: Y1 = q1; r = (Y1 B - C)/(Y1 B + C), t = 2 Y1 amp/(Y1 B + C) (Murakowski 2014 eq. 2.24a, 2.25a)
        num_s, den_s = q1 * bs - cs, q1 * bs + cs
        # p: Y1 = q1/eps1, numerator and denominator multiplied by eps1 (Murakowski 2014 eq. 2.24b, 2.25b)
        num_p, den_p = q1 * bp - eps1 * cp, q1 * bp + eps1 * cp
        rs, ts = num_s / den_s, 2.0 * q1 * amp_s / den_s
        rp, tp = num_p / den_p, 2.0 * q1 * amp_p / den_p
    # Exactly grazing (q1 = 0): r = -C/C, which complex division may round to 0.999...; the
    # limit is r = -1, t = 0 (R = 1, T = 0), unless den = 0 too: Y_in = 0, i.e. everything below
    # is index-matched to the incident medium at grazing (or, for p only, a metal under such
    # layers). Passive media give den != 0 everywhere else.
    flat = q1 == 0.0
    rs, ts = _grazing(flat & (den_s != 0.0), rs, ts)
    rp, tp = _grazing(flat & (den_p != 0.0), rp, tp)
    rs, ts = _degenerate(den_s, rs, ts, amp_s, bs, opaque, metal_r=-1.0)
    rp, tp = _degenerate(den_p, rp, tp, amp_p, bp, opaque, metal_r=1.0)
    Rs, Ts, As = _powers(rs, ts, q1.real, yexit_s, opaque)
    with np.errstate(divide="ignore", invalid="ignore"):
        y1p = (q1 / eps1).real
    Rp, Tp, Ap = _powers(rp, tp, y1p, yexit_p, opaque)
    return Fresnel(rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap)


def _grazing(mask, r, t):
    """r = -1, t = 0 where ``mask`` (exactly grazing incidence, not index-matched)."""
    if not np.any(mask):
        return r, t
    return np.where(mask, -1.0 + 0j, r), np.where(mask, 0j, t)


def _degenerate(den, r, t, amp, b, opaque, metal_r):
    """Replace the 0/0 of an exactly matched grazing configuration by its limit."""
    bad = den == 0.0
    if not np.any(bad):
        return r, t
    with np.errstate(divide="ignore", invalid="ignore"):
        t_matched = np.where(b != 0.0, amp / np.where(b != 0.0, b, 1.0), 1.0)
    r = np.where(bad, metal_r if opaque else 0.0, r)
    t = np.where(bad, 0.0 if opaque else t_matched, t)
    return r + 0j, t + 0j


def _powers(r, t, y1, y2, opaque):
    """R, T, A for one polarization (Murakowski 2014 eq. 2.34, sec. 2.2.4).

    Parameters
    ----------
    r, t : ndarray, complex128
        Amplitudes (same field quantity, see `Fresnel`).
    y1, y2 : ndarray, float64
        Re of the incident and exit admittances [-].
    opaque : bool
        Nothing is transmitted (perfect-conductor exit).

    Returns
    -------
    R, T, A : ndarray, float64
        Each in [0, 1], ``R + T + A == 1`` to rounding.
    """
    R = r.real**2 + r.imag**2
    if opaque:
        T = np.zeros_like(R)
    else:
        grazing = ~(y1 > 0.0)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            T = (t.real**2 + t.imag**2) * y2 / np.where(grazing, 1.0, y1)
        # Exactly grazing (Re Y1 = 0) the flux ratio is 0/0; its limit from a lossless medium
        # 1 is 1 - R (R = 1 unless the exit is index-matched, then everything continues).
        T = np.where(grazing, 1.0 - R, T)
        # Re Y2 < 0 is possible only under a lossy incident medium (p: Re(q2/eps2) with q2 in
        # the fourth quadrant): the homogeneous-wave flux is then meaningless, count none.
        T = np.maximum(T, 0.0)
    total = R + T
    over = total > 1.0
    # Murakowski 2014 sec. 2.2.4: "if it occurs, we scale R and T such that R + T = 1"
    scale = np.where(over, total, 1.0)
    R, T = R / scale, T / scale
    A = np.maximum(1.0 - R - T, 0.0)
    return R, T, A


def interface(eps1, eps2, cos1, with_q2=False):
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
    eps1 = np.asarray(eps1, dtype=np.complex128)
    eps2 = np.asarray(eps2, dtype=np.complex128)
    cos1 = np.asarray(cos1, dtype=np.float64)
    shape = np.broadcast_shapes(eps1.shape, eps2.shape, cos1.shape)
    eps1, eps2, cos1 = (np.broadcast_to(a, shape) for a in (eps1, eps2, cos1))
    q1, q1sq = _incident(eps1, cos1)
    # q2^2 = eps2 - eps1 sin^2 (Murakowski 2014 eq. 2.20), the transmitted wave runs forward. Under a
    # lossy incident medium the decaying root can run backwards (Re q2 < 0: negative flux, R > 1
    # and a jump to total reflection just off normal incidence); "outgoing" is continuous with
    # the lossless case.
    q2 = _normal_below(eps2, eps1, q1sq, branch="outgoing")
    one = np.ones(shape, dtype=np.complex128)
    with np.errstate(divide="ignore", invalid="ignore"):
        y2p = (q2 / eps2).real
    # (B, C) of a bare half-space: Y_in = q2 (s), q2/eps2 (p); t = 1 + r (Murakowski 2014 eq. 2.25)
    coeffs = _close(q1, eps1, one, q2, eps2, q2, one, eps2, q2.real, y2p, opaque=False)
    return (coeffs, q2) if with_q2 else coeffs
