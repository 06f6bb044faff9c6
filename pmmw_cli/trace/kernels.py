"""Compiled per-ray steps of the bounce loop (numba), one pass over a wave each, no temporaries.

The integrator (`pmmw_cli.trace.integrator`) keeps what is vectorized well or happens once per
wave: the Embree call, the sky and atmosphere models, and the interface coefficients (Fresnel and
coherent films, `Integrator._coefficients`). Everything per ray between them runs here:

* `arrive`: for each ray that hit a face, the atmosphere's and the medium's absorption and
  emission along the segment (Murakowski 2014 eq. 2.37, 2.38), the medium stack (sec. 2.2.9),
  and whether it interacts with the face or passes through it (then moved across it here);
* `scatter`: for each interacting ray, the local (s, p) basis (eq. 2.23, 2.35), the emission of
  what the interface absorbs (eq. 2.36) or a sink swallows, the choice of branches
  (``render.strategy``), the reflected and transmitted children (eq. 2.19-2.21, 2.39, 2.40) off
  the surface, and their termination (`survive`);
* `emit`: incoherent emission seen through Jones matrices, added to the per-sample sums
  (`pmmw_cli.physics.jones`, "Stokes from an emission event");
* `survivors`: the depth cut-off, weight threshold and Russian roulette for a wave (the
  rough-surface code's children; `scatter` applies the same `survive` to its own).

A wave is passed as a tuple ``(o, d, s, p, m, sid, depth, stack, top, last_t)`` of arrays (the
fields of `integrator._Wave`). Random numbers are drawn by the caller (one per ray that may need
one), so the kernels are deterministic functions of their inputs. The compiled code is cached on
disk next to this file (or in numba's user cache): the first render after an install compiles it
(`warm`), later ones load it; ``NUMBA_DISABLE_JIT=1`` runs the same code as Python.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from pmmw_cli.physics import fresnel, multilayer
from pmmw_cli.trace.intersect import _plane_distance
from pmmw_cli.trace.job import BLACKBODY, DIELECTRIC, METAL, OPAQUE, THIN

A_ROUNDING = 1e-12  # absorbed fractions below this are rounding of lossless interfaces
_TINY = 1e-12
_NORMAL = 1e-9  # |n x k| below this: normal incidence, the ray keeps its own s

STRATEGIES = {"split": 0, "stochastic": 1, "hybrid": 2}
NO_SETTLE = (True, np.zeros(0, np.int64), np.zeros(0, np.int8))  # `scatter`'s children leave at once

_jit = numba.njit(cache=True, error_model="numpy")
_inline = numba.njit(cache=True, error_model="numpy", inline="always")


@_inline
def _add(acc, k, n00, n01, n10, n11, ta, tb):
    """acc[k] += (Ex2, Ey2, U, V) of emission (Ta, Tb) seen through N (`jones.stokes_terms`)."""
    c = n00 * np.conj(n10) * ta + n01 * np.conj(n11) * tb
    acc[k, 0] += (n00.real ** 2 + n00.imag ** 2) * ta + (n01.real ** 2 + n01.imag ** 2) * tb
    acc[k, 1] += (n10.real ** 2 + n10.imag ** 2) * ta + (n11.real ** 2 + n11.imag ** 2) * tb
    acc[k, 2] += 2.0 * c.real
    acc[k, 3] += 2.0 * c.imag


@_jit
def emit(acc, sid, m, ta, tb):
    """Add the emission of brightness temperatures (ta, tb) [K], one per ray, seen through each
    ray's Jones matrix ``m`` (columns a, b), to ``acc[sid]``."""
    for i in range(sid.shape[0]):
        _add(acc, sid[i], m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1], ta[i], tb[i])


@_inline
def _end(acc, cut, k, m00, m01, m10, m11, t_last, t_lo, t_hi):
    """End a path on ``t_last`` (Murakowski 2014 sec. 2.2.9) and count what that may have cost:
    the ended power (mean of the rows) and the rows' largest power times the largest difference
    between ``t_last`` and any brightness the path could still have seen."""
    _add(acc, k, m00, m01, m10, m11, t_last, t_last)
    r0 = m00.real ** 2 + m00.imag ** 2 + m01.real ** 2 + m01.imag ** 2
    r1 = m10.real ** 2 + m10.imag ** 2 + m11.real ** 2 + m11.imag ** 2
    cut[k, 0] += 0.5 * (r0 + r1)
    cut[k, 1] += max(r0, r1) * max(t_hi - t_last, t_last - t_lo)


@_jit
def survive(acc, cut, k, m, i, depth, t_last, u, limits):
    """Termination of one ray (row ``i`` of ``m``) after an interaction: True to go on.

    ``limits = (max_depth, threshold, roulette, t_lo, t_hi)``. Beyond ``max_depth`` the path
    ends on ``t_last``; below ``threshold`` (the largest row power, `jones.row_power`) it ends
    there too, or with ``roulette`` survives with probability weight / threshold (``u`` < it)
    and is scaled up by 1 / that (unbiased). A ray with no power left ends silently.
    """
    max_depth, threshold, roulette, t_lo, t_hi = limits
    m00, m01, m10, m11 = m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1]
    w = max(m00.real ** 2 + m00.imag ** 2 + m01.real ** 2 + m01.imag ** 2,
            m10.real ** 2 + m10.imag ** 2 + m11.real ** 2 + m11.imag ** 2)
    if w <= 0.0:
        return False
    if depth >= max_depth:
        _end(acc, cut, k, m00, m01, m10, m11, t_last, t_lo, t_hi)
        return False
    if w < threshold:
        if not roulette:
            _end(acc, cut, k, m00, m01, m10, m11, t_last, t_lo, t_hi)
            return False
        q = w / threshold
        if u >= q:
            return False
        g = 1.0 / math.sqrt(q)
        m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1] = m00 * g, m01 * g, m10 * g, m11 * g
    return True


@_jit
def survivors(wave, u, limits, acc, cut, keep):
    """`survive` for every ray of a wave (in place on its Jones matrices); ``keep`` is set."""
    m, sid, depth, last_t = wave[4], wave[5], wave[6], wave[9]
    for i in range(sid.shape[0]):
        keep[i] = survive(acc, cut, sid[i], m, i, depth[i], last_t[i], u[i] if u.shape[0] else 1.0, limits)


@_inline
def _dot(a, i, b, j):
    return a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]


@_jit
def arrive(wave, t, prim, atm, faces, media, acc, hit):
    """The rays of a wave at the faces they hit.

    Parameters
    ----------
    wave : tuple of arrays
        Modified in place: Jones matrices by the segment's absorption; for rays that pass through
        a face, the origin (moved across it) and the medium stack.
    t, prim : ndarray, shape (n,)
        Distance [m] and face hit (-1: none, the ray is skipped).
    atm : tuple (trans, emission) of ndarray, shape (n,) or (0,)
        The layered atmosphere's power transmittance and emission [K] along each segment (empty:
        no atmosphere work).
    faces : tuple (face_medium, face_normals, face_offset)
    media : tuple (kind, alpha, temperature, n1_real, has_coat, eps)
    acc : ndarray, shape (samples, 4)
    hit : tuple (pos, n_in, cos1, cur, face_med, other, leaving, code), each of length n
        Filled: the hit point, the face normal facing the incident side, the cosine of incidence,
        the media (current, the face's, the far side's), whether the ray leaves the face's
        medium, and code 0 (missed), 1 (passed through), 2 (interacts).
    """
    o, d, m, sid, stack, top = wave[0], wave[1], wave[4], wave[5], wave[7], wave[8]
    face_medium, face_normals, face_offset = faces
    kind, alpha, temperature = media[0], media[1], media[2]
    trans, emission = atm
    pos, n_in, cos1, cur_o, fm_o, other_o, leaving_o, code = hit
    cap = stack.shape[1]
    with_atm = trans.shape[0] > 0
    for i in range(t.shape[0]):
        f = prim[i]
        if f < 0:
            code[i] = 0
            continue
        k = sid[i]
        ti = t[i]
        cur = stack[i, top[i]]
        if with_atm and (trans[i] != 1.0 or emission[i] != 0.0):
            e = emission[i]
            _add(acc, k, m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1], e, e)
            g = math.sqrt(trans[i])
            for a in range(2):
                for b in range(2):
                    m[i, a, b] *= g
        a_c = alpha[cur]
        if a_c > 0.0:  # eq. 2.37, 2.38: emission 1 - tau at the medium's temperature
            tau = math.exp(-a_c * ti)
            e = math.sqrt(1.0 - tau)
            tc = temperature[cur]
            _add(acc, k, m[i, 0, 0] * e, m[i, 0, 1] * e, m[i, 1, 0] * e, m[i, 1, 1] * e, tc, tc)
            g = math.sqrt(tau)
            for a in range(2):
                for b in range(2):
                    m[i, a, b] *= g
        for c in range(3):
            pos[i, c] = o[i, c] + ti * d[i, c]
        fm = face_medium[f]
        cosf = _dot(d, i, face_normals, f)
        kd = kind[fm]
        entering = cosf < 0.0
        diel = kd == DIELECTRIC
        tp = top[i]
        leaving_cur = diel and not entering and fm == cur
        enter_ok = diel and entering and tp < cap - 1
        if (not diel or enter_ok or leaving_cur) and cosf != 0.0:
            sgn = 1.0 if entering else -1.0
            for c in range(3):
                n_in[i, c] = sgn * face_normals[f, c]
            cos1[i] = min(max(-sgn * cosf, 0.0), 1.0)
            cur_o[i] = cur
            fm_o[i] = fm
            if not diel or entering:
                other_o[i] = fm
            else:
                other_o[i] = stack[i, tp - 1] if tp > 0 else 0
            leaving_o[i] = (not entering) and diel
            code[i] = 2
        else:  # cross without interacting; drop the face's medium from the stack if it is there
            step = face_offset[f] if not entering else -face_offset[f]
            for c in range(3):
                o[i, c] = pos[i, c] + step * face_normals[f, c]
            for kpos in range(1, tp + 1):  # rare: only at interpenetrating objects
                if stack[i, kpos] == fm:
                    for j in range(kpos, tp):
                        stack[i, j] = stack[i, j + 1]
                    top[i] = tp - 1
                    break
            code[i] = 1


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
    """An amplitude with the phase of ``amp`` and the magnitude sqrt(power) (renormalized R, T)."""
    mag = abs(amp)
    ph = amp / mag if mag > 0.0 else 1.0 + 0.0j
    return ph * math.sqrt(max(power, 0.0))


@_inline
def _child(out, n, o_pos, dv, sv, mm, sid, depth, stack_row, top, last_t, g, step, finish):
    """Write one child at row n of ``out``: direction ``dv`` with basis vector ``sv``, off the
    surface at ``o_pos`` along the side normal ``g`` (mirrored through the face's plane first if
    it points to the wrong side, keeping its power); at ``o_pos`` itself unless ``finish``."""
    oo, od, os_, op, om, osid, odepth, ostack, otop, olast = out
    side = 0.0
    if finish:
        dg = dv[0] * g[0] + dv[1] * g[1] + dv[2] * g[2]
        if dg <= 0.0:
            sg = sv[0] * g[0] + sv[1] * g[1] + sv[2] * g[2]
            for c in range(3):
                dv[c] -= 2.0 * dg * g[c]
                sv[c] -= 2.0 * sg * g[c]
            dg = -dg
        side = -step if dg < 0.0 else step
    for c in range(3):
        oo[n, c] = o_pos[c] + side * g[c]
        od[n, c] = dv[c]
        os_[n, c] = sv[c]
    # p = k x s with k = -d
    op[n, 0] = -(dv[1] * sv[2] - dv[2] * sv[1])
    op[n, 1] = -(dv[2] * sv[0] - dv[0] * sv[2])
    op[n, 2] = -(dv[0] * sv[1] - dv[1] * sv[0])
    for a in range(2):
        for b in range(2):
            om[n, a, b] = mm[a, b]
    osid[n] = sid
    odepth[n] = depth
    for c in range(stack_row.shape[0]):
        ostack[n, c] = stack_row[c]
    otop[n] = top
    olast[n] = last_t


@_jit
def scatter(rows, wave, hit, coeff, prim, faces, media, choice, u_choose, u_roul, limits, acc, cut, out, settle):
    """Interactions of the rays ``rows`` of a wave with the faces they hit (`arrive` filled
    ``hit``); their surviving children are written to ``out`` (room for two per row). Returns
    how many.

    Parameters
    ----------
    hit : tuple (pos, n, cos1, cur, face_med, other, leaving, code)
        As `arrive` fills it; on a rough face ``n`` is the facet normal drawn for the ray and
        ``cos1`` the cosine about it.
    coeff : tuple (amp, power, t_absorb, q2, at)
        Interface coefficients the caller computed (faces under coherent films): amplitudes
        (rs, rp, ts, tp), powers (Rs, Rp, Ts, Tp, As, Ap), the temperature at which A emits [K],
        and the far medium's normal component (outgoing branch) for refraction, at row ``at[j]``
        for ``rows[j]``; ``at[j] = -1``: a bare interface or a perfect conductor, computed here
        (`fresnel.interface1`, `fresnel.conductor1`).
    choice : tuple (strategy code, split_depth)
    u_choose, u_roul : ndarray
        Uniforms for the branch choice (one per row; empty with ``split``) and Russian roulette
        (two per row; empty without roulette).
    settle : tuple (finish, src, branch)
        ``finish``: the children leave the surface here (offset along the side normal, then
        `survive`). Otherwise (rough faces: masking decides first) they stay at the hit point,
        unterminated, and ``src``/``branch`` receive each child's row in the wave and +1
        (reflected) or -1 (transmitted).
    """
    finish, src, branch = settle
    d, s_old, p_old, m, sid, depth, stack, top = wave[1], wave[2], wave[3], wave[4], wave[5], wave[6], wave[7], wave[8]
    pos, n_in, cos1, cur_a, fm_a, other_a, leaving_a = hit[0], hit[1], hit[2], hit[3], hit[4], hit[5], hit[6]
    amp, power, t_absorb, q2, at = coeff
    face_offset = faces[2]
    kind, temperature, n1_real, eps = media[0], media[2], media[3], media[5]
    strategy, split_depth = choice
    roulette = u_roul.shape[0] > 0
    ml = np.empty((2, 2), np.complex128)
    mc = np.empty((1, 2, 2), np.complex128)  # a child's Jones matrix (as a one-row wave for `survive`)
    s_new = np.empty(3)
    dv = np.empty(3)
    sv = np.empty(3)
    g = np.empty(3)
    n_out = 0
    for j in range(rows.shape[0]):
        i = rows[j]
        k = sid[i]
        fm = fm_a[i]
        kd = kind[fm]
        t_body = temperature[fm]
        nx, ny, nz = n_in[i, 0], n_in[i, 1], n_in[i, 2]
        dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
        # the outgoing wave's (s, p) about the normal: s = unit(n x k), k = -d (eq. 2.23)
        sx, sy, sz = -(ny * dz - nz * dy), -(nz * dx - nx * dz), -(nx * dy - ny * dx)
        norm = math.sqrt(sx * sx + sy * sy + sz * sz)
        if norm > _NORMAL:
            s_new[0], s_new[1], s_new[2] = sx / norm, sy / norm, sz / norm
        else:
            s_new[0], s_new[1], s_new[2] = s_old[i, 0], s_old[i, 1], s_old[i, 2]
        # p = k x s
        px = -(dy * s_new[2] - dz * s_new[1])
        py = -(dz * s_new[0] - dx * s_new[2])
        pz = -(dx * s_new[1] - dy * s_new[0])
        # M re-expressed in (s, p) (eq. 2.35, `jones.rebase`)
        b00 = s_new[0] * s_old[i, 0] + s_new[1] * s_old[i, 1] + s_new[2] * s_old[i, 2]
        b01 = px * s_old[i, 0] + py * s_old[i, 1] + pz * s_old[i, 2]
        b10 = s_new[0] * p_old[i, 0] + s_new[1] * p_old[i, 1] + s_new[2] * p_old[i, 2]
        b11 = px * p_old[i, 0] + py * p_old[i, 1] + pz * p_old[i, 2]
        for a in range(2):
            ml[a, 0] = m[i, a, 0] * b00 + m[i, a, 1] * b10
            ml[a, 1] = m[i, a, 0] * b01 + m[i, a, 1] * b11
        c = at[j]
        if c >= 0:  # computed by the caller (coherent films: `multilayer`)
            rs, rp, ts, tp = amp[c, 0], amp[c, 1], amp[c, 2], amp[c, 3]
            Rs, Rp, Ts, Tp, As, Ap = power[c, 0], power[c, 1], power[c, 2], power[c, 3], power[c, 4], power[c, 5]
            t_abs, q2c = t_absorb[c], q2[c]
        elif kd == METAL:
            rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2c = fresnel.conductor1()
            t_abs = t_body
        else:  # a bare interface; a lossy incident medium's remainder emits at its temperature
            e1 = eps[cur_a[i]]
            rs, rp, ts, tp, Rs, Rp, Ts, Tp, As, Ap, q2c = fresnel.interface1(e1, _far_eps1(kd, e1, eps[other_a[i]]),
                                                                             cos1[i])
            t_abs = temperature[cur_a[i]]
        # what the interface (or its films) absorbs, and what a sink swallows (eq. 2.36)
        if As > A_ROUNDING or Ap > A_ROUNDING:
            ea, eb = math.sqrt(As), math.sqrt(Ap)
            _add(acc, k, ml[0, 0] * ea, ml[0, 1] * eb, ml[1, 0] * ea, ml[1, 1] * eb, t_abs, t_abs)
        if kd == BLACKBODY or kd == OPAQUE:
            ea, eb = math.sqrt(Ts), math.sqrt(Tp)
            _add(acc, k, ml[0, 0] * ea, ml[0, 1] * eb, ml[1, 0] * ea, ml[1, 1] * eb, t_body, t_body)
        trans = (kd == DIELECTRIC or kd == THIN) and (Ts > 0.0 or Tp > 0.0)
        keep_r, keep_t, gain_r, gain_t = True, trans, 1.0, 1.0
        if strategy != 0 and trans and (strategy == 1 or depth[i] >= split_depth):
            r_sum, t_sum = Rs + Rp, Ts + Tp
            p_r = r_sum / max(r_sum + t_sum, _TINY)
            if u_choose[j] < p_r:
                keep_t, gain_r = False, 1.0 / math.sqrt(p_r)
            else:
                keep_r, gain_t = False, 1.0 / math.sqrt(1.0 - p_r)
        step = face_offset[prim[i]]
        dn = dx * nx + dy * ny + dz * nz
        if keep_r:  # reflected (eq. 2.21, 2.39): stays on the incident side
            a_s = gain_r * _amplitude(rs, Rs)
            a_p = gain_r * _amplitude(rp, Rp)
            for a in range(2):
                mc[0, a, 0] = ml[a, 0] * a_s
                mc[0, a, 1] = ml[a, 1] * a_p
            u = u_roul[2 * j] if roulette else 1.0
            if not finish or survive(acc, cut, k, mc, 0, depth[i] + 1, t_body, u, limits):
                dv[0], dv[1], dv[2] = dx - 2.0 * dn * nx, dy - 2.0 * dn * ny, dz - 2.0 * dn * nz
                sv[:] = s_new
                g[0], g[1], g[2] = nx, ny, nz
                _child(out, n_out, pos[i], dv, sv, mc[0], k, depth[i] + 1, stack[i], top[i], t_body, g, step, finish)
                if not finish:
                    src[n_out], branch[n_out] = i, 1
                n_out += 1
        if keep_t:  # transmitted (eq. 2.19, 2.40): refracted into the other medium, or straight through a sheet
            a_s = gain_t * _amplitude(ts, Ts)
            a_p = gain_t * _amplitude(tp, Tp)
            for a in range(2):
                mc[0, a, 0] = ml[a, 0] * a_s
                mc[0, a, 1] = ml[a, 1] * a_p
            u = u_roul[2 * j + 1] if roulette else 1.0
            if not finish or survive(acc, cut, k, mc, 0, depth[i] + 1, t_body, u, limits):
                diel = kd == DIELECTRIC
                if diel:
                    # homogeneous wave (sec. 2.2.4): tangential part kept (eq. 2.18), normal part
                    # Re q2 of the outgoing root (eq. 2.20); Snell's law for lossless media
                    c1 = -dn
                    n1 = n1_real[cur_a[i]]
                    qr = q2c.real
                    tx, ty, tz = n1 * (dx + c1 * nx) - qr * nx, n1 * (dy + c1 * ny) - qr * ny, n1 * (dz + c1 * nz) - qr * nz
                    tn = math.sqrt(tx * tx + ty * ty + tz * tz)
                    dv[0], dv[1], dv[2] = tx / tn, ty / tn, tz / tn
                else:
                    dv[0], dv[1], dv[2] = dx, dy, dz
                sv[:] = s_new
                g[0], g[1], g[2] = -nx, -ny, -nz
                tp = top[i]
                _child(out, n_out, pos[i], dv, sv, mc[0], k, depth[i] + 1, stack[i], tp, t_body, g, step, finish)
                if not finish:
                    src[n_out], branch[n_out] = i, -1
                if diel and not leaving_a[i]:
                    out[8][n_out] = tp + 1
                    out[7][n_out, tp + 1] = fm
                elif diel:
                    out[8][n_out] = tp - 1
                n_out += 1
    return n_out


def warm(stack_size: int = 8) -> None:
    """Compile (first time after an install) or load the bounce loop's compiled code with the
    integrator's types (these kernels, the Fresnel and coating arithmetic, the intersector's
    float64 distances), so that forked workers inherit it instead of each loading its own."""
    cos1, eps = np.array([0.5]), np.array([2.0 + 0.1j])
    fresnel.interface(eps, eps * 2.0, cos1, with_q2=True)
    multilayer.stack(np.array([[1.0, 2.0 + 0.1j, 3.0]]), np.array([[1e-3]]), cos1, 1e3)
    _plane_distance(np.zeros((1, 3)), np.ones((1, 3)), np.zeros((1, 3)), np.ones((1, 3)), np.zeros(1, np.int64),
                    np.zeros(1))
    n = 1
    wave = (np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 2, 2), complex),
            np.zeros(n, np.int64), np.zeros(n, np.int32), np.zeros((n, stack_size), np.int16), np.zeros(n, np.int32),
            np.zeros(n))
    acc, cut = np.zeros((n, 4)), np.zeros((n, 2))
    t, prim = np.ones(n), np.full(n, -1, np.int64)
    faces = (np.zeros(1, np.int32), np.zeros((1, 3)), np.zeros(1))
    media = (np.zeros(1, np.int8), np.zeros(1), np.zeros(1), np.ones(1), np.zeros(1, bool), np.ones(1, complex))
    hit = (np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n), np.zeros(n, np.int64), np.zeros(n, np.int64),
           np.zeros(n, np.int64), np.zeros(n, bool), np.zeros(n, np.int8))
    empty = np.zeros(0)
    arrive(wave, t, prim, (empty, empty), faces, media, acc, hit)
    limits = (32, 1e-3, True, 0.0, 300.0)
    coeff = (np.zeros((0, 4), complex), np.zeros((0, 6)), np.zeros(0), np.zeros(0, complex), np.zeros(0, np.int64))
    scatter(np.zeros(0, np.int64), wave, hit, coeff, prim, faces, media, (0, 0), empty, empty, limits, acc, cut, wave,
            NO_SETTLE)
    survivors(wave, empty, limits, acc, cut, np.zeros(n, bool))
    emit(acc, np.zeros(0, np.int64), np.zeros((0, 2, 2), complex), empty, empty)
