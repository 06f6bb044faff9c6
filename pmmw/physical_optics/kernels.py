"""Compiled kernels of physical optics: the exact phase integral over flat triangles, summed.

Both the direct far-field sum (`solver.radiation_vectors`) and the octree's leaf stage
(`octree._leaf_patterns`) reduce to sums of currents times ``integral_T exp(i q . r) dS`` over
many triangles and many q; here they run as compiled loops (numba, parallel over directions or
boxes), without the (facets x directions) temporaries of the vectorized form. The compiled code
is cached on disk next to this file (or in numba's user cache), so only the first call after an
install pays the compile (about 6 s on this 2-core machine; 0.7 s to load it after);
``NUMBA_DISABLE_JIT=1`` runs the same code as Python.

The closed form (`triangle_phase`): with a_j = q . r_j sorted into lo <= mid <= hi, the integral
is 2 A exp(i a_mid) G(s, t), s = lo - mid <= 0 <= t = hi - mid, the second divided difference
of exp(i x) by the Hermite-Genocchi formula, G(s, t) = (phi1(t) - phi1(s)) / (i (t - s)) with
phi1(x) = (exp(i x) - 1) / (i x) = sin x / x + i 2 sin^2(x/2) / x, free of cancellation. |t - s|
is the largest spread of the phases, so the difference loses at most eps / |t - s|; below
`TAYLOR` the series 1/2 + i(s+t)/6 - (s^2+st+t^2)/24 - i(s^3+s^2t+st^2+t^3)/120 takes over
(its next term is below 1e-18 there).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from pmmw.jit import inline, njit

TAYLOR = 1e-4  # |spread| of a facet's phases below which the divided difference is a series


@inline(error_model="python")
def _phi1(x):
    """(exp(i x) - 1) / (i x) for real x."""
    if x == 0.0:
        return 1.0 + 0.0j
    h = 0.5 * x
    sh, ch = math.sin(h), math.cos(h)
    return complex(2.0 * sh * ch / x, 2.0 * sh * sh / x)


@njit(error_model="python")
def triangle_phase(a0, a1, a2, area):
    """``integral_T exp(i q . r) dS`` of a triangle of ``area`` [m^2] whose vertices have the
    phases a_j = q . r_j [rad] (module docstring)."""
    lo, mid, hi = a0, a1, a2
    if lo > mid:
        lo, mid = mid, lo
    if mid > hi:
        mid, hi = hi, mid
    if lo > mid:
        lo, mid = mid, lo
    s, t = lo - mid, hi - mid
    spread = t - s
    if spread > TAYLOR:
        g = (_phi1(t) - _phi1(s)) / complex(0.0, spread)
    else:
        g = complex(0.5 - (s * s + s * t + t * t) / 24.0, (s + t) / 6.0 - (s**3 + s * s * t + s * t * t + t**3) / 120.0)
    return 2.0 * area * complex(math.cos(mid), math.sin(mid)) * g


@njit(parallel=True, error_model="python")
def triangle_integrals(tri, area, q):
    """(F, D) complex128 integrals of the triangles tri (F, 3, 3) [m], area (F,) [m^2] at the
    wave vectors q (D, 3) [1/m]."""
    F, D = tri.shape[0], q.shape[0]
    out = np.empty((F, D), np.complex128)
    for f in numba.prange(F):
        for d in range(D):
            qx, qy, qz = q[d, 0], q[d, 1], q[d, 2]
            out[f, d] = triangle_phase(
                qx * tri[f, 0, 0] + qy * tri[f, 0, 1] + qz * tri[f, 0, 2],
                qx * tri[f, 1, 0] + qy * tri[f, 1, 1] + qz * tri[f, 1, 2],
                qx * tri[f, 2, 0] + qy * tri[f, 2, 1] + qz * tri[f, 2, 2],
                area[f],
            )
    return out


@njit(parallel=True, error_model="python")
def direction_sums(tri, area, src, q):
    """(D, C) complex128: ``sum_f src[f, c] integral_{T_f} exp(i q_d . r) dS`` for triangles tri
    (F, 3, 3) [m], area (F,) [m^2], weights src (F, C) complex128 and wave vectors q (D, 3)."""
    F, D, C = tri.shape[0], q.shape[0], src.shape[1]
    out = np.zeros((D, C), np.complex128)
    for d in numba.prange(D):
        qx, qy, qz = q[d, 0], q[d, 1], q[d, 2]
        for f in range(F):
            a0 = qx * tri[f, 0, 0] + qy * tri[f, 0, 1] + qz * tri[f, 0, 2]
            a1 = qx * tri[f, 1, 0] + qy * tri[f, 1, 1] + qz * tri[f, 1, 2]
            a2 = qx * tri[f, 2, 0] + qy * tri[f, 2, 1] + qz * tri[f, 2, 2]
            w = triangle_phase(a0, a1, a2, area[f])
            for c in range(C):
                out[d, c] += src[f, c] * w
    return out


@njit(parallel=True, error_model="python")
def box_patterns(tri, area, src, start, centres, q, r_hat, eta):
    """(B, 3, D) complex128: for each box b, the facets start[b]:start[b+1] (contiguous), the
    vector V = eta N + L x r_hat of their currents about the box centre, N and L being
    ``sum_f [J_f, M_f] integral_{T_f} exp(i q_d . (r - centres[b])) dS``.

    tri (F, 3, 3) [m]; area (F,) [m^2]; src (F, 6) complex128, [J, M] [A/m], [V/m];
    start (B + 1,) int64; centres (B, 3) [m]; q (D, 3) [1/m]; r_hat (D, 3) unit; eta [ohm].
    """
    B, D = centres.shape[0], q.shape[0]
    out = np.empty((B, 3, D), np.complex128)
    for b in numba.prange(B):
        cx, cy, cz = centres[b, 0], centres[b, 1], centres[b, 2]
        acc = np.zeros((D, 6), np.complex128)
        for f in range(start[b], start[b + 1]):
            x0, y0, z0 = tri[f, 0, 0] - cx, tri[f, 0, 1] - cy, tri[f, 0, 2] - cz
            x1, y1, z1 = tri[f, 1, 0] - cx, tri[f, 1, 1] - cy, tri[f, 1, 2] - cz
            x2, y2, z2 = tri[f, 2, 0] - cx, tri[f, 2, 1] - cy, tri[f, 2, 2] - cz
            for d in range(D):
                qx, qy, qz = q[d, 0], q[d, 1], q[d, 2]
                w = triangle_phase(
                    qx * x0 + qy * y0 + qz * z0, qx * x1 + qy * y1 + qz * z1, qx * x2 + qy * y2 + qz * z2, area[f]
                )
                for c in range(6):
                    acc[d, c] += src[f, c] * w
        for d in range(D):
            rx, ry, rz = r_hat[d, 0], r_hat[d, 1], r_hat[d, 2]
            out[b, 0, d] = eta * acc[d, 0] + acc[d, 4] * rz - acc[d, 5] * ry
            out[b, 1, d] = eta * acc[d, 1] + acc[d, 5] * rx - acc[d, 3] * rz
            out[b, 2, d] = eta * acc[d, 2] + acc[d, 3] * ry - acc[d, 4] * rx
    return out
