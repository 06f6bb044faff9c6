"""Octree aggregation of the physical-optics far field (Xia et al. 2023, supplement sec. 1.2.2).

`far_field_octree` returns what `pmmw.physical_optics.currents.far_field` returns (same conventions, stated
in that module), to a relative accuracy ``tol`` of the pattern's peak. The direct sum costs
O(F D); this costs O(F M_leaf^2 + (boxes x M^2 log M per level) + D), so it wins from about
1e8 facet-directions on (docs/benchmarks_po.md).

Both far-field components project one vector, V = eta N + L x r_hat: f_theta = theta_hat . V
and f_phi = phi_hat . V (phi_hat . L = theta_hat . (L x r_hat), theta_hat . L = -phi_hat .
(L x r_hat)), so three components are aggregated instead of six.

Algorithm
---------
* The lit facets are binned by centroid into an octree over their bounding cube; leaves have a
  side of about `_LEAF_WAVELENGTHS` wavelengths.
* A box with centre c radiates the pattern
  ``P_c(r_hat) = sum_k [J_k, M_k] integral_T_k exp(i q . (r - c)) dS``, q = k0 (k_hat - r_hat),
  whose r_hat dependence is exp(-i k0 r_hat . (r - c)) with |r - c| <= R (R: the farthest facet
  vertex from c, over the level). On the torus (theta, phi) in [0, 2 pi)^2 (theta past pi is
  the direction (2 pi - theta, phi + pi)) its Fourier series is band-limited to
  L = k0 R + a (k0 R)^(1/3) (the excess-bandwidth rule behind Xia et al. 2023 eq. 6,
  M = k d + 6 (k d)^(1/3) with d = 2 R; a from ``tol``), so a uniform torus grid of
  M >= 2 L + 1 points per angle holds it exactly.
* Each leaf's pattern is computed exactly: every facet's closed-form phase integral about the
  leaf centre at the leaf grid's directions (theta in [0, pi] only; the rest are the same
  directions relabelled), times its currents, summed (`kernels.box_patterns`, compiled).
* Going up, each child's grid is upsampled to the parent's by zero-padding its 2-D FFT
  (trigonometric interpolation, exact for the band-limited pattern), multiplied by the
  translation exp(i q . (c_child - c_parent)) and summed into the parent.
* At the root the grid is upsampled `_OVERSAMPLE` times and interpolated to the requested
  directions with `_LAGRANGE`-point periodic Lagrange stencils in theta and phi; the root's phase
  exp(i q . c_root) is applied exactly there.
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft

from pmmw.physical_optics import kernels
from pmmw.physical_optics.currents import ETA0, call_slices, direction, theta_phi_hats

_LEAF_WAVELENGTHS = 1.5  # leaf side [wavelengths]; 1.5 is 7 % faster than 3 and 20 % than 1 (82k-facet sphere)
_OVERSAMPLE = 2  # root grid upsampling before the local interpolation to the requested directions
_LAGRANGE = 12  # points per angle of the final Lagrange stencil; with 2x oversampling ~1e-5
_CHUNK = 1 << 21  # complex elements per block of work (memory ~ 16-100 B each)


def _excess(tol: float) -> float:
    """The constant a in L = kR + a (kR)^(1/3) for a truncation error ``tol``.

    The MLFMA rule a = 1.8 log10(1/tol)^(2/3) bounds spherical-harmonic truncation; on the
    (theta, phi) torus half of it measured ~1e-4 at tol = 1e-3 (40-wavelength sphere, 7 levels),
    and it sets the cost of every level.
    """
    return 0.9 * max(np.log10(1.0 / tol), 1.0) ** (2.0 / 3.0)


def _grid_size(kR: float, tol: float) -> int:
    """Points per angle on the torus for a pattern of radius kR: even, FFT-friendly, > 2 L."""
    L = kR + _excess(tol) * max(kR, 1.0) ** (1.0 / 3.0)
    n = sfft.next_fast_len(int(np.ceil(2.0 * L + 2.0)))
    while n % 2:
        n = sfft.next_fast_len(n + 1)
    return n


def _grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Torus angles (n, n) [rad], theta along axis 0 and phi along axis 1."""
    a = 2.0 * np.pi * np.arange(n) / n
    return np.meshgrid(a, a, indexing="ij")


def _resample(spec: np.ndarray, n: int, axis: int) -> np.ndarray:
    """Zero-pad a Fourier spectrum along ``axis`` from its length m to ``n`` >= m, splitting the
    Nyquist bin of an even m between +/- frequencies (the symmetric trigonometric interpolant)."""
    m = spec.shape[axis]
    if n == m:
        return spec
    spec = np.moveaxis(spec, axis, 0)
    out = np.zeros((n,) + spec.shape[1:], spec.dtype)
    n_pos, n_neg = (m + 1) // 2, (m - 1) // 2  # frequencies 0..n_pos-1 and -n_neg..-1
    out[:n_pos] = spec[:n_pos]
    if n_neg:
        out[n - n_neg :] = spec[m - n_neg :]
    if m % 2 == 0:
        out[m // 2] = 0.5 * spec[m // 2]
        out[n - m // 2] += 0.5 * spec[m // 2]
    return np.moveaxis(out, 0, axis)


def _upsample(a: np.ndarray, n: int) -> np.ndarray:
    """Trigonometric interpolation of (..., m, m) torus samples onto an (n, n) grid."""
    m = a.shape[-1]
    if n == m:
        return a
    spec = sfft.fft2(a, axes=(-2, -1), workers=-1)
    spec = _resample(_resample(spec, n, -2), n, -1)
    return sfft.ifft2(spec, axes=(-2, -1), workers=-1) * ((n / m) ** 2)


def _half_grid(n: int) -> np.ndarray:
    """Directions (n // 2 + 1, n, 3) of the torus rows theta in [0, pi]."""
    th, ph = _grid(n)
    return direction(th[: n // 2 + 1], ph[: n // 2 + 1])


def _unfold(half: np.ndarray) -> np.ndarray:
    """Torus samples (..., n, n) from the rows theta in [0, pi] (..., n // 2 + 1, n): theta_j
    for j > n/2 is the direction (theta_{n-j}, phi + pi)."""
    h, n = half.shape[-2:]
    full = np.empty(half.shape[:-2] + (n, n), half.dtype)
    full[..., :h, :] = half
    full[..., h:, :] = np.roll(half[..., n - np.arange(h, n), :], -(n // 2), axis=-1)
    return full


def _leaf_patterns(tri, area, src, box, centres, k_hat, k0, n):
    """Patterns V (B, 3, n, n) of the leaves about their centres (B, 3): each facet's exact phase
    integral at the leaf grid's directions theta in [0, pi] (`kernels.box_patterns`), unfolded.

    tri : (F, 3, 3) [m]; area : (F,) [m^2]; src : (F, 6) complex, [J, M]; box : (F,) int,
    non-decreasing (facets in Morton order, so a leaf's facets are contiguous).
    """
    B = len(centres)
    start = np.searchsorted(box, np.arange(B + 1)).astype(np.int64)
    r_hat = np.ascontiguousarray(_half_grid(n).reshape(-1, 3))  # (n // 2 + 1) x n directions
    q = np.ascontiguousarray(k0 * (k_hat[None, :] - r_hat))
    tri, area, src = np.ascontiguousarray(tri), np.ascontiguousarray(area), np.ascontiguousarray(src)
    centres = np.ascontiguousarray(centres)
    half = np.empty((B, 3, r_hat.shape[0]), np.complex128)
    for run in call_slices(np.diff(start) * r_hat.shape[0]):  # boxes in runs: Ctrl-C between them
        half[run] = kernels.box_patterns(tri, area, src, start[run.start : run.stop + 1], centres[run], q, r_hat, ETA0)
    return _unfold(half.reshape(B, 3, n // 2 + 1, n))


def _lagrange(u: np.ndarray, p: int) -> tuple[np.ndarray, np.ndarray]:
    """First node (D,) and weights (D, p) of the p-point Lagrange stencil at grid coordinate u."""
    i0 = np.floor(u).astype(np.int64) - (p // 2 - 1)
    t = u - i0
    j = np.arange(p)
    diff = t[:, None] - j[None, :]  # (D, p)
    w = np.ones((len(u), p))
    for a in range(p):
        for b in range(p):
            if a != b:
                w[:, a] *= diff[:, b] / (a - b)
    return i0, w


def _interpolate(P: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Periodic Lagrange interpolation of torus samples (C, n, n) at angles (D,) -> (D, C)."""
    n = P.shape[-1]
    p = _LAGRANGE
    h = 2.0 * np.pi / n
    it, wt = _lagrange(np.mod(theta, 2.0 * np.pi) / h, p)
    ip, wp = _lagrange(np.mod(phi, 2.0 * np.pi) / h, p)
    out = np.empty((len(theta), P.shape[0]), complex)
    j = np.arange(p)
    step = max(1, _CHUNK // (P.shape[0] * p * p))
    for d0 in range(0, len(theta), step):
        sl = slice(d0, d0 + step)
        rt = (it[sl, None] + j) % n  # (d, p)
        rp = (ip[sl, None] + j) % n
        g = P[:, rt[:, :, None], rp[:, None, :]]  # (C, d, p, p)
        out[sl] = np.einsum("cdab,da,db->dc", g, wt[sl], wp[sl])
    return out


def _tree(tri, k0, tol):
    """The octree of facets ``tri`` (F, 3, 3) [m] binned by centroid over their bounding cube.

    Returns
    -------
    order : (F,) int, the facets in Morton order (a box's facets contiguous)
    tri : (F, 3, 3), the facets in that order
    levels : list of dict, deepest first: ``lev``, ``keys``, ``ijk`` and ``centres`` of its boxes,
        ``box`` (each facet's box index), ``n`` (grid points per angle, never coarser than a child's)
    side0 : float, the cube's side [m]
    """
    cen = tri.mean(axis=1)
    lo, hi = cen.min(axis=0), cen.max(axis=0)
    side0 = float(max((hi - lo).max(), 1e-12)) * (1.0 + 1e-9)
    wavelength = 2.0 * np.pi / k0
    depth = max(0, int(np.ceil(np.log2(side0 / (_LEAF_WAVELENGTHS * wavelength)))))
    leaf_side = side0 / 2**depth
    ijk = np.clip(np.floor((cen - lo) / leaf_side).astype(np.int64), 0, 2**depth - 1)
    del cen

    # Morton order: a box's children are contiguous and its key is theirs shifted by 3 bits
    morton = np.zeros(len(ijk), np.int64)
    for bit in range(depth):
        for axis in range(3):
            morton |= ((ijk[:, axis] >> bit) & 1) << (3 * bit + 2 - axis)
    order = np.argsort(morton, kind="stable")
    tri, ijk, morton = tri[order], ijk[order], morton[order]

    # boxes per level, deepest first; each facet's box index at that level
    levels = []
    for lev in range(depth, -1, -1):
        keys, first, inv = np.unique(morton >> (3 * (depth - lev)), return_index=True, return_inverse=True)
        side = side0 / 2**lev
        c = ijk[first] >> (depth - lev)
        centres = lo + (c + 0.5) * side
        R = float(np.linalg.norm(tri - centres[inv][:, None, :], axis=2).max())
        levels.append(dict(lev=lev, keys=keys, ijk=c, centres=centres, box=inv, n=_grid_size(k0 * R, tol)))
    # a parent's grid is never coarser than its children's
    for a, b in zip(levels[:-1], levels[1:]):
        b["n"] = max(b["n"], a["n"])
    return order, tri, levels, side0


def memory_bytes(tri, k0: float, directions: int, tol: float = 1e-3) -> float:
    """Peak memory [bytes] of `far_field_octree` on the facets ``tri`` (F, 3, 3) [m] (all of
    them: the lit ones are fewer, their patterns no larger), at ``k0`` [1/m] toward
    ``directions`` directions, from the tree alone (`_tree`: no pattern computed).

    The largest of its stages, each counted with the arrays alive in it (complex128, 16 B):
    the leaves' patterns (half the torus computed, then unfolded); each level's children and
    parents with one block of upsampling (`_CHUNK`) and the level's grid and translation; the
    root's pattern upsampled `_OVERSAMPLE` times with its FFT's buffers. Plus the facets' own
    arrays in Morton order (tri, area, currents, keys: ~220 B each, and each level's box index).
    """
    order, _, levels, _ = _tree(np.asarray(tri, float), k0, tol)
    facets = len(order) * (220.0 + 8.0 * len(levels))
    cplx = 16.0
    leaf = levels[0]
    b0, n0 = len(leaf["centres"]), leaf["n"]
    stages = [b0 * 3 * (n0 // 2 + 1 + n0) * n0 * cplx]
    for child, parent in zip(levels[:-1], levels[1:]):
        nc, n_p = child["n"], parent["n"]
        step = max(1, _CHUNK // (3 * n_p * n_p))
        block = min(step, len(child["centres"])) * 3 * cplx * (2 * nc * nc + n_p * nc + 3 * n_p * n_p)
        stages.append(
            (len(child["centres"]) * nc * nc + len(parent["centres"]) * n_p * n_p) * 3 * cplx + block + 88.0 * n_p * n_p
        )
    n_r = levels[-1]["n"]
    n_fine = sfft.next_fast_len(int(np.ceil(_OVERSAMPLE * n_r)))
    n_fine += n_fine % 2
    stages.append(
        3 * cplx * (3 * n_r * n_r + n_fine * n_r + 3 * n_fine * n_fine) + _CHUNK * 2 * cplx + directions * 200.0
    )
    return facets + max(stages)


def far_field_octree(target, lit, J, M, k_hat, k0, theta, phi, tol=1e-3):
    """`solver.far_field` by octree aggregation (see the module docstring).

    Parameters
    ----------
    target : solver.Target; lit : (F,) bool; J, M : (F, 3) complex128 [A/m], [V/m] at the origin
    phase; k_hat : (3,) unit propagation direction of the incident wave; k0 : float [1/m];
    theta, phi : arrays of one shape D [rad]; tol : relative accuracy (of the peak |f|).

    Returns
    -------
    f_theta, f_phi : (D,) complex128, as `solver.far_field`.
    """
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    shape = theta.shape
    th_o, ph_o = theta.ravel(), phi.ravel()
    k_hat = np.asarray(k_hat, float)
    lit = np.asarray(lit, bool)
    if not lit.any():
        z = np.zeros(shape, complex)
        return z, z.copy()
    order, tri, levels, side0 = _tree(target.tri[lit], k0, tol)
    area = target.area[lit][order]
    src = np.concatenate([J[lit], M[lit]], axis=1)[order]

    leaf = levels[0]
    P = _leaf_patterns(tri, area, src, leaf["box"], leaf["centres"], k_hat, k0, leaf["n"])
    for child, parent in zip(levels[:-1], levels[1:]):
        n = parent["n"]
        pid = np.searchsorted(parent["keys"], child["keys"] >> 3)
        th, ph = _grid(n)
        q = k0 * (k_hat[None, None, :] - direction(th, ph))  # (n, n, 3)
        octant = child["ijk"] & 1  # (B, 3): child centre - parent centre = (octant - 1/2) side/2
        slot = (octant[:, 0] * 2 + octant[:, 1]) * 2 + octant[:, 2]
        Pp = np.zeros((len(parent["centres"]), 3, n, n), complex)
        step = max(1, _CHUNK // (3 * n * n))
        for o in np.unique(slot):
            # each parent has at most one child per octant: one translation, no repeated index
            sel = np.flatnonzero(slot == o)
            shift = (octant[sel[0]] - 0.5) * (0.5 * side0 / 2 ** parent["lev"])
            phase = np.exp(1j * (q @ shift))  # Xia et al. 2023: e^{j k0 (c_child - c) . r_hat}
            for b0 in range(0, len(sel), step):
                part = sel[b0 : b0 + step]
                up = _upsample(P[part], n)
                up *= phase
                Pp[pid[part]] += up
        P = Pp

    root = levels[-1]
    n_fine = sfft.next_fast_len(int(np.ceil(_OVERSAMPLE * root["n"])))
    n_fine += n_fine % 2
    Pf = _upsample(P[0], n_fine)
    V = _interpolate(Pf, th_o, ph_o)  # (D, 3)
    r_hat = direction(th_o, ph_o)
    V *= np.exp(1j * k0 * ((k_hat[None, :] - r_hat) @ root["centres"][0]))[:, None]
    th, ph = theta_phi_hats(th_o, ph_o)
    f_theta = np.einsum("dc,dc->d", V, th)
    f_phi = np.einsum("dc,dc->d", V, ph)
    return f_theta.reshape(shape), f_phi.reshape(shape)
