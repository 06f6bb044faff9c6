"""The polarized Ashikhmin model of Stryjewski et al. 2009 for one rough interface (`pmmw.reflectance`
docstring, ``analytic``): the single-reflection term in closed form, the double-reflection term
by a deterministic quadrature, and hemispherical totals integrated over facet normals.

(The module is not called ``analytic``: that name is the function `analytic` re-exported by the
package, and a submodule of the same name would be shadowed by it.)
"""

from __future__ import annotations

import math

import numpy as np

from pmmw.arrays import FloatArray
from pmmw.errors import UserError
from pmmw.physics import roughness as rough
from pmmw.physics.jones import basis_change
from pmmw.physics.vec import cross, dot, unit
from pmmw.reflectance.grid import (
    N_PHI,
    N_THETA,
    _cells,
    _hv,
    grid_directions,
    mueller_from_jones,
    projected_solid_angle,
)
from pmmw.reflectance.optics import _TINY, _amplitude, _facet_basis, _Interface
from pmmw.reflectance.stack import Stack

__all__ = ["SHADOWING", "analytic", "analytic_mueller", "analytic_totals"]

SHADOWING = ("smith", "ashikhmin", "torrance_sparrow", "none")
# Zenith and azimuth step [deg] of the sub-grid on which `analytic` evaluates the (broad) double-
# reflection term before interpolating it onto the 1-degree grid (4 x fewer evaluations).
_DOUBLE_STEP = 2


def _facet_jones(
    itf: _Interface,
    m: FloatArray,
    k_in: FloatArray,
    k_out: FloatArray,
    s_in_basis: FloatArray,
    p_in_basis: FloatArray,
    s_out_basis: FloatArray | None,
    p_out_basis: FloatArray | None,
    out_basis: bool = True,
) -> tuple[np.ndarray, FloatArray, FloatArray]:
    """Jones matrix of one specular facet reflection, shape (N, 2, 2), from the (s_in, p_in)
    basis of the incoming wave to the (s_out, p_out) basis of the outgoing one, or with
    ``out_basis=False`` to the facet's own (s, k_out x s); also returns that s and p."""
    cos1 = np.clip(-dot(k_in, m), 0.0, 1.0)
    co = itf.fresnel(cos1, True)
    s, p_in = _facet_basis(m, k_in, s_in_basis)
    p_out = cross(k_out, s)
    r = np.stack([_amplitude(co.rs, co.Rs), _amplitude(co.rp, co.Rp)], axis=1)
    j = r[:, :, None] * basis_change(s, p_in, s_in_basis, p_in_basis)
    if out_basis:
        assert s_out_basis is not None and p_out_basis is not None  # given whenever out_basis is
        j = basis_change(s_out_basis, p_out_basis, s, p_out) @ j
    return j, s, p_out


def analytic_mueller(
    stack: Stack,
    wi: np.ndarray,
    wo: np.ndarray,
    *,
    phi_o: np.ndarray | None = None,
    shadowing: str = "smith",
    double: bool = True,
    double_samples: int = 256,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Stryjewski et al. 2009's polarized Ashikhmin BRDF for given outgoing directions (`pmmw.reflectance` docstring).

    Parameters
    ----------
    stack : Stack
        One layer (the substrate), optionally coated; its roughness a microfacet model or None.
    wi : ndarray, shape (3,), float64
        Unit direction toward the source (wi.z > 0).
    wo : ndarray, shape (N, 3), float64
        Unit outgoing directions (wo.z >= 0).
    phi_o : ndarray, shape (N,), optional
        Azimuth defining the (h, v) basis where wo is the zenith (default: atan2 of wo).
    shadowing : {"smith", "ashikhmin", "torrance_sparrow", "none"}
        G of the single-reflection term.
    double : bool
        Add the double-reflection term.
    double_samples : int
        Quadrature points over the first facet (scrambled Sobol, seeded by ``seed``).

    Returns
    -------
    single, double : ndarray, shape (N, 4, 4), float64
        BRDF Mueller matrices [1/sr] (``double`` zeros when off; a smooth surface returns zeros:
        its BRDF is a delta, see `analytic`).
    """
    if len(stack.layers) != 1:
        raise UserError(
            "the analytic model is for one rough interface (a substrate, optionally coated); "
            "use --method mc for layered stacks",
            "--method",
        )
    if shadowing not in SHADOWING:
        raise UserError(f"unknown shadowing {shadowing!r}; known: {', '.join(SHADOWING)}", "--shadowing")
    itf = _Interface(stack, 0)
    model = itf.model
    if isinstance(model, rough.BlenderGloss):
        raise UserError(
            "blender_gloss is Blender's normal perturbation, not a microfacet distribution: it has no "
            "analytic BRDF; use --method mc",
            "--method",
        )
    wo = np.asarray(wo, dtype=np.float64)
    nc = wo.shape[0]
    phi_o = np.arctan2(wo[:, 1], wo[:, 0]) if phi_o is None else np.asarray(phi_o, dtype=np.float64)
    wi = np.asarray(wi, dtype=np.float64)
    cos_i = float(wi[2])
    phi_i = math.atan2(wi[1], wi[0])
    zero = np.zeros((nc, 4, 4))
    if model is None:
        return zero, zero.copy()
    k_in = np.tile(-wi, (nc, 1))
    h_in, v_in = _hv(k_in, np.full(nc, phi_i + math.pi))
    h_out, v_out = _hv(wo, phi_o)
    nz = np.tile([0.0, 0.0, 1.0], (nc, 1))
    tangent = np.tile([1.0, 0.0, 0.0], (nc, 1))
    cos_o = wo[:, 2]
    valid = cos_o > 1e-12
    cos_o_safe = np.where(valid, cos_o, 1.0)

    # Single reflection (Stryjewski et al. 2009 eq. 4 with the full Fresnel Jones matrix, eq. 10-11)
    hv = unit(wi[None, :] + wo)
    d_h = model.D(nz, tangent, hv)
    j1, _, _ = _facet_jones(itf, hv, k_in, wo, h_in, v_in, h_out, v_out)
    wi_n = np.tile(wi, (nc, 1))
    if shadowing == "smith":
        g = model.shadowing(nz, hv, wi_n, wo, tangent)
    elif shadowing == "ashikhmin":
        g = rough.ashikhmin_pair(model.masking(nz, tangent, wi_n), model.masking(nz, tangent, wo), nz, wi_n, wo)
    elif shadowing == "torrance_sparrow":
        g = rough.torrance_sparrow(nz, hv, wi_n, wo)
    else:
        g = np.ones(nc)
    scale = np.where(valid, d_h * g / (4.0 * cos_i * cos_o_safe), 0.0)
    single = mueller_from_jones(j1) * scale[:, None, None]
    if not double:
        return single, zero

    dbl = _double_term(itf, model, wi, wo, h_in, v_in, h_out, v_out, int(double_samples), int(seed))
    return single, dbl


def _double_term(
    itf: _Interface,
    model: rough.MicrofacetModel,
    wi: FloatArray,
    wo: FloatArray,
    h_in: FloatArray,
    v_in: FloatArray,
    h_out: FloatArray,
    v_out: FloatArray,
    n_samples: int,
    seed: int,
) -> FloatArray:
    """Stryjewski et al. 2009's double-reflection term for the Smith microsurface, shape (N, 4, 4) [1/sr].

    ``f2(wi, wo) = int f(w12) dw12`` over the direction w12 from facet 1 (h1 = unit(wi + w12))
    to facet 2 (h2 = unit(wo - w12)), with
    ``f = G1(wi) G1(wo) D(h1) D(h2) M_F2 / (16 cos_i cos_o A(w12+))`` (`pmmw.reflectance` docstring). Two
    sampling strategies share one scrambled Sobol set: h1 ~ D cos (w12 from the incident side,
    density q1 = D(h1) cos(h1) / (4 wi.h1)) and h2 ~ D cos (w12 from the outgoing side,
    q2 = D(h2) cos(h2) / (4 wo.h2)), combined by the balance heuristic ``f / (q1 + q2)``: each
    captures the peak the other misses, and the estimate is reciprocal (swapping wi and wo swaps
    the strategies).
    """
    from scipy.stats import qmc

    nc = wo.shape[0]
    wi = np.asarray(wi, dtype=np.float64)
    cos_i = float(wi[2])
    cos_o = wo[:, 2]
    z = np.array([0.0, 0.0, 1.0])
    tx = np.array([1.0, 0.0, 0.0])
    sob = qmc.Sobol(d=2, scramble=True, seed=seed).random(n_samples)
    hs, _ = model.sample_dcos(z, tx, sob[:, 0], sob[:, 1])
    g1_i = float(model.masking(z, tx, wi[None, :])[0])
    g1_o = model.masking(z, tx, wo)
    acc = np.zeros((nc, 4, 4))
    cells = np.nonzero(cos_o > 1e-12)[0]
    wo_c = wo[cells]
    k_in1 = -wi[None, :]

    def area_up(w12: FloatArray) -> FloatArray:
        up = w12.copy()
        up[:, 2] = np.abs(up[:, 2])  # A(-w) = A(w with z flipped): D is point-symmetric in x, y
        return model.projected_area(z, tx, up)

    def accumulate(
        sel: np.ndarray,
        h1: FloatArray,
        h2: FloatArray,
        w12: FloatArray,
        c1: FloatArray | float,
        c2: FloatArray,
        dc1: FloatArray,
        dc2: FloatArray,
        a12: FloatArray | float,
        ja: np.ndarray,
        s_a: FloatArray,
        p_a: FloatArray,
    ) -> None:
        """acc[sel] += M(J) f/(q1 + q2), arrays over the cells ``sel`` (broadcastable)."""
        q = dc1 / (4.0 * c1) + dc2 / (4.0 * c2)
        fw = g1_i * g1_o[sel] * (dc1 / h1[..., 2]) * (dc2 / h2[..., 2]) / (16.0 * cos_i * cos_o[sel] * a12 * q)
        n = sel.size
        jb, _, _ = _facet_jones(
            itf,
            h2,
            np.broadcast_to(w12, (n, 3)),
            wo[sel],
            np.broadcast_to(s_a, (n, 3)),
            np.broadcast_to(p_a, (n, 3)),
            h_out[sel],
            v_out[sel],
        )
        acc[sel] += mueller_from_jones(jb @ ja) * np.maximum(fw, 0.0)[:, None, None]  # distinct cells

    for h in hs:
        dch = float(model.D(z, tx, h[None, :])[0]) * h[2]
        if not (dch > 0.0 and h[2] > 0.0):
            continue
        # strategy 1: h is facet 1, seen from wi (w12, facet 1's Jones matrix shared by all cells)
        c1 = float(h @ wi)
        if c1 > 0.0:
            w12 = -wi + 2.0 * c1 * h
            h2 = unit(wo_c - w12[None, :])
            c2 = dot(wo_c, h2)
            dc2 = model.D(z, tx, h2) * h2[:, 2]
            ok = (c2 > 0.0) & (dc2 > 0.0) & (h2[:, 2] > 0.0)
            if np.any(ok):
                ja, s_a, p_a = _facet_jones(
                    itf, h[None, :], k_in1, w12[None, :], h_in[:1], v_in[:1], None, None, out_basis=False
                )
                a12 = float(area_up(w12[None, :])[0])
                accumulate(cells[ok], h, h2[ok], w12, c1, c2[ok], dch, dc2[ok], a12, ja, s_a[0], p_a[0])
        # strategy 2: h is facet 2, seen from wo (the reversed path); w12 and facet 1 per cell
        co = wo_c @ h
        m2 = co > 0.0
        if np.any(m2):
            sel = cells[m2]
            w12 = wo_c[m2] - 2.0 * co[m2][:, None] * h[None, :]
            h1 = unit(wi[None, :] + w12)
            c1v = h1 @ wi
            dc1 = model.D(z, tx, h1) * h1[:, 2]
            ok = (c1v > 0.0) & (dc1 > 0.0) & (h1[:, 2] > 0.0)
            if np.any(ok):
                sel, w12, h1, c1v, dc1, cov = sel[ok], w12[ok], h1[ok], c1v[ok], dc1[ok], co[m2][ok]
                n = sel.size
                ja, s_a, p_a = _facet_jones(
                    itf, h1, np.broadcast_to(k_in1, (n, 3)), w12, h_in[sel], v_in[sel], None, None, out_basis=False
                )
                accumulate(sel, h1, np.broadcast_to(h, (n, 3)), w12, c1v, cov, dc1, dch, area_up(w12), ja, s_a, p_a)
    return acc / n_samples


def analytic_totals(
    stack: Stack,
    wi: np.ndarray,
    *,
    shadowing: str = "smith",
    double: bool = True,
    n_points: int = 1 << 16,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Hemispherical Mueller matrices [-] of the analytic single and double terms, integrated
    over facet normals rather than over the grid (accurate for any roughness, also where the
    lobe is narrower than a grid cell):

    ``R1 = int D(h) G F (wi.h) / cos_i dw_h`` with h ~ D cos (scrambled Sobol), and
    ``R2 = int int G1(wi) G1(wo) D1 D2 F2 (wi.h1)(-w12.h2) / (cos_i A(w12+)) dw_h1 dw_h2``
    (the double term of `_double_term` with ``dw12 = 4 (wi.h1) dw_h1``, ``dwo = 4 (-w12.h2) dw_h2``).

    Returns
    -------
    single, double : ndarray, shape (4, 4), float64
    """
    from scipy.stats import qmc

    itf = _Interface(stack, 0)
    model = itf.model
    wi = np.asarray(wi, dtype=np.float64)
    cos_i = float(wi[2])
    phi_i = math.atan2(wi[1], wi[0])
    z = np.array([0.0, 0.0, 1.0])
    tx = np.array([1.0, 0.0, 0.0])
    zero = np.zeros((4, 4))
    if model is None or isinstance(model, rough.BlenderGloss):
        return zero, zero.copy()
    pts = qmc.Sobol(d=4, scramble=True, seed=int(seed)).random(int(n_points))
    n = pts.shape[0]
    k_in = np.tile(-wi, (n, 1))
    h_in, v_in = _hv(k_in, np.full(n, phi_i + math.pi))
    wi_n = np.tile(wi, (n, 1))
    g1_i = float(model.masking(z, tx, wi[None, :])[0])

    h1, _ = model.sample_dcos(z, tx, pts[:, 0], pts[:, 1])
    c1 = h1 @ wi
    wo = 2.0 * c1[:, None] * h1 - wi
    ok = (c1 > 0.0) & (wo[:, 2] > 0.0)
    h_out, v_out = _hv(wo, np.arctan2(wo[:, 1], wo[:, 0]))
    if shadowing == "smith":
        g = model.shadowing(z, h1, wi_n, wo, tx)
    elif shadowing == "ashikhmin":
        g = rough.ashikhmin_pair(np.full(n, g1_i), model.masking(z, tx, wo), np.tile(z, (n, 1)), wi_n, wo)
    elif shadowing == "torrance_sparrow":
        g = rough.torrance_sparrow(np.tile(z, (n, 1)), h1, wi_n, wo)
    else:
        g = np.ones(n)
    w = np.where(ok, g * c1 / (cos_i * np.maximum(h1[:, 2], _TINY)), 0.0)
    j1, _, _ = _facet_jones(itf, h1, k_in, wo, h_in, v_in, h_out, v_out)
    single = np.einsum("n,nij->ij", w, mueller_from_jones(j1)) / n
    if not double:
        return single, zero.copy()

    w12 = wo  # the first reflection's direction
    h2, _ = model.sample_dcos(z, tx, pts[:, 2], pts[:, 3])
    c2 = -dot(w12, h2)
    wo2 = w12 + 2.0 * c2[:, None] * h2
    ok2 = (c1 > 0.0) & (c2 > 0.0) & (wo2[:, 2] > 0.0)
    up = w12.copy()
    up[:, 2] = np.abs(up[:, 2])
    a12 = model.projected_area(z, tx, up)
    g1_o = model.masking(z, tx, wo2)
    with np.errstate(divide="ignore", invalid="ignore"):
        w2 = np.where(
            ok2 & (a12 > 0.0),
            g1_i * g1_o * c1 * c2 / (cos_i * a12 * np.maximum(h1[:, 2], _TINY) * np.maximum(h2[:, 2], _TINY)),
            0.0,
        )
    ja, s_a, p_a = _facet_jones(itf, h1, k_in, w12, h_in, v_in, None, None, out_basis=False)
    h2_out, v2_out = _hv(wo2, np.arctan2(wo2[:, 1], wo2[:, 0]))
    jb, _, _ = _facet_jones(itf, h2, w12, wo2, s_a, p_a, h2_out, v2_out)
    dbl = np.einsum("n,nij->ij", w2, mueller_from_jones(jb @ ja)) / n
    return single, dbl


def analytic(
    stack: Stack,
    wi: np.ndarray,
    *,
    shadowing: str = "smith",
    double: bool = True,
    double_samples: int = 256,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """`analytic_mueller` at the centres of the 91 x 360 grid.

    A smooth interface has a delta BRDF: its Fresnel Mueller matrix divided by the projected
    solid angle of the specular cell, so that the grid sums to the flat reflectance.

    Returns
    -------
    single, double : ndarray, shape (91, 360, 4, 4), float64 [1/sr]
    """
    _, ph, wgrid = grid_directions()
    single, _ = analytic_mueller(
        stack, wi, wgrid.reshape(-1, 3), phi_o=ph.reshape(-1), shadowing=shadowing, double=False
    )
    single = single.reshape(N_THETA, N_PHI, 4, 4)
    dbl = np.zeros_like(single)
    if double and stack.layers[0].roughness is not None:
        # the double-reflection lobe is broad: evaluate it every _DOUBLE_STEP degrees and
        # interpolate bilinearly (periodic in azimuth)
        st = _DOUBLE_STEP
        rows, cols = np.arange(0, N_THETA, st), np.arange(0, N_PHI, st)
        sub_w = wgrid[np.ix_(rows, cols)].reshape(-1, 3)
        sub_ph = ph[np.ix_(rows, cols)].reshape(-1)
        _, sub = analytic_mueller(
            stack, wi, sub_w, phi_o=sub_ph, shadowing=shadowing, double=True, double_samples=double_samples, seed=seed
        )
        sub = sub.reshape(rows.size, cols.size, 4, 4)
        sub = np.concatenate([sub, sub[:, :1]], axis=1)  # wrap azimuth
        r = np.arange(N_THETA) / st
        c = np.arange(N_PHI) / st
        r0 = np.minimum(np.floor(r).astype(int), rows.size - 2)
        c0 = np.floor(c).astype(int)
        tr = (r - r0)[:, None, None, None]
        tc = (c - c0)[None, :, None, None]
        a, b = sub[r0][:, c0], sub[r0][:, c0 + 1]
        cc, d = sub[r0 + 1][:, c0], sub[r0 + 1][:, c0 + 1]
        dbl = (1 - tr) * ((1 - tc) * a + tc * b) + tr * ((1 - tc) * cc + tc * d)
    if stack.layers[0].roughness is None:
        wi = np.asarray(wi, dtype=np.float64)
        phi_i = math.atan2(wi[1], wi[0])
        ws = np.array([[-wi[0], -wi[1], wi[2]]])
        row, col = _cells(ws)
        h_in, v_in = _hv(-wi[None, :], np.array([phi_i + math.pi]))
        h_out, v_out = _hv(ws, np.array([phi_i + math.pi]))
        jj, _, _ = _facet_jones(
            _Interface(stack, 0), np.array([[0.0, 0.0, 1.0]]), -wi[None, :], ws, h_in, v_in, h_out, v_out
        )
        single[row[0], col[0]] = mueller_from_jones(jj)[0] / projected_solid_angle()[row[0], col[0]]
    return single, dbl
