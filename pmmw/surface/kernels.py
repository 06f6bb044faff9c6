"""The surfaces' compiled per-ray steps (numba), one pass over a wave each, no temporaries: what
happens to a ray at a face, and the termination rule every step shares.

The integrator's own steps (a segment's arrival at a face, the sky, a tile's sums) are in
`pmmw.trace.kernels`, which calls these; the surface layer (`pmmw.surface.surfaces`) drives them
once per bounce:

* `scatter`: for each interacting ray, the interface's coefficients (`coefficients`: Fresnel, a
  perfect conductor, or the stack of its coherent films), the local (s, p) basis (Murakowski 2014
  eq. 2.23, 2.35), the emission of what the interface absorbs (eq. 2.36) or a sink swallows, the
  choice of branches (``render.strategy``), the reflected and transmitted children (eq.
  2.19-2.21, 2.39, 2.40) off the surface, and their termination (`survive`). On rough faces whose
  masking is compiled (GGX, Beckmann; ``MASKED``) the same pass draws the GGX facet
  (`pmmw.physics.roughness.ggx_draw1`) and sends each child off the surface or back onto it for a
  re-hit (Smith masking, `pmmw.physics.roughness.smith_g1`);
* `settle`: that masking as a pass of its own over children that `scatter` left at the hit
  point (``AT_POINT``), for models whose masking is array code and for the walk through rough
  coating layers; `cross_layer`: a ray across a rough coating layer;
* `emit`: incoherent emission seen through Jones matrices, added to the per-sample sums
  (`pmmw.physics.jones`, "Stokes from an emission event");
* `survive`/`survivors`: the depth cut-off, weight threshold and Russian roulette, and `compact`
  to drop the ended rays in place; `gather`, `tangents`, `off_surface`.

A wave is passed as a `WaveArrays` record (the fields of `pmmw.surface.Wave`), a hit as a `Hit`,
the media, faces and termination limits as `MediaTable`, `Faces` and `Limits`
(`pmmw.surface.records`: named tuples, read by name; ``Hit.code`` is a `HitCode`). Random numbers
are drawn by the caller (one per ray that may need one), so the kernels are deterministic
functions of their inputs. The compiled code is cached on disk (`pmmw.jit`);
``NUMBA_DISABLE_JIT=1`` runs the same code as Python.
"""

from __future__ import annotations

import math

import numpy as np

from pmmw.jit import inline, njit
from pmmw.physics import fresnel, multilayer, roughness
from pmmw.rng import child_key1
from pmmw.surface.media import BLACKBODY, DIELECTRIC, METAL, OPAQUE, THIN
from pmmw.surface.records import Facets, HitCode, Settle

# `Hit.code` as compiled constants (numba reads a module's int globals as constants)
_MISSED, _PASSED, _INTERACTS, _ENDED = (
    int(c) for c in (HitCode.MISSED, HitCode.PASSED, HitCode.INTERACTS, HitCode.ENDED)
)
A_ROUNDING = 1e-12  # absorbed fractions below this are rounding of lossless interfaces
_TINY = 1e-12
_NORMAL = 1e-9  # |n x k| below this: normal incidence, the ray keeps its own s

STRATEGIES = {"split": 0, "stochastic": 1, "hybrid": 2}
#: What `scatter` does with the children (its ``settle`` argument's first entry): they leave the
#: surface at once and are terminated (smooth faces); they stay at the hit point (the rough code's
#: steps that follow); or, on rough faces, each leaves or comes back by Smith masking here.
FINISH, AT_POINT, MASKED = 0, 1, 2
_I64, _I8 = np.zeros(0, np.int64), np.zeros(0, np.int8)
NO_SETTLE = Settle(FINISH, _I64, _I8, None)  # `scatter`'s children leave at once


def at_point(src, branch):
    """`scatter`'s ``settle`` argument for children left at the hit point (``AT_POINT``), each
    one's row in the wave to ``src`` and +1 (reflected) or -1 (transmitted) to ``branch``."""
    return Settle(AT_POINT, src, branch, None)


def masked(draw, u1, u2, n_geo, n_mac, u_leave, rough, over, wavelength, rehit_depth, back, counts):
    """`scatter`'s ``settle`` argument for rough faces (``MASKED``): a `Facets` record (see there
    and `scatter`), its scalars as the kernels' types. ``scatter`` is then called with ``rows``
    = arange(n) (`surfaces.Surfaces._scatter_masked`): ``u1``, ``u2`` are read by the wave's row
    and ``u_leave`` with the other uniforms by the position in ``rows``, the same index there."""
    facets = Facets(
        draw, u1, u2, n_geo, n_mac, u_leave, rough, bool(over), float(wavelength), int(rehit_depth), back, counts
    )
    return Settle(MASKED, _I64, _I8, facets)


_jit = njit()
_inline = inline()


@_inline
def _add(acc, k, n00, n01, n10, n11, ta, tb):
    """acc[k] += (Ex2, Ey2, U, V) of emission (Ta, Tb) seen through N (`jones.stokes_terms`)."""
    c = n00 * np.conj(n10) * ta + n01 * np.conj(n11) * tb
    acc[k, 0] += (n00.real**2 + n00.imag**2) * ta + (n01.real**2 + n01.imag**2) * tb
    acc[k, 1] += (n10.real**2 + n10.imag**2) * ta + (n11.real**2 + n11.imag**2) * tb
    acc[k, 2] += 2.0 * c.real
    acc[k, 3] += 2.0 * c.imag


@_jit
def emit(acc, sid, m, ta, tb):
    """Add the emission of brightness temperatures (ta, tb) [K], one per ray, seen through each
    ray's Jones matrix ``m`` (columns a, b), to ``acc[sid]``."""
    for i in range(sid.shape[0]):
        _add(acc, sid[i], m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1], ta[i], tb[i])


@_inline
def _row_powers(m00, m01, m10, m11):
    """The powers of the two rows of a Jones matrix (`jones.row_power` of one ray)."""
    return (
        m00.real**2 + m00.imag**2 + m01.real**2 + m01.imag**2,
        m10.real**2 + m10.imag**2 + m11.real**2 + m11.imag**2,
    )


@_inline
def _rebase1(m00, m01, m10, m11, s_old, p_old, s_new, p_new):
    """A Jones matrix re-expressed in a new local basis, M B (eq. 2.35; `jones.rebase` of one ray;
    the basis vectors as 3-tuples of floats)."""
    b00 = s_new[0] * s_old[0] + s_new[1] * s_old[1] + s_new[2] * s_old[2]
    b01 = p_new[0] * s_old[0] + p_new[1] * s_old[1] + p_new[2] * s_old[2]
    b10 = s_new[0] * p_old[0] + s_new[1] * p_old[1] + s_new[2] * p_old[2]
    b11 = p_new[0] * p_old[0] + p_new[1] * p_old[1] + p_new[2] * p_old[2]
    return m00 * b00 + m01 * b10, m00 * b01 + m01 * b11, m10 * b00 + m11 * b10, m10 * b01 + m11 * b11


@_inline
def _end(acc, cut, k, m00, m01, m10, m11, t_last, t_lo, t_hi):
    """End a path on ``t_last`` (Murakowski 2014 sec. 2.2.9) and count what that may have cost:
    the ended power (mean of the rows) and the rows' largest power times the largest difference
    between ``t_last`` and any brightness the path could still have seen."""
    _add(acc, k, m00, m01, m10, m11, t_last, t_last)
    r0, r1 = _row_powers(m00, m01, m10, m11)
    cut[k, 0] += 0.5 * (r0 + r1)
    cut[k, 1] += max(r0, r1) * max(t_hi - t_last, t_last - t_lo)


@_inline
def _roulette(w, threshold, u):
    """Russian roulette of a ray of weight ``w`` below ``threshold``: the factor its Jones matrix
    is scaled by, 1 / sqrt(q) if it survives (``u`` < q = w / threshold, so that its expected
    power is kept: unbiased), 0 if it ends."""
    q = w / threshold
    return 1.0 / math.sqrt(q) if u < q else 0.0


@_inline
def _fate(m00, m01, m10, m11, depth, u, limits):
    """The termination rule of one ray after an interaction (`survive`), on the entries of its
    Jones matrix alone: the factor to scale them by (1 usually, > 1 after roulette), 0 when the
    ray ends silently, -1 when it ends on the temperature of its last object (`_end`)."""
    max_depth, threshold, roulette = limits.max_depth, limits.threshold, limits.roulette
    w = max(_row_powers(m00, m01, m10, m11))
    if w <= 0.0:
        return 0.0
    if depth >= max_depth:
        return -1.0
    if w < threshold:
        return _roulette(w, threshold, u) if roulette else -1.0
    return 1.0


@_inline
def survive(acc, cut, k, m, i, depth, t_last, u, limits):
    """Termination of one ray (row ``i`` of ``m``) after an interaction: True to go on.

    ``limits = (max_depth, threshold, roulette, t_lo, t_hi)``. Beyond ``max_depth`` the path
    ends on ``t_last``; below ``threshold`` (the largest row power, `jones.row_power`) it ends
    there too, or with ``roulette`` survives with probability weight / threshold (``u`` < it)
    and is scaled up by 1 / that (unbiased). A ray with no power left ends silently.
    """
    m00, m01, m10, m11 = m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1]
    g = _fate(m00, m01, m10, m11, depth, u, limits)
    if g < 0.0:
        _end(acc, cut, k, m00, m01, m10, m11, t_last, limits.t_lo, limits.t_hi)
    if g <= 0.0:
        return False
    if g != 1.0:
        m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1] = m00 * g, m01 * g, m10 * g, m11 * g
    return True


@_jit
def survivors(wave, u, limits, acc, cut, keep):
    """`survive` for every ray of a wave (in place on its Jones matrices); ``keep`` is set."""
    m, sid, depth, last_t = wave.m, wave.sid, wave.depth, wave.last_t
    for i in range(sid.shape[0]):
        keep[i] = survive(acc, cut, sid[i], m, i, depth[i], last_t[i], u[i] if u.shape[0] else 1.0, limits)


@_inline
def _dot(a, i, b, j):
    return a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]


@_inline
def _far_eps1(kind, eps1, eps_other):
    """Permittivity beyond a face: a thin sheet keeps the incident medium on both sides; a
    blackbody is index-matched (nothing reflects at its own surface, all that enters is absorbed;
    under a coating, to the coating's last layer)."""
    return eps1 if kind == THIN or kind == BLACKBODY else eps_other


@_jit
def far_eps(kind, eps1, eps_other):
    """`_far_eps1` of arrays of rays."""
    out = np.empty(eps1.shape[0], np.complex128)
    for i in range(eps1.shape[0]):
        out[i] = _far_eps1(kind[i], eps1[i], eps_other[i])
    return out


@_inline
def _amplitude(amp, power):
    """An amplitude with the phase of ``amp`` and the magnitude sqrt(power) (renormalized R, T):
    ``amp sqrt(power / |amp|^2)``, no complex division (an amplitude below 1e-154, whose square
    underflows, is taken real: its power is below any threshold)."""
    mag2 = amp.real * amp.real + amp.imag * amp.imag
    power = max(power, 0.0)
    return amp * math.sqrt(power / mag2) if mag2 > 0.0 else complex(math.sqrt(power), 0.0)


@_inline
def _k_cross(dx, dy, dz, sx, sy, sz):
    """p = k x s of a ray of direction d (k = -d, the wave's direction of travel toward the
    detector) and basis vector s: the second vector of its (s, p) basis."""
    return -(dy * sz - dz * sy), -(dz * sx - dx * sz), -(dx * sy - dy * sx)


@_inline
def _off_surface1(ox, oy, oz, dx, dy, dz, sx, sy, sz, gx, gy, gz, step):
    """A ray at the surface (origin o, direction d, basis vector s) off it along the side normal
    g: a ray on the wrong side (``d . g <= 0``, a bump's tilt) is first mirrored through the face's
    plane (d and s reflected; the caller sets p = k x s: the power is kept), then moved by
    ``step`` along g. Returns (o, d, s, mirrored) as scalars (see `scatter` on why scalars)."""
    dg = dx * gx + dy * gy + dz * gz
    mirrored = dg <= 0.0
    if mirrored:
        sg = sx * gx + sy * gy + sz * gz
        dx, dy, dz = dx - 2.0 * dg * gx, dy - 2.0 * dg * gy, dz - 2.0 * dg * gz
        sx, sy, sz = sx - 2.0 * sg * gx, sy - 2.0 * sg * gy, sz - 2.0 * sg * gz
        dg = -dg
    side = -step if dg < 0.0 else step
    return ox + side * gx, oy + side * gy, oz + side * gz, dx, dy, dz, sx, sy, sz, mirrored


@_inline
def _scaled1(m, f):
    """Jones entries ``m`` (a 4-tuple) times the factor ``f`` that `_fate` gave (unchanged for 1)."""
    return m if f == 1.0 else (m[0] * f, m[1] * f, m[2] * f, m[3] * f)


@_inline
def _off_surface3(o, d, s, g, step):
    """`_off_surface1` on 3-tuples: (o, d, s) off the surface along g."""
    ox, oy, oz, dx, dy, dz, sx, sy, sz, _ = _off_surface1(
        o[0], o[1], o[2], d[0], d[1], d[2], s[0], s[1], s[2], g[0], g[1], g[2], step
    )
    return (ox, oy, oz), (dx, dy, dz), (sx, sy, sz)


@_inline
def _off_surface(o, d, s, p, c, gx, gy, gz, step):
    """`_off_surface1` of ray c of a wave, in place."""
    (o[c, 0], o[c, 1], o[c, 2], d[c, 0], d[c, 1], d[c, 2], s[c, 0], s[c, 1], s[c, 2], mirrored) = _off_surface1(
        o[c, 0], o[c, 1], o[c, 2], d[c, 0], d[c, 1], d[c, 2], s[c, 0], s[c, 1], s[c, 2], gx, gy, gz, step
    )
    if mirrored:
        p[c, 0], p[c, 1], p[c, 2] = _k_cross(d[c, 0], d[c, 1], d[c, 2], s[c, 0], s[c, 1], s[c, 2])


@_jit
def off_surface(wave, g, step):
    """`_off_surface` for every ray of a wave (at the surface), side normals ``g`` (n, 3) and
    steps (n,) [m]; in place."""
    for c in range(g.shape[0]):
        _off_surface(wave.o, wave.d, wave.s, wave.p, c, g[c, 0], g[c, 1], g[c, 2], step[c])


@_inline
def _film_buffers(films):
    """Room for one ray's stack of media (`_coefficients1`)."""
    n = films.count.max() + 2 if films.count.shape[0] else 2
    return np.empty(n, np.complex128), np.empty(n, np.float64)


@_inline
def _coefficients1(fm, cur, other, leaving, cos1, media, films, buf_eps, buf_d):
    """Coefficients of one ray meeting a face of medium ``fm`` from medium ``cur`` (``other``
    beyond; ``leaving`` ``fm``) at cosine ``cos1``: (rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2,
    t_absorb) (`pmmw.surface.surface_coefficients` over arrays): `_coated1` under coherent
    films, else `_bare1`. ``q2``: the far medium's normal component for refraction (outgoing
    root; NaN for a conductor); ``t_absorb`` the temperature what is absorbed emits at."""
    if media.has_coat[fm]:
        return _coated1(fm, cur, other, leaving, cos1, media, films, buf_eps, buf_d)
    eps, temperature = media.eps, media.temperature
    return _bare1(media.kind[fm], eps[cur], eps[other], cos1, temperature[cur], temperature[fm])


@_inline
def _bare1(kd, e1, e_other, cos1, t_cur, t_fm):
    """A face without films, of kind ``kd``, from permittivity ``e1`` (``e_other`` beyond): a
    perfect conductor (`fresnel.conductor1`, absorbing nothing; ``t_fm``), or a bare interface
    (`fresnel.interface1`), a lossy incident medium's remainder emitting at ``t_cur``. Scalars
    only (see `scatter`)."""
    if kd == METAL:
        rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2 = fresnel.conductor1()
        return rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2, t_fm
    rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2 = fresnel.interface1(e1, _far_eps1(kd, e1, e_other), cos1)
    return rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2, t_cur


@_inline
def _coated1(fm, cur, other, leaving, cos1, media, films, buf_eps, buf_d):
    """`_coefficients1` of a face under coherent films (eq. 2.27-2.34): the stack from ``cur``
    through them (innermost first when leaving) to the far medium, its absorption emitting at
    the films' temperature."""
    kind, eps = media.kind, media.eps
    f_start, f_count, f_eps, f_d = films.start, films.count, films.eps, films.thickness
    kd = kind[fm]
    e1 = eps[cur]
    nf, st = f_count[fm], f_start[fm]
    buf_eps[0] = e1
    for q in range(nf):
        f = st + (nf - 1 - q if leaving else q)
        buf_eps[1 + q], buf_d[q] = f_eps[f], f_d[f]
    # a blackbody is index-matched to the films' innermost layer
    buf_eps[nf + 1] = f_eps[st + nf - 1] if kd == BLACKBODY else _far_eps1(kd, e1, eps[other])
    rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap = multilayer.stack1(
        buf_eps[: nf + 2], buf_d[:nf], cos1, films.k0, kd == METAL
    )
    q2 = complex(np.nan, 0.0)
    if kd == DIELECTRIC:
        eo = eps[other]
        kpar2 = e1 * (1.0 - cos1**2)
        q2 = fresnel._root1(eo - kpar2, fresnel._l1(eo) + fresnel._l1(kpar2), False)
    return rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2, films.temperature[fm]


@_jit
def coefficients(cur, face_med, other, leaving, cos1, media, films, amp, power, q2, t_absorb):
    """`_coefficients1` of arrays of rays (shape (n,)): amplitudes (rs, rp, ts, tp) in ``amp``
    (n, 4), powers (Rs, Rp, Ts, Tp, As, Ap) in ``power`` (n, 6), ``q2`` and ``t_absorb`` (n,)."""
    buf_eps, buf_d = _film_buffers(films)
    for i in range(cos1.shape[0]):
        rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2[i], t_absorb[i] = _coefficients1(
            face_med[i], cur[i], other[i], leaving[i], cos1[i], media, films, buf_eps, buf_d
        )
        amp[i, 0], amp[i, 1], amp[i, 2], amp[i, 3] = rs, rp, ts, tp
        power[i, 0], power[i, 1], power[i, 2], power[i, 3], power[i, 4], power[i, 5] = Rs, Rp, Ts, Tp, As, Ap


@_inline
def _masked_side1(side, diel, cur, other, leaving):
    """The media of the side a masked child is on, seen from there (cur, other, leaving): a
    reflected child (``side`` > 0) keeps them, a refracted one swaps them, a thin sheet's
    transmitted child keeps them."""
    if side < 0.0 and diel:
        return other, cur, not leaving
    return cur, other, leaving


@_inline
def _to_next_facet1(alpha, wavelength):
    """A masked child's way to the next facet, one wavelength of its side's medium (extinction
    ``alpha`` [1/m]): transmittance, and the amplitude factors of what it emits and keeps."""
    tau = math.exp(-alpha * wavelength)
    return tau, math.sqrt(1.0 - tau), math.sqrt(tau)


@_jit
def scatter(rows, wave, hit, films, prim, faces, media, choice, u_choose, u_roul, limits, acc, cut, out, settle):
    """Interactions of the rays ``rows`` of a wave with the faces they hit (`arrive` filled
    ``hit``); their children are written to ``out`` (room for two per row). Returns how many
    (with ``MASKED``: how many leave).

    What the surface does to a ray (its response, as pbrt's BxDF: the facet drawn, `_facet1`;
    the local basis and the interface's coefficients, `_response1`; each child's direction and
    amplitudes, `_child1`; its masking, `_leaves1`) is apart from the integrator's bookkeeping
    in `_scatter` (the emission deposited, the branch choice, termination and Russian roulette,
    the child's row, offset and medium stack, a masked child's way back).

    Parameters
    ----------
    hit : Hit
        As `arrive` fills it; on a rough face ``n_in`` is the facet normal drawn for the ray and
        ``cos1`` the cosine about it (with ``MASKED``: the macro normal, or the facet normal a
        model without a compiled draw gave, and ``cos1`` is not read).
    films : Films
        The media's coherent films. A face under films is the stack from the incident medium
        through them (innermost first for a ray leaving the body) to the far medium
        (`multilayer.stack1`); a bare interface `fresnel.interface1`, a perfect conductor
        `fresnel.conductor1`.
    prim, faces, media : the face each row hit, `Faces`, `MediaTable`
    choice : Choice
    u_choose, u_roul : ndarray
        Uniforms for the branch choice (one per row; empty with ``split``) and Russian roulette
        (two per row, the reflected child's first; empty without roulette; read by ``FINISH`` and
        ``MASKED``).
    limits, acc, cut : `Limits`, the per-sample sums and truncation sums (`survive`)
    out : WaveArrays
    settle : Settle
        ``FINISH`` (`NO_SETTLE`): the children leave the surface here (offset along the side
        normal, then `survive`). ``AT_POINT`` (`at_point`; the rough code's steps decide what
        follows): they stay at the hit point, unterminated, and ``src``/``branch`` receive each
        child's row in the wave and +1 (reflected) or -1 (transmitted). ``MASKED`` (`masked`):
        a rough face's whole interaction, `Surfaces._interact` without the steps between
        kernels, its `Facets`: where ``draw[face_med]``, the GGX facet drawn here from ``u1``,
        ``u2`` (`roughness.ggx_draw1` about the `_tangent1` frame; a facet that faces away: the
        power emitted at the face's temperature, the ray goes on with none about the macro
        normal). Each child then leaves (terminated by `survive` with ``u_roul`` as with
        ``FINISH``, then off the surface as `settle` sends it: rows 0, 1, ... of ``out``) unless
        its ``u_leave`` (two per row, the reflected child's first) is at or above its
        Smith masking probability (`roughness.smith_g1`); a masked child emits its power at the
        face's temperature if ``over`` (the chain's end), else it crosses one ``wavelength`` of
        its side's medium and comes back for a re-hit (depth changed by ``rehit_depth``): rows
        ``len(out) - 1``, ``len(out) - 2``, ... of ``out``, its row, media and branch in
        ``back`` as `settle` fills them; ``counts`` as `Facets` says. Each child's ``key`` is
        its parent's hashed with its branch (`pmmw.rng.child_key1`).
    """
    return _scatter(
        rows,
        wave,
        hit,
        films,
        prim,
        faces,
        media,
        choice,
        u_choose,
        u_roul,
        limits,
        acc,
        cut,
        out,
        settle.mode,
        settle.src,
        settle.branch,
        settle.facets,
    )


# -- the surface's response to one ray (scalars in, scalars out: see `_scatter`) ---------------


@_inline
def _facet1(nx, ny, nz, mx, my, mz, tx, ty, tz, dx, dy, dz, u1, u2, ax, ay, orient):
    """The GGX facet visible from a ray of direction d on a rough face of macro normal m and
    tangent t (`roughness.ggx_draw1`), and the draw's weight; where no facet is visible (weight
    0, degenerate input only) the normal n it had."""
    fx, fy, fz, w = roughness.ggx_draw1((mx, my, mz), (tx, ty, tz), (-dx, -dy, -dz), u1, u2, ax, ay, orient)
    if w > 0.0:
        return fx, fy, fz, w
    return nx, ny, nz, w


@_inline
def _response1(nx, ny, nz, dx, dy, dz, s_old, p_old, m00, m01, m10, m11):
    """The ray's outgoing (s, p) basis about the normal n (s = unit(n x k), k = -d, eq. 2.23; the
    ray's own s at normal incidence; p = k x s) and its Jones matrix re-expressed in it (eq.
    2.35): (sx, sy, sz, px, py, pz, ml00, ml01, ml10, ml11)."""
    sx, sy, sz = -(ny * dz - nz * dy), -(nz * dx - nx * dz), -(nx * dy - ny * dx)
    norm = math.sqrt(sx * sx + sy * sy + sz * sz)
    if norm > _NORMAL:
        sx, sy, sz = sx / norm, sy / norm, sz / norm
    else:
        sx, sy, sz = s_old
    px, py, pz = _k_cross(dx, dy, dz, sx, sy, sz)
    ml00, ml01, ml10, ml11 = _rebase1(m00, m01, m10, m11, s_old, p_old, (sx, sy, sz), (px, py, pz))
    return sx, sy, sz, px, py, pz, ml00, ml01, ml10, ml11


@_inline
def _child1(br, dx, dy, dz, nx, ny, nz, rs, rp, ts, tp, Rs, Rp, Ts, Tp, q2, n1, diel):
    """The reflected (``br`` 0, eq. 2.21, 2.39: on the incident side, along +n) or transmitted
    child (eq. 2.19, 2.40: refracted into the other medium, straight through a sheet) of a ray of
    direction d at a face of normal n: its direction and (s, p) amplitudes (renormalized to the
    powers R, T). The refracted wave is homogeneous (sec. 2.2.4): the tangential part kept
    (eq. 2.18), the normal part Re q2 of the outgoing root (eq. 2.20): Snell's law for lossless
    media; ``n1`` the incident side's real index."""
    dn = dx * nx + dy * ny + dz * nz
    if br == 0:
        return dx - 2.0 * dn * nx, dy - 2.0 * dn * ny, dz - 2.0 * dn * nz, _amplitude(rs, Rs), _amplitude(rp, Rp)
    if not diel:
        return dx, dy, dz, _amplitude(ts, Ts), _amplitude(tp, Tp)
    qr = q2.real
    cx = n1 * (dx - dn * nx) - qr * nx
    cy = n1 * (dy - dn * ny) - qr * ny
    cz = n1 * (dz - dn * nz) - qr * nz
    norm = math.sqrt(cx * cx + cy * cy + cz * cz)
    return cx / norm, cy / norm, cz / norm, _amplitude(ts, Ts), _amplitude(tp, Tp)


@_inline
def _leaves1(side, mx, my, mz, tx, ty, tz, cx, cy, cz, code, ax, ay, orient, u):
    """Whether a child of direction c leaves a rough face's microsurface: unless ``u`` (uniform)
    is at or above Smith's masking probability G1 = (c . m') / A(c) (Heitz 2014; the model
    ``code`` of widths ``ax``, ``ay``, `roughness.smith_g1`) about the macro normal m' =
    ``side`` m of the child's side (m facing the incident side, tangent t). A NaN G1 lets it
    leave, as the array code's masking test reads."""
    g1 = roughness.smith_g1((side * mx, side * my, side * mz), (tx, ty, tz), (cx, cy, cz), code, ax, ay, orient)
    return not u >= g1


@_inline
def _rough_normal1(nx, ny, nz, dx, dy, dz, mac, code, draw, u1, u2, ax, ay, orient):
    """The normal a ray of direction d meets on a rough face of macro normal ``mac`` (3-tuple)
    and roughness model ``code`` (widths ``ax``, ``ay``): the GGX facet drawn from ``u1``, ``u2``
    (`_facet1`) where the model has a compiled draw (``draw``), else the normal n it had (weight
    1); and the tangent of the face's masking frame (`_tangent1`; zeros on a smooth face).
    Returns (nx, ny, nz, w, tx, ty, tz)."""
    tx, ty, tz, w = 0.0, 0.0, 0.0, 1.0
    if code != roughness.NOT_ROUGH:
        tx, ty, tz = _tangent1(mac[0], mac[1], mac[2])
    if draw:
        nx, ny, nz, w = _facet1(nx, ny, nz, mac[0], mac[1], mac[2], tx, ty, tz, dx, dy, dz, u1, u2, ax, ay, orient)
    return nx, ny, nz, w, tx, ty, tz


# -- the integrator's bookkeeping ---------------------------------------------------------------


@_inline
def _emit_absorbed(acc, k, ml00, ml01, ml10, ml11, fa, fb, t):
    """Deposit in ``acc[k]`` the emission of the power fractions ``fa``, ``fb`` that a face takes
    from the s and p columns of a ray's Jones matrix (``ml``, in the local basis) and emits at
    ``t`` [K] (Murakowski 2014 eq. 2.36: emissivity = absorptivity): what an interface or its films
    absorb, or what a sink swallows. Straight-line on purpose (see `_scatter`)."""
    ea, eb = math.sqrt(fa), math.sqrt(fb)
    _add(acc, k, ml00 * ea, ml01 * eb, ml10 * ea, ml11 * eb, t, t)


@_inline
def _choose1(ml00, ml01, ml10, ml11, Rs, Rp, Ts, Tp, u):
    """One branch drawn by power (``render.strategy``): the branches' shares of the power the ray
    carries (its Jones columns' powers times R and T), so that for a lossless interface the chosen
    child keeps that power exactly. Returns (keep_r, keep_t, gain_r, gain_t)."""
    c0 = ml00.real**2 + ml00.imag**2 + ml10.real**2 + ml10.imag**2
    c1 = ml01.real**2 + ml01.imag**2 + ml11.real**2 + ml11.imag**2
    r_sum, t_sum = c0 * Rs + c1 * Rp, c0 * Ts + c1 * Tp
    p_r = r_sum / max(r_sum + t_sum, _TINY)
    if u < p_r:
        return True, False, 1.0 / math.sqrt(p_r), 1.0
    return False, True, 1.0, 1.0 / math.sqrt(1.0 - p_r)


@_inline
def _branches1(choice, trans, depth, ml00, ml01, ml10, ml11, Rs, Rp, Ts, Tp, u):
    """Which children a ray makes (`Choice`): the reflected one, and the transmitted one where the
    face transmits (``trans``); with ``stochastic``, or ``hybrid`` from ``split_depth`` on, one of
    them drawn by power with uniform ``u`` (`_choose1`). Returns (keep_r, keep_t, gain_r, gain_t),
    the gains the drawn child's amplitudes are scaled by (unbiased: 1 / sqrt(its probability))."""
    if choice.strategy != 0 and trans and (choice.strategy == 1 or depth >= choice.split_depth):
        return _choose1(ml00, ml01, ml10, ml11, Rs, Rp, Ts, Tp, u)
    return True, trans, 1.0, 1.0


@_inline
def _side1(br, diel, leaving, top):
    """The side a child is on, +1 (reflected: the incident side) or -1 (transmitted: beyond the
    face), and the top of its medium stack: a refracted child leaving the body pops its medium,
    one entering it pushes it (a thin sheet's transmitted child keeps the stack)."""
    if br == 0:
        return 1.0, top
    if diel:
        return -1.0, (top - 1 if leaving else top + 1)
    return -1.0, top


@_inline
def _masked1(acc, k, m, over, t_over, alpha, t_medium, wavelength):
    """A masked child of a rough face, Jones entries ``m`` (m00, m01, m10, m11): at the re-hit
    chain's end (``over``) its power is emitted at ``t_over`` [K] and it ends; else it crosses one
    ``wavelength`` [m] of its side's medium (`_masked_side1`; extinction ``alpha`` [1/m]) to the
    next facet (Heitz et al. 2016's walk on the microsurface), emitting what that medium absorbs
    at its temperature ``t_medium`` [K] (Murakowski 2014 eq. 2.37, 2.38). Returns (comes back,
    m): its Jones entries after the crossing; False when nothing is left beyond rounding."""
    if over:
        _add(acc, k, m[0], m[1], m[2], m[3], t_over, t_over)
        return False, m
    tau, e, g = _to_next_facet1(alpha, wavelength)
    if tau < 1.0:
        _add(acc, k, m[0] * e, m[1] * e, m[2] * e, m[3] * e, t_medium, t_medium)
        m = (m[0] * g, m[1] * g, m[2] * g, m[3] * g)
    return tau > A_ROUNDING, m


@_inline
def _put_child(out, row, o, c, s, m, k, depth, t_last, key, stack, i, stack_top, top, pushed):
    """Write a child to row ``row`` of the wave ``out``: origin, direction and basis vector s
    (3-tuples; p = k x s with k = -c), Jones entries ``m`` (m00, m01, m10, m11), sample ``k``,
    ``depth``, the temperature of its last object ``t_last``, its ``key``, and its medium stack:
    its parent's (row ``i`` of ``stack``, whose top is ``stack_top``) with ``pushed`` on top
    where its ``top`` rose above that (a refracted child entering a body, `_side1`)."""
    out.d[row, 0], out.d[row, 1], out.d[row, 2] = c
    out.s[row, 0], out.s[row, 1], out.s[row, 2] = s
    out.p[row, 0], out.p[row, 1], out.p[row, 2] = _k_cross(c[0], c[1], c[2], s[0], s[1], s[2])
    out.o[row, 0], out.o[row, 1], out.o[row, 2] = o
    out.m[row, 0, 0], out.m[row, 0, 1], out.m[row, 1, 0], out.m[row, 1, 1] = m
    out.sid[row], out.depth[row], out.top[row], out.last_t[row], out.key[row] = k, depth, top, t_last, key
    ostack = out.stack
    for a in range(stack.shape[1]):
        ostack[row, a] = stack[i, a]
    if top > stack_top:
        ostack[row, top] = pushed


@_jit
def _scatter(rows, wave, hit, films, prim, faces, media, choice, u_choose, u_roul, limits, acc, cut, out, mode, src,
             branch, facets):  # fmt: skip
    """`scatter` with its ``settle`` unpacked: ``facets`` is None but with ``MASKED``, so that
    numba compiles the smooth kernels without the rough faces' steps (they cost smooth scenes
    6 % of an interaction as run-time branches). For each ray, the surface's response (the
    normal met `_rough_normal1`, the local basis `_response1`, the coefficients `_coated1` or
    `_bare1`, each child's direction and amplitudes `_child1` and masking `_leaves1`) and the
    integrator's bookkeeping around it: the emission of what the face absorbs (`_emit_absorbed`),
    the branch choice (`_branches1`), and each child's fate: termination and roulette (`_fate`,
    `_end`: `survive`), the way off the surface (`_off_surface3`) or a masked child's way back
    (`_masked1`), its side, medium stack and row (`_side1`, `_put_child`).

    numba counts references to an array handed to a helper, and LLVM drops the counting where
    it inlines straight-line code (`_add`, `_end`, `_emit_absorbed`) but not around every
    branch: a first cut of this split that handed the tables and sums to helpers with branches
    (the termination, the rough face's normal, the coefficients) ran the rough scene's trace at
    `pmmw bench`'s trace x workers / Embree ratio 8.9-10.0 against 5.7-6.3. So the hot helpers
    take scalars, except `_put_child` (the child's row) and `_masked1` (a masked child's sums),
    which take arrays and branch: the machine code then has 5 / 6 / 2 incref call sites (smooth
    `scatter` / masked `scatter` / `settle`) against 6 / 6 / 1 before the split, and the
    renders' timings show no cost (`pmmw bench`: median trace ratio 0.94-0.99 of before)."""
    finish = mode == FINISH
    d, s_old, p_old, m, sid, depth, stack, top = wave.d, wave.s, wave.p, wave.m, wave.sid, wave.depth, wave.stack, wave.top  # fmt: skip
    pos, n_in, cos1_a, cur_a, fm_a, other_a, leaving_a = hit.pos, hit.n_in, hit.cos1, hit.cur, hit.face_med, hit.other, hit.leaving  # fmt: skip
    kind, temperature, n1_real, has_coat, eps = media.kind, media.temperature, media.n1_real, media.has_coat, media.eps
    key, offset = wave.key, faces.offset
    buf_eps, buf_d = _film_buffers(films)
    roulette, last_row = u_roul.shape[0] > 0, out.o.shape[0] - 1
    if facets is not None:
        n_mac, n_geo, rough, back, alpha = facets.n_mac, facets.n_geo, facets.rough, facets.back, media.alpha
    n_out, n_back, drawn_off = 0, 0, 0
    for j in range(rows.shape[0]):
        i = rows[j]
        k, fm = sid[i], fm_a[i]
        kd, t_body = kind[fm], temperature[fm]
        nx, ny, nz = n_in[i, 0], n_in[i, 1], n_in[i, 2]
        dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
        if facets is not None:
            nx, ny, nz, w, tx, ty, tz = _rough_normal1(
                nx, ny, nz, dx, dy, dz, (n_mac[i, 0], n_mac[i, 1], n_mac[i, 2]), rough.code[fm], facets.draw[fm],
                facets.u1[i], facets.u2[i], rough.alpha_x[fm], rough.alpha_y[fm], rough.orientation[fm],
            )  # fmt: skip
            drawn_off += w != 1.0
            if not w > 0.0:  # no facet visible (degenerate input only): the power emitted here, none goes on
                _add(acc, k, m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1], t_body, t_body)
                m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1] = 0j, 0j, 0j, 0j
        cos1 = min(max(-(dx * nx + dy * ny + dz * nz), 0.0), 1.0) if facets is not None else cos1_a[i]
        sx, sy, sz, px, py, pz, ml00, ml01, ml10, ml11 = _response1(
            nx, ny, nz, dx, dy, dz, (s_old[i, 0], s_old[i, 1], s_old[i, 2]), (p_old[i, 0], p_old[i, 1], p_old[i, 2]),
            m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1],
        )  # fmt: skip
        if has_coat[fm]:  # (`_coefficients1`, the bare face's branch on scalars: see above)
            coef = _coated1(fm, cur_a[i], other_a[i], leaving_a[i], cos1, media, films, buf_eps, buf_d)
        else:
            coef = _bare1(kd, eps[cur_a[i]], eps[other_a[i]], cos1, temperature[cur_a[i]], t_body)
        rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2c, t_abs = coef
        if As > A_ROUNDING or Ap > A_ROUNDING:  # what the interface (or its films) absorbs
            _emit_absorbed(acc, k, ml00, ml01, ml10, ml11, As, Ap, t_abs)
        if kd == BLACKBODY or kd == OPAQUE:  # what a sink swallows
            _emit_absorbed(acc, k, ml00, ml01, ml10, ml11, Ts, Tp, t_body)
        diel = kd == DIELECTRIC
        trans = (diel or kd == THIN) and (Ts > 0.0 or Tp > 0.0)
        u = u_choose[j] if u_choose.shape[0] else 0.0
        keep_r, keep_t, gain_r, gain_t = _branches1(choice, trans, depth[i], ml00, ml01, ml10, ml11, Rs, Rp, Ts, Tp, u)
        for br in range(2):
            if not (keep_t if br else keep_r):
                continue
            cx, cy, cz, a_s, a_p = _child1(br, dx, dy, dz, nx, ny, nz, rs, rp, ts, tp, Rs, Rp, Ts, Tp, q2c,
                                           n1_real[cur_a[i]], diel)  # fmt: skip
            gain = gain_t if br else gain_r
            mc = (ml00 * (gain * a_s), ml01 * (gain * a_p), ml10 * (gain * a_s), ml11 * (gain * a_p))
            side, top_c = _side1(br, diel, leaving_a[i], top[i])
            o, c, s_c, leaves = (pos[i, 0], pos[i, 1], pos[i, 2]), (cx, cy, cz), (sx, sy, sz), True
            if facets is not None and rough.code[fm] != roughness.NOT_ROUGH:  # masked by the microsurface?
                leaves = _leaves1(
                    side, n_mac[i, 0], n_mac[i, 1], n_mac[i, 2], tx, ty, tz, cx, cy, cz, rough.code[fm],
                    rough.alpha_x[fm], rough.alpha_y[fm], rough.orientation[fm], facets.u_leave[2 * j + br],
                )  # fmt: skip
            if leaves and (finish or facets is not None):  # terminated (`survive`), then off the surface
                f = _fate(mc[0], mc[1], mc[2], mc[3], depth[i] + 1, u_roul[2 * j + br] if roulette else 1.0, limits)
                if f < 0.0:
                    _end(acc, cut, k, mc[0], mc[1], mc[2], mc[3], t_body, limits.t_lo, limits.t_hi)
                if f <= 0.0:
                    continue
                mc = _scaled1(mc, f)
                g = (n_geo[i, 0], n_geo[i, 1], n_geo[i, 2]) if facets is not None else (nx, ny, nz)
                o, c, s_c = _off_surface3(o, c, s_c, (side * g[0], side * g[1], side * g[2]), offset[prim[i]])
            row, depth_row = n_out, depth[i] + 1
            if facets is not None and not leaves:  # masked: back for a re-hit, at the rows from the end of `out`
                cur, oth, lv = _masked_side1(side, diel, cur_a[i], other_a[i], leaving_a[i])
                on, mc = _masked1(acc, k, mc, facets.over, t_body, alpha[cur], temperature[cur], facets.wavelength)
                if not on:
                    continue
                row, depth_row = last_row - n_back, depth_row + facets.rehit_depth
                back.src[n_back], back.cur[n_back], back.other[n_back] = i, cur, oth
                back.leaving[n_back], back.sign[n_back] = lv, side
                n_back += 1
            _put_child(out, row, o, c, s_c, mc, k, depth_row, t_body, child_key1(key[i], br), stack, i, top[i], top_c,
                       fm)  # fmt: skip
            if mode == AT_POINT:
                src[row], branch[row] = i, 1 - 2 * br
            n_out += leaves
    if facets is not None:
        facets.counts[0] += drawn_off
        facets.counts[2] = n_back
    return n_out


@_jit
def gather(src, rows, dst):
    """Rows ``rows`` of wave ``src`` to rows 0, 1, ... of wave ``dst`` (the same wave when every
    ``rows[n] >= n``: in place). One call per wave: numba counts references to arrays handed to a
    helper, at a cost above a row's copy, so the arrays are unpacked once here."""
    o, d, s, p, m, sid, depth, stack, top, last_t, key = (
        src.o,
        src.d,
        src.s,
        src.p,
        src.m,
        src.sid,
        src.depth,
        src.stack,
        src.top,
        src.last_t,
        src.key,
    )
    o2, d2, s2, p2, m2 = dst.o, dst.d, dst.s, dst.p, dst.m
    sid2, depth2, stack2, top2, last_t2, key2 = dst.sid, dst.depth, dst.stack, dst.top, dst.last_t, dst.key
    for n in range(rows.shape[0]):
        c = rows[n]
        for a in range(3):
            o2[n, a], d2[n, a], s2[n, a], p2[n, a] = o[c, a], d[c, a], s[c, a], p[c, a]
        m2[n, 0, 0], m2[n, 0, 1], m2[n, 1, 0], m2[n, 1, 1] = m[c, 0, 0], m[c, 0, 1], m[c, 1, 0], m[c, 1, 1]
        sid2[n], depth2[n], top2[n], last_t2[n], key2[n] = sid[c], depth[c], top[c], last_t[c], key[c]
        for a in range(stack.shape[1]):
            stack2[n, a] = stack[c, a]


@_inline
def _tangent1(n0, n1, n2):
    """The unit anisotropy tangent of a rough face of unit normal n: world X projected onto the
    plane normal to n (world Y where n is within 26 degrees of X)."""
    t0, t1 = (0.0, 1.0) if abs(n0) > 0.9 else (1.0, 0.0)
    tn = t0 * n0 + t1 * n1
    x0, x1, x2 = t0 - tn * n0, t1 - tn * n1, -tn * n2
    norm = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    return x0 / norm, x1 / norm, x2 / norm


@_jit
def tangents(n, out):
    """`_tangent1` of each unit normal, shape (N, 3)."""
    for i in range(n.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = _tangent1(n[i, 0], n[i, 1], n[i, 2])


@_jit
def compact(wave, keep):
    """Move the rows of a wave with ``keep`` to its front, in order (in place: the wave's arrays
    must not be shared); returns how many."""
    rows = np.flatnonzero(keep)
    gather(wave, rows, wave)
    return rows.shape[0]


@_jit
def settle(
    kids,
    src,
    branch,
    u_leave,
    p_leave,
    hit,
    n_mac,
    tangent,
    step,
    chain_end,
    media,
    rough,
    wavelength,
    acc,
    leave,
    back,
    back_side,
    leave_side,
    finish,
    rehit_depth,
    fate,
):
    """Children of a rough surface's facets (`scatter` with ``finish`` False) sent off the
    surface or back onto it (`Surfaces._settle`, which describes the rule), or between the
    interfaces of rough coating layers (`Surfaces._layer_step`: ``finish`` False).

    Parameters
    ----------
    kids : tuple of arrays (a wave)
        The children, at their hit points; ``src`` their row in ``hit`` and ``branch`` +1
        (reflected) or -1 (transmitted).
    u_leave : ndarray, shape (n,)
        Uniforms of the children of rough faces: a child leaves unless ``u_leave >= G1``,
        Smith's masking probability about the macro normal of its side.
    p_leave : ndarray, shape (n,)
        G1 of the children of faces whose roughness model is not compiled
        (`roughness.OTHER_CODE`), computed by the caller; read for those only.
    hit : tuple (pos, n_geo, cos1, cur, face_med, other, leaving, code)
        The interacting rows (``n_geo``: the face normal facing the incident side).
    n_mac, tangent : ndarray, shape (rows, 3)
        Macro normals facing the incident side, and the anisotropy tangents (`roughness.local_frame`).
    step : ndarray, shape (rows,)
        Offset off the face [m].
    chain_end : tuple (over, t_end)
        ``over`` (rows,) bool: the re-hit chain of the row is at its end, and a masked child's
        power is emitted at ``t_end`` (rows, 2) [K] (column 0 for reflected children, 1 for
        transmitted ones).
    media : tuple (kind, alpha, temperature, ...)
    rough : tuple (code, alpha_x, alpha_y, orientation) of arrays, one entry per medium
        The media's roughness models (`roughness.smith_g1`'s codes; `roughness.NOT_ROUGH`: smooth).
    wavelength : float
        [m]: the way a masked child crosses in its medium to the next facet.
    leave, back : tuple of arrays (waves)
        Filled with the children that leave (off the surface, a wrong-side child mirrored
        through the face's plane) and those that re-hit (at the hit point, one wavelength's
        absorption applied and emitted, depth changed by ``rehit_depth``).
    back_side : tuple (src, cur, other, leaving, sign)
        Filled for each re-hitting child: its row in ``hit``, the media of its side seen from
        there, and its branch.
    leave_side : tuple (src, sign)
        Filled for each leaving child: its row in ``hit`` and its branch.
    finish : bool
        Leaving children are terminated (`survive`) and leave the surface here (mirrored to the
        right side of the face and offset along it); otherwise they are left at the hit point as
        they are.
    rehit_depth : int
        Added to a re-hitting child's depth: -1 in the renderer (a chain of facets at one point
        is one interaction), 0 where depth counts facet events (`pmmw brdf`'s orders).
    fate : tuple (u_roul, limits, cut)
        With ``finish``: Russian roulette's uniforms, two per row of ``hit`` (the reflected
        child's first, as `scatter` reads them; empty without roulette), ``survive``'s limits and
        truncation sums.

    Returns
    -------
    (int, int)
        How many children leave and how many re-hit.
    """
    pos, n_geo, cur_a, fm_a, other_a, leaving_a = hit.pos, hit.n_in, hit.cur, hit.face_med, hit.other, hit.leaving
    o, d, s, p, m, sid, k_depth, k_last = kids.o, kids.d, kids.s, kids.p, kids.m, kids.sid, kids.depth, kids.last_t
    kind, alpha, temperature, over, t_end = media.kind, media.alpha, media.temperature, chain_end.over, chain_end.t_end
    r_code, r_ax, r_ay, r_orient = rough.code, rough.alpha_x, rough.alpha_y, rough.orientation
    b_src, b_cur, b_other, b_leaving, b_sign = back_side.src, back_side.cur, back_side.other, back_side.leaving, back_side.sign  # fmt: skip
    l_src, l_sign = leave_side.src, leave_side.sign
    u_roul, limits, cut = fate.u_roul, fate.limits, fate.cut
    roulette = u_roul.shape[0] > 0
    l_rows, b_rows = np.empty(src.shape[0], np.int64), np.empty(src.shape[0], np.int64)
    nl, nb = 0, 0
    for c in range(src.shape[0]):
        i, sg = src[c], float(branch[c])
        fm = fm_a[i]
        code, leaves = r_code[fm], True
        if code == roughness.OTHER_CODE:  # (NaN: leaves, as the masking test reads)
            leaves = not u_leave[c] >= p_leave[c]
        elif code != roughness.NOT_ROUGH:
            leaves = _leaves1(
                sg, n_mac[i, 0], n_mac[i, 1], n_mac[i, 2], tangent[i, 0], tangent[i, 1], tangent[i, 2],
                d[c, 0], d[c, 1], d[c, 2], code, r_ax[fm], r_ay[fm], r_orient[fm], u_leave[c],
            )  # fmt: skip
        if leaves:
            if finish:  # terminated (`survive`), then off the surface (a wrong-side child mirrored), as `scatter` does
                mc = (m[c, 0, 0], m[c, 0, 1], m[c, 1, 0], m[c, 1, 1])
                u = u_roul[2 * i + (0 if sg > 0.0 else 1)] if roulette else 1.0
                f = _fate(mc[0], mc[1], mc[2], mc[3], k_depth[c], u, limits)
                if f < 0.0:
                    _end(acc, cut, sid[c], mc[0], mc[1], mc[2], mc[3], k_last[c], limits.t_lo, limits.t_hi)
                if f <= 0.0:
                    continue
                if f != 1.0:
                    m[c, 0, 0], m[c, 0, 1], m[c, 1, 0], m[c, 1, 1] = mc[0] * f, mc[1] * f, mc[2] * f, mc[3] * f
                g = (sg * n_geo[i, 0], sg * n_geo[i, 1], sg * n_geo[i, 2])
                o[c, 0], o[c, 1], o[c, 2], d[c, 0], d[c, 1], d[c, 2], s[c, 0], s[c, 1], s[c, 2], mirrored = _off_surface1(
                    o[c, 0], o[c, 1], o[c, 2], d[c, 0], d[c, 1], d[c, 2], s[c, 0], s[c, 1], s[c, 2], g[0], g[1], g[2], step[i]
                )  # fmt: skip
                if mirrored:
                    p[c, 0], p[c, 1], p[c, 2] = _k_cross(d[c, 0], d[c, 1], d[c, 2], s[c, 0], s[c, 1], s[c, 2])
            l_src[nl], l_sign[nl], l_rows[nl] = i, sg, c
            nl += 1
            continue
        te = t_end[i, 0] if sg > 0.0 else t_end[i, 1]
        cur, oth, lv = _masked_side1(sg, kind[fm] == DIELECTRIC, cur_a[i], other_a[i], leaving_a[i])
        mc = (m[c, 0, 0], m[c, 0, 1], m[c, 1, 0], m[c, 1, 1])
        on, mc = _masked1(acc, sid[c], mc, over[i], te, alpha[cur], temperature[cur], wavelength)
        m[c, 0, 0], m[c, 0, 1], m[c, 1, 0], m[c, 1, 1] = mc
        if not on:
            continue
        b_src[nb], b_cur[nb], b_other[nb] = i, cur, oth
        b_leaving[nb], b_sign[nb], b_rows[nb] = lv, sg, c
        nb += 1
    gather(kids, l_rows[:nl], leave)
    gather(kids, b_rows[:nb], back)
    b_o, b_depth = back.o, back.depth
    for j in range(nb):  # a re-hit starts at the hit point
        i = b_src[j]
        b_o[j, 0], b_o[j, 1], b_o[j, 2] = pos[i, 0], pos[i, 1], pos[i, 2]
        b_depth[j] += rehit_depth
    return nl, nb


@_jit
def cross_layer(wave, n, rows, alpha, thickness, temperature, acc):
    """Rays of a wave across a rough coating layer to its next interface (`Surfaces._layer_step`),
    in place: each attenuated by exp(-alpha t / |cos|) (its direction against the layer's normal
    ``n[rows[c]]``, the cosine kept above 1e-6) and emitting what it loses at ``temperature``
    [K] (Murakowski 2014 eq. 2.37, 2.38); ``alpha`` [1/m], ``thickness`` [m]."""
    d, m, sid = wave.d, wave.m, wave.sid
    for c in range(d.shape[0]):
        i = rows[c]
        cos_t = max(abs(d[c, 0] * n[i, 0] + d[c, 1] * n[i, 1] + d[c, 2] * n[i, 2]), 1e-6)
        tau = math.exp(-alpha * thickness / cos_t)
        if tau < 1.0:
            e, g = math.sqrt(1.0 - tau), math.sqrt(tau)
            m00, m01, m10, m11 = m[c, 0, 0], m[c, 0, 1], m[c, 1, 0], m[c, 1, 1]
            _add(acc, sid[c], m00 * e, m01 * e, m10 * e, m11 * e, temperature, temperature)
            m[c, 0, 0], m[c, 0, 1], m[c, 1, 0], m[c, 1, 1] = m00 * g, m01 * g, m10 * g, m11 * g
