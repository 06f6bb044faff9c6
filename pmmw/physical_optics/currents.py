"""Physical optics: surface currents on lit facets and their exact far field (Xia et al. 2023).

Conventions
-----------
* Time dependence exp(-i w t), as everywhere in pmmw. A plane wave travelling along the unit
  vector k_hat is E0 e exp(i k k_hat . r).
* Angles in the mesh frame: theta from +z, phi from +x toward +y;
  ``direction(theta, phi) = (sin t cos p, sin t sin p, cos t)``, with the unit vectors
  ``theta_hat = (cos t cos p, cos t sin p, -sin t)`` and ``phi_hat = (-sin p, cos p, 0)``.
* The incidence (theta_i, phi_i) is the direction the wave comes *from*: it travels along
  ``k_hat = -direction(theta_i, phi_i)``, so the backscatter direction is the incidence itself.
  Its E-field (amplitude 1 V/m) lies along theta_hat or phi_hat at the incidence direction.

Currents (Xia et al. 2023 eq. 4-5)
----------------------------------
On a lit facet with outward normal n the total field is the incident plus the locally reflected
plane wave: E1 = Ei + Er, H1 = Hi + Hr, with ``H = (1/eta) k_hat x E`` for each wave. The
reflection is the renderer's (`pmmw.surface.surface_response`: bare Fresnel, coherent
coatings through the multilayer recursion, perfect conductors): rs is the E-field ratio of the
s (TE) part, rp the H-field ratio of the p (TM) part, so a perfect conductor has rs = -1, rp = +1.
With s_hat = k_hat x n / |k_hat x n| and the reflected direction k_r = k_hat - 2 (k_hat . n) n,

    Er = rs (Ei . s_hat) s_hat + eta rp (Hi . s_hat) (s_hat x k_r)
    Hr = (1/eta) rs (Ei . s_hat) (k_r x s_hat) + rp (Hi . s_hat) s_hat,

and the currents are J = n x H1, M = -n x E1, each carrying the incident phase
exp(i k k_hat . r) along the facet. A facet is lit when the incidence direction sees its centroid
(an Embree shadow ray, Xia et al. 2023's shadowed-point culling); an open sheet is lit on
whichever side faces the wave (its normal is turned toward it), a closed body only on its outside
(the far side is shadowed by the body itself).

Far field (Xia et al. 2023 eq. 7-10)
------------------------------------
With N = integral J exp(-i k r_hat . r') dS' and L the same of M (Balanis's radiation vectors in
this time convention), the scattered far field is

    E_theta = i k exp(i k r) / (4 pi r) (L_phi + eta N_theta)
    E_phi = -i k exp(i k r) / (4 pi r) (L_theta - eta N_phi),

so the bistatic RCS is sigma_theta = k^2 / (4 pi) |L_phi + eta N_theta|^2 (per 1 V/m incident)
and sigma_phi = k^2 / (4 pi) |L_theta - eta N_phi|^2. Over a flat triangle the currents are
constant times the incident phase, so each facet contributes J_k I_k(q) with the phase integral

    I(q) = integral_T exp(i q . r) dS,   q = k (k_hat - r_hat),

in closed form: 2 A times the second divided difference of exp at i q . r_1, i q . r_2, i q . r_3
(Hermite-Genocchi), evaluated without cancellation (`kernels.triangle_phase`, compiled). A flat plate of two
triangles is therefore exact physical optics, at any size in wavelengths.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from pmmw.physical_optics import kernels
from pmmw.surface import surface_response
from pmmw.trace.intersect import make_intersector, offset_origins

ETA0 = 376.730313668  # [ohm] impedance of free space

#: Facet x direction terms per thread in one call of a compiled sum (`kernels.direction_sums`,
#: `kernels.box_patterns`). A compiled call holds the interpreter, which sees Ctrl-C only between
#: calls: at 2-5e6 terms per second and thread (2 cores, idle to busy) a call lasts 0.1-0.25 s,
#: and the calls' overhead (~20 us each) is lost in that.
CALL_TERMS = 500_000


def call_slices(cost) -> list[slice]:
    """Runs of consecutive items, each one compiled call of about `CALL_TERMS` terms per thread.

    cost : (n,) terms of each item (independent of one another: the results do not depend on
    the cut). A run holds at least one item per thread, so that every thread has work.
    """
    import numba

    threads = numba.get_num_threads()
    total = np.cumsum(np.asarray(cost, np.float64))
    runs, i, n = [], 0, len(total)
    while i < n:
        j = int(np.searchsorted(total, (total[i - 1] if i else 0.0) + CALL_TERMS * threads, side="right"))
        j = min(n, max(j, i + threads))
        runs.append(slice(i, j))
        i = j
    return runs


def direction(theta, phi) -> np.ndarray:
    """Unit vectors (..., 3) for angles [rad] (theta from +z, phi from +x toward +y)."""
    st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
    return np.stack(np.broadcast_arrays(st * cp, st * sp, ct), axis=-1)


def theta_phi_hats(theta, phi) -> tuple[np.ndarray, np.ndarray]:
    """theta_hat and phi_hat (..., 3) at the angles [rad]."""
    st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
    zero = np.zeros(np.broadcast(theta, phi).shape)
    th = np.stack(np.broadcast_arrays(ct * cp, ct * sp, -st), axis=-1)
    ph = np.stack(np.broadcast_arrays(-sp + zero, cp + zero, zero), axis=-1)
    return th, ph


@dataclass
class Target:
    """A triangle mesh with one material per face, ready for physical optics.

    vertices : (V, 3) float64 [m]; faces : (F, 3) int64; face_medium : (F,) int, the index of
    each face's material in ``media`` (a `pmmw.trace.job.Media`, index 0 the ambient air).
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_medium: np.ndarray
    media: object

    def __post_init__(self):
        tri = self.vertices[self.faces]
        cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area2 = np.linalg.norm(cross, axis=1)
        keep = area2 > 1e-12 * max(float(area2.max(initial=0.0)), 1e-300)
        self.faces, self.face_medium = self.faces[keep], np.asarray(self.face_medium)[keep]
        self.tri = tri[keep]
        self.normal = cross[keep] / area2[keep, None]
        self.area = 0.5 * area2[keep]
        self.centroid = self.tri.mean(axis=1)
        self._isect = None

    @property
    def intersector(self):
        if self._isect is None:
            self._isect = make_intersector(self.vertices, self.faces)
        return self._isect


def make_target(vertices, faces, face_material, material_ids, db, f: float) -> Target:
    """A `Target` of the given triangles, ``face_material`` (F,) indexing ``material_ids`` in the
    material database ``db``, with the media at frequency f [Hz] (air around it)."""
    from pmmw.surface.media import build_media

    media = build_media(db, material_ids, f)
    return Target(np.asarray(vertices, float), np.asarray(faces, np.int64), np.asarray(face_material, int) + 1, media)


def lit_facets(target: Target, d_inc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Facets the incidence direction ``d_inc`` (unit, toward the source) sees, and each facet's
    normal turned toward the source. A centroid-to-source shadow ray decides (Embree)."""
    cos_i = target.normal @ d_inc
    n_eff = np.where(cos_i[:, None] < 0.0, -target.normal, target.normal)
    facing = np.abs(cos_i) > 1e-9
    isect = target.intersector
    d = np.broadcast_to(d_inc, target.centroid.shape).copy()
    origins = offset_origins(target.centroid, n_eff, d, scale=isect.face_scale)  # past Embree's float32
    t, _ = isect.intersect(origins, d)
    lit = facing & ~np.isfinite(t)
    return lit, n_eff


def currents(target: Target, d_inc: np.ndarray, e_inc: np.ndarray, k0: float):
    """PO currents of the lit facets for a unit plane wave from ``d_inc`` polarized along
    ``e_inc`` (unit, perpendicular to d_inc).

    Returns
    -------
    lit : (F,) bool
    J, M : (F, 3) complex128
        Current amplitudes [A/m], [V/m] at the origin phase (J(r) = J exp(i k k_hat . r)).
    """
    lit, n = lit_facets(target, d_inc)
    F = len(target.faces)
    J = np.zeros((F, 3), complex)
    M = np.zeros((F, 3), complex)
    k_hat = np.broadcast_to(-d_inc, (int(lit.sum()), 3))
    ei = np.broadcast_to(e_inc.astype(complex), k_hat.shape)
    J[lit], M[lit], _, _ = surface_currents(target.media, target.face_medium[lit], n[lit], k_hat, ei, k0)
    return lit, J, M


def surface_currents(media, medium, n, k_hat, e, k0):
    """Currents of plane waves meeting surfaces, and the waves they reflect (one row per wave).

    Parameters
    ----------
    media : Media; medium : (R,) int, each surface's material index
    n : (R, 3) unit normals facing the incoming wave (n . k_hat < 0)
    k_hat : (R, 3) unit propagation directions; e : (R, 3) complex E-field at the surface point

    Returns
    -------
    J, M : (R, 3) complex, n x (Hi + Hr) and -n x (Ei + Er)
    e_r : (R, 3) complex, the reflected E-field there; k_r : (R, 3) its direction
    """
    R = len(medium)
    hi = np.cross(k_hat, e) / ETA0
    cos1 = np.clip(-np.einsum("ij,ij->i", n, k_hat), 0.0, 1.0)
    s = np.cross(k_hat, n)
    s_norm = np.linalg.norm(s, axis=1)
    # normal incidence: any tangent is s; take one perpendicular to n
    fallback = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    s = np.where(
        s_norm[:, None] > 1e-12,
        s / np.maximum(s_norm, 1e-300)[:, None],
        fallback / np.linalg.norm(fallback, axis=1)[:, None],
    )
    k_r = k_hat - 2.0 * np.einsum("ij,ij->i", n, k_hat)[:, None] * n
    rs, rp = np.zeros(R, complex), np.zeros(R, complex)
    job = SimpleNamespace(media=media, k0=k0)
    for m in np.unique(medium):
        sel = medium == m
        c, _, _ = surface_response(job, 0, int(m), int(m), False, cos1[sel])
        rs[sel], rp[sel] = c.rs, c.rp
    e_s = np.einsum("ij,ij->i", e, s)
    h_s = np.einsum("ij,ij->i", hi, s)
    e_r = (rs * e_s)[:, None] * s + (ETA0 * rp * h_s)[:, None] * np.cross(s, k_r)
    h_r = (rs * e_s / ETA0)[:, None] * np.cross(k_r, s) + (rp * h_s)[:, None] * s
    return np.cross(n, hi + h_r), -np.cross(n, e + e_r), e_r, k_r


def triangle_integral(tri: np.ndarray, area: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``integral_T exp(i q . r) dS`` over flat triangles, exactly (`kernels.triangle_phase`).

    tri : (F, 3, 3) vertices [m]; area : (F,) [m^2]; q : (D, 3) [1/m]. Returns (F, D) complex128.
    """
    return kernels.triangle_integrals(
        np.ascontiguousarray(tri, float), np.ascontiguousarray(area, float), np.ascontiguousarray(q, float)
    )


def radiation_vectors(target: Target, lit, J, M, k_hat, k0, r_hat):
    """N and L (D, 3) of the lit facets' currents toward the unit directions ``r_hat`` (D, 3)."""
    src = np.ascontiguousarray(np.concatenate([J[lit], M[lit]], axis=1))
    q = np.ascontiguousarray(k0 * (np.asarray(k_hat, float)[None, :] - r_hat))
    tri, area = np.ascontiguousarray(target.tri[lit]), np.ascontiguousarray(target.area[lit])
    NL = np.empty((q.shape[0], src.shape[1]), np.complex128)
    for run in call_slices(np.full(q.shape[0], tri.shape[0])):  # directions in runs: Ctrl-C between them
        NL[run] = kernels.direction_sums(tri, area, src, q[run])
    return NL[:, :3], NL[:, 3:]


def components(N, L, theta, phi):
    """``(L_phi + eta N_theta, -(L_theta - eta N_phi))`` at the angles [rad] (flat arrays)."""
    th, ph = theta_phi_hats(theta, phi)
    n_th, n_ph = np.einsum("dc,dc->d", N, th), np.einsum("dc,dc->d", N, ph)
    l_th, l_ph = np.einsum("dc,dc->d", L, th), np.einsum("dc,dc->d", L, ph)
    return l_ph + ETA0 * n_th, -(l_th - ETA0 * n_ph)


def far_field(target: Target, lit, J, M, k_hat, k0, theta, phi):
    """Scattered far-field components for observation angles [rad] (arrays of one shape D).

    Returns
    -------
    f_theta, f_phi : (D,) complex
        ``L_phi + eta N_theta`` and ``-(L_theta - eta N_phi)``: E = i k exp(ikr)/(4 pi r) f, so
        that sigma = k^2 |f|^2 / (4 pi) [m^2] for a 1 V/m incident wave.
    """
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    shape = theta.shape
    N, L = radiation_vectors(target, lit, J, M, k_hat, k0, direction(theta.ravel(), phi.ravel()))
    ft, fp = components(N, L, theta.ravel(), phi.ravel())
    return ft.reshape(shape), fp.reshape(shape)


def incident(theta_i: float, phi_i: float, polarization: str):
    """(d_inc, e_inc): unit direction toward the source and the incident E direction."""
    d = direction(theta_i, phi_i)
    th, ph = theta_phi_hats(theta_i, phi_i)
    return d, (th if polarization == "theta" else ph)
