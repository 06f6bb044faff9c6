"""Multiple bounces for physical optics: shooting and bouncing ray tubes (SBR).

Single-bounce PO (`pmmw.physical_optics.solver`) radiates the currents the incident wave induces. Where a
wave reflects onto another part of the target (dihedrals, trihedrals, a bracket's inside corner)
the reflected wave induces currents too. They are found by shooting a grid of square ray tubes
from the incidence over the target's projected disc (Embree, one batched call per bounce),
reflecting each tube's polarized field with the same local reflection as the PO currents
(`solver.surface_currents`: Fresnel, coatings, perfect conductors), and radiating, at every hit
from the second on, the currents of the tube's footprint.

A tube of side vectors (a, b) perpendicular to its direction d lands on a flat face of normal n
on the parallelogram u = a - d (a . n)/(d . n), v likewise, of area |u x v|; its currents are the
hit's, carrying the phase of the ray's path, exp(i k d . (r - r_hit)) across the footprint, so
the footprint radiates exactly

    J(r_hit) exp(-i k r_hat . r_hit) |u x v| sinc(q . u / 2) sinc(q . v / 2),   q = k (d - r_hat),

with sinc(x) = sin(x)/x. Tubes stay parallel on flat faces (their side vectors are mirrored at
each reflection), which makes corner reflectors exact up to the tube grid's edges; on curved
faces their divergence is ignored, as in the classic SBR of Ling, Chou & Lee (1989).
"""

from __future__ import annotations

import numpy as np

from pmmw.errors import UserError
from pmmw.physical_optics import currents as solver
from pmmw.trace.intersect import offset_origins

MAX_TUBES = 4_000_000
_CHUNK = 1 << 21  # tube x direction elements at once


def tube_grid(target: solver.Target, d_inc: np.ndarray, tube: float):
    """Tube centres on a plane in front of the target, their side vectors and field phase."""
    lo, hi = target.vertices.min(axis=0), target.vertices.max(axis=0)
    centre = (lo + hi) / 2.0
    radius = float(np.linalg.norm(hi - lo)) / 2.0 + tube
    a_hat = np.cross(d_inc, [0.0, 0.0, 1.0] if abs(d_inc[2]) < 0.9 else [1.0, 0.0, 0.0])
    a_hat /= np.linalg.norm(a_hat)
    b_hat = np.cross(d_inc, a_hat)
    n = int(np.ceil(radius / tube))
    if (2 * n + 1) ** 2 > MAX_TUBES:
        raise UserError(
            f"{(2 * n + 1) ** 2} ray tubes of {tube:.3g} m over a target {2 * radius:.3g} m across, "
            f"more than {MAX_TUBES}: give a larger --tube",
            "--tube",
        )
    i, j = np.meshgrid(np.arange(-n, n + 1), np.arange(-n, n + 1), indexing="ij")
    keep = (i * i + j * j) * tube * tube <= radius * radius
    i, j = i[keep].astype(float), j[keep].astype(float)
    origins = centre + d_inc * (radius + tube) + tube * (i[:, None] * a_hat + j[:, None] * b_hat)
    return origins, tube * a_hat, tube * b_hat


def bounce_radiation(target: solver.Target, k0: float, d_inc, e_inc, bounces: int, r_hat, tube=None):
    """N and L (D, 3) of the currents induced by waves reflected 1 .. bounces-1 times.

    Parameters
    ----------
    d_inc : (3,) unit direction toward the source; e_inc : (3,) its unit E-field
    bounces : int, >= 2; r_hat : (D, 3) observation directions
    tube : float, optional
        Tube side [m]; default a quarter wavelength (finer where the target is small).
    """
    lam = 2.0 * np.pi / k0
    tube = tube or lam / 4.0
    origins, a, b = tube_grid(target, d_inc, tube)
    R = len(origins)
    d = np.broadcast_to(-d_inc, (R, 3)).copy()
    e = np.broadcast_to(e_inc.astype(complex), (R, 3)) * np.exp(1j * k0 * (origins @ -d_inc))[:, None]
    ta, tb = np.broadcast_to(a, (R, 3)).copy(), np.broadcast_to(b, (R, 3)).copy()
    D = r_hat.shape[0]
    N = np.zeros((D, 3), complex)
    L = np.zeros((D, 3), complex)
    isect = target.intersector
    for bounce in range(1, bounces + 1):
        if len(origins) == 0:
            break
        t, prim = isect.intersect(origins, d)
        hit = np.isfinite(t)
        origins, d, e, ta, tb, t, prim = (x[hit] for x in (origins, d, e, ta, tb, t, prim))
        if len(origins) == 0:
            break
        r = origins + t[:, None] * d
        e = e * np.exp(1j * k0 * t)[:, None]
        n = target.normal[prim]
        n = np.where((np.einsum("ij,ij->i", n, d) > 0.0)[:, None], -n, n)  # facing the wave
        J, M, e_r, k_r = solver.surface_currents(target.media, target.face_medium[prim], n, d, e, k0)
        if bounce >= 2:
            dn = np.einsum("ij,ij->i", d, n)
            u = ta - d * (np.einsum("ij,ij->i", ta, n) / dn)[:, None]
            v = tb - d * (np.einsum("ij,ij->i", tb, n) / dn)[:, None]
            area = np.linalg.norm(np.cross(u, v), axis=1)
            step = max(1, _CHUNK // max(1, len(r)))
            for d0 in range(0, D, step):
                rh = r_hat[d0 : d0 + step]
                q = k0 * (d[:, None, :] - rh[None, :, :])  # (R, Dc, 3)
                w = (
                    np.exp(-1j * k0 * (r @ rh.T))
                    * area[:, None]
                    * np.sinc(np.einsum("rdc,rc->rd", q, u) / (2.0 * np.pi))
                    * np.sinc(np.einsum("rdc,rc->rd", q, v) / (2.0 * np.pi))
                )
                N[d0 : d0 + step] += w.T @ J
                L[d0 : d0 + step] += w.T @ M
        # the reflected tube leaves the hit point, its side vectors mirrored
        origins = offset_origins(r, n, k_r, scale=isect.face_scale[prim])
        ta = ta - 2.0 * np.einsum("ij,ij->i", ta, n)[:, None] * n
        tb = tb - 2.0 * np.einsum("ij,ij->i", tb, n)[:, None] * n
        d, e = k_r, e_r
        alive = np.linalg.norm(e, axis=1) > 1e-12
        origins, d, e, ta, tb = (x[alive] for x in (origins, d, e, ta, tb))
    return N, L
