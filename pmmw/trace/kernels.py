"""The integrator's compiled per-ray steps (numba): a segment's arrival at a face, the sky, a
tile's sums; `warm`, which compiles or loads every kernel of the bounce loop.

The integrator (`pmmw.trace.integrator`) keeps what is vectorized well or happens once per
wave: the Embree call, the sky and atmosphere models. Per ray:

* `arrive`: for each ray that hit a face, the atmosphere's and the medium's absorption and
  emission along the segment (Murakowski 2014 eq. 2.37, 2.38), Russian roulette of the rays
  that the segment left below the threshold (before they cost an interaction), the medium stack
  (sec. 2.2.9), and whether it interacts with the face or passes through it (then moved across
  it here): ``Hit.code``;
* `sky_emit`: the sky's brightness for the rays that miss every face, their Jones matrices
  re-expressed in the sky's (h, v) basis first; `ambient_segments`: which segments cross the
  layered atmosphere;
* `tally`, `tile_means`, `stderr`: a tile's per-pixel sums, means, standard errors and replicate
  difference.

What happens at a face is the surface layer's (`pmmw.surface.kernels`: `scatter`, `settle`,
`survive`, ...), whose names this module also re-exports for the integrator's callers.
"""

from __future__ import annotations

import math

import numpy as np

from pmmw import rng
from pmmw.jit import inline, njit
from pmmw.physics import roughness
from pmmw.scene import bump, camera
from pmmw.surface.kernels import (  # noqa: F401  (the surfaces' kernels, re-exported for the integrator)
    _ENDED,
    _INTERACTS,
    _MISSED,
    _PASSED,
    _TINY,
    A_ROUNDING,
    AT_POINT,
    FINISH,
    MASKED,
    NO_SETTLE,
    STRATEGIES,
    _add,
    _dot,
    _rebase1,
    _roulette,
    _row_powers,
    at_point,
    coefficients,
    compact,
    cross_layer,
    emit,
    far_eps,
    gather,
    masked,
    off_surface,
    scatter,
    settle,
    survive,
    survivors,
    tangents,
)
from pmmw.surface.media import DIELECTRIC
from pmmw.surface.records import (
    BackSide,
    ChainEnd,
    Choice,
    Faces,
    Fate,
    Films,
    Hit,
    LeaveSide,
    Limits,
    MediaTable,
    RoughTable,
    Settle,
    WaveArrays,
)
from pmmw.trace.intersect import _plane_distance

_jit = njit()
_inline = inline()


@_jit
def sky_emit(rows, wave, ta, tb, polarized, acc):
    """The sky's brightness seen by the rays ``rows`` of a wave (which missed every face): (Tv,
    Th) = (``ta``, ``tb``) [K], one pair per row. Unpolarized (``polarized`` False): ``ta`` in
    both columns. Polarized: each Jones matrix re-expressed in the sky's (h, v) basis about the
    ray (eq. 2.35; h = unit(z x k) with k = -d, the ray's own s at the zenith and nadir, v = k x
    h), columns (h, v) seeing (Th, Tv)."""
    d, s, p, m, sid = wave.d, wave.s, wave.p, wave.m, wave.sid
    for j in range(rows.shape[0]):
        i = rows[j]
        m00, m01, m10, m11 = m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1]
        if not polarized:
            _add(acc, sid[i], m00, m01, m10, m11, ta[j], ta[j])
            continue
        kx, ky, kz = -d[i, 0], -d[i, 1], -d[i, 2]
        hx, hy = -ky, kx  # z x k
        norm = math.sqrt(hx * hx + hy * hy)
        if norm > _TINY:
            hx, hy, hz = hx / norm, hy / norm, 0.0
        else:
            hx, hy, hz = s[i, 0], s[i, 1], s[i, 2]
        vx, vy, vz = ky * hz - kz * hy, kz * hx - kx * hz, kx * hy - ky * hx  # k x h
        n00, n01, n10, n11 = _rebase1(
            m00, m01, m10, m11, (s[i, 0], s[i, 1], s[i, 2]), (p[i, 0], p[i, 1], p[i, 2]), (hx, hy, hz), (vx, vy, vz)
        )
        _add(acc, sid[i], n00, n01, n10, n11, tb[j], ta[j])


@_jit
def ambient_segments(wave, t, prim, skip, top_height, z0, z1, length):
    """The segments of a wave's rays through the layered atmosphere (`AtmosphereModel.walk`): those
    of rays that hit a face, travelled in the ambient medium (0) and are longer than ``skip`` [m]
    (`integrator.atmosphere_skip_length`). Fills their ends' heights (within 0..``top_height``
    [m]) and length, and length 0 for every other ray; returns how many there are. The part of a
    segment above ``top_height`` crosses no air (an imager above the model's top): only the
    length below it counts, so that the walk's stretch L / |z1 - z0| stays the segment's own."""
    o, d, stack, top = wave.o, wave.d, wave.stack, wave.top
    count = 0
    for i in range(t.shape[0]):
        ti = t[i]
        z0[i], z1[i], length[i] = 0.0, 0.0, 0.0
        if prim[i] >= 0 and stack[i, top[i]] == 0 and ti > skip:
            a = o[i, 2]
            b = a + ti * d[i, 2]
            lo, hi = min(a, b), max(a, b)
            if hi > top_height:
                if lo >= top_height:
                    continue
                ti *= (top_height - lo) / (hi - lo)
            z0[i], z1[i], length[i] = min(max(a, 0.0), top_height), min(max(b, 0.0), top_height), ti
            count += 1
    return count


@_jit
def arrive(wave, t, prim, atm, faces, media, acc, hit, u, threshold):
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
        medium, and code 0 (missed), 1 (passed through), 2 (interacts), 3 (ended by roulette).
    u : ndarray, shape (n,) or (0,)
        With Russian roulette, one uniform per ray: a ray that the segment's absorption left
        below ``threshold`` (its largest row power, as `survive` reads it) plays roulette here,
        before it interacts. It goes on with probability weight / threshold, scaled up by 1 / that
        (unbiased); otherwise it ends (code 3) and costs no interaction. Empty: no roulette here.
    """
    o, d, m, sid, stack, top = wave.o, wave.d, wave.m, wave.sid, wave.stack, wave.top
    face_medium, face_normals, face_offset = faces.medium, faces.normal, faces.offset
    kind, alpha, temperature = media.kind, media.alpha, media.temperature
    trans, emission = atm
    pos, n_in, cos1, cur_o, fm_o, other_o, leaving_o = (
        hit.pos,
        hit.n_in,
        hit.cos1,
        hit.cur,
        hit.face_med,
        hit.other,
        hit.leaving,
    )
    code = hit.code
    cap = stack.shape[1]
    with_atm = trans.shape[0] > 0
    for i in range(t.shape[0]):
        f = prim[i]
        if f < 0:
            code[i] = _MISSED
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
        if u.shape[0] > 0:
            w = max(_row_powers(m[i, 0, 0], m[i, 0, 1], m[i, 1, 0], m[i, 1, 1]))
            if w < threshold:
                g = _roulette(w, threshold, u[i])
                if g == 0.0:
                    code[i] = _ENDED
                    continue
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
            code[i] = _INTERACTS
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
            code[i] = _PASSED


@_inline
def _stderr1(s1, s2, c):
    """Standard error of a mean of ``c`` samples from their shifted sum ``s1`` and sum of
    squares ``s2`` (0 for one sample)."""
    var = max(s2 - s1 * s1 / c, 0.0) / max(c - 1.0, 1.0)
    return math.sqrt(var / c) if c > 1.0 else 0.0


@_jit
def stderr(s1, s2, count, out):
    """`_stderr1` of each pixel's four values: sums ``s1``, ``s2`` (pixels, 4), ``count`` (pixels,)."""
    for px in range(count.shape[0]):
        c = float(count[px])
        for k in range(4):
            out[px, k] = _stderr1(s1[px, k], s2[px, k], c)


@_jit
def tile_means(ref, s1, s2, r1, count, mean, err, diff):
    """A tile's per-pixel results from its sums (`tally`; `Integrator.render_tile`): the mean,
    its standard error (`_stderr1`), and the mean of the even samples minus that of the odd ones
    (replicates 0 and 1 of ``r1``; 0 where either has none)."""
    if r1.shape[1] != 2:
        raise ValueError("tile_means reads two replicates")
    for px in range(count.shape[0]):
        n = count[px]
        c = float(n)
        n0, n1 = float((n + 1) // 2), float(n // 2)  # samples 0, 2, 4, ... and 1, 3, ...
        for k in range(4):
            mean[px, k] = ref[px, k] + s1[px, k] / c
            err[px, k] = _stderr1(s1[px, k], s2[px, k], c)
            diff[px, k] = r1[px, 0, k] / n0 - r1[px, 1, k] / n1 if n1 > 0.0 else 0.0


@_jit
def tally(active, vals, cut, first_t, first_m, done, replicates, ref, s1, s2, r1, count, trunc, depth, material):
    """Add one chunk of samples to a tile's per-pixel sums (`Integrator.render_tile`).

    Parameters
    ----------
    active : ndarray, shape (a,), int64
        The tile's pixels that took samples ``done .. done + nb - 1``, nb = len(vals) / a.
    vals : ndarray, shape (a * nb, 4)
        Per sample (Ex2, Ey2, U, V) [K], pixel-major.
    cut : ndarray, shape (a * nb, 2)
        Per sample the truncated power and bound (`TileResult.truncated`).
    first_t, first_m : ndarray, shape (a * nb,)
        First-hit distance [m] and medium (-1: sky).
    ref, s1, s2 : ndarray, shape (pixels, 4)
        The shift (set on the first chunk to its mean), the sums of shifted values and squares.
    r1 : ndarray, shape (pixels, replicates, 4)
        Shifted sums per replicate (sample number mod ``replicates``).
    count : ndarray, shape (pixels,), int64
    trunc : ndarray, shape (pixels, 2)
    depth, material : ndarray, shape (pixels,)
        Set on the first chunk: mean first-hit distance and the first sample's medium.
    """
    nb = vals.shape[0] // active.shape[0]
    for a in range(active.shape[0]):
        px = active[a]
        k0 = a * nb
        if done == 0:
            t_sum = 0.0
            for c in range(4):
                v = 0.0
                for j in range(nb):
                    v += vals[k0 + j, c]
                ref[px, c] = v / nb
            for j in range(nb):
                t_sum += first_t[k0 + j]
            depth[px] = t_sum / nb
            material[px] = first_m[k0]
        for j in range(nb):
            k = k0 + j
            r = (done + j) % replicates
            for c in range(4):
                dv = vals[k, c] - ref[px, c]
                s1[px, c] += dv
                s2[px, c] += dv * dv
                r1[px, r, c] += dv
            trunc[px, 0] += cut[k, 0]
            trunc[px, 1] += cut[k, 1]
        count[px] += nb


def warm(stack_size: int = 8, rough: bool = True) -> None:
    """Compile (first time after an install) or load the bounce loop's compiled code with the
    integrator's types (these kernels, the Fresnel and coating arithmetic, the intersector's
    float64 distances), so that forked workers inherit it instead of each loading its own.

    ``rough`` False leaves out what only rough faces, bump maps and rough coating layers run (the
    masked specialization of `scatter`, `settle`, the facet draws, `cross_layer`): a smooth
    scene's first render after an install then compiles only what it runs. Whatever is left out
    compiles (or loads) where it is first called, so leaving out too much costs time, never a
    wrong number."""
    _plane_distance(
        np.zeros((1, 3)), np.ones((1, 3)), np.zeros((1, 3)), np.ones((1, 3)), np.zeros(1, np.int64), np.zeros(1)
    )
    # every record from its type's `empty` (`pmmw.surface.records`), as the renderer makes them
    n = 1
    wave = WaveArrays.empty(n, zero=True, stack=stack_size)
    acc, cut = np.zeros((n, 4)), np.zeros((n, 2))
    t, prim = np.ones(n), np.full(n, -1, np.int64)
    faces, media, films = Faces.empty(1, zero=True), MediaTable.empty(1, zero=True), Films.empty(1, zero=True)
    hit, limits, choice = Hit.empty(n), Limits.empty(), Choice.empty()
    empty, ints = np.zeros(0), np.zeros(0, np.int64)
    arrive(wave, t, prim, (empty, empty), faces, media, acc, hit, empty, 1e-3)
    ambient_segments(wave, t, prim, 0.0, 1e3, np.zeros(n), np.zeros(n), np.zeros(n))
    coefficients(
        ints, ints, ints, np.zeros(0, bool), empty, media, films, np.zeros((0, 4), complex), np.zeros((0, 6)),
        np.zeros(0, complex), empty,
    )  # fmt: skip
    for settle_ in (NO_SETTLE, at_point(ints, np.zeros(0, np.int8))) + ((Settle.empty(0, zero=True),) if rough else ()):
        # smooth faces; the rough code's steps (``AT_POINT``); rough faces with compiled masking (``MASKED``)
        scatter(ints, wave, hit, films, prim, faces, media, choice, empty, empty, limits, acc, cut, wave, settle_)
    survivors(wave, empty, limits, acc, cut, np.zeros(n, bool))
    compact(wave, np.zeros(n, bool))
    if rough:
        settle(
            wave, ints, np.zeros(0, np.int8), empty, empty, hit, np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n),
            ChainEnd.empty(n, zero=True), media, RoughTable.empty(1, zero=True), 1e-3, acc, wave, wave,
            BackSide.empty(0), LeaveSide.empty(0), True, -1, Fate.empty(0, zero=True),
        )  # fmt: skip
    emit(acc, np.zeros(0, np.int64), np.zeros((0, 2, 2), complex), empty, empty)
    if rough:
        # rough faces and bump maps (`Surfaces._facets`, `_bumped`)
        v3 = np.zeros((n, 3))
        roughness._ggx_sample_rows(v3, v3, v3, empty, empty, 1.0, 1.0, 0.0, v3, empty)
        roughness._smith_masking_rows(v3, v3, v3, roughness.GGX_CODE, 1.0, 1.0, 0.0, empty)
        bump._perturb_rows(v3, v3, np.zeros((1, 1)), np.zeros((1, 1)), 1.0, 1.0, v3)
        bump._shade_rows(v3, v3, v3, np.zeros((1, 1)), np.zeros((1, 1)), 1.0, 1.0, v3)
        tangents(v3, v3)
        off_surface(wave, v3, np.zeros(n))
        cross_layer(wave, v3, np.zeros(n, np.int64), 1.0, 1e-3, 300.0, acc)
    # a tile's per-pixel sums (`Integrator.render_tile`)
    px4, ints1 = np.zeros((1, 4)), np.zeros(1, np.int64)
    tally(
        ints1,
        px4,
        np.zeros((1, 2)),
        np.zeros(1),
        np.zeros(1),
        0,
        2,
        px4,
        px4,
        px4,
        np.zeros((1, 2, 4)),
        ints1,
        np.zeros((1, 2)),
        np.zeros(1),
        np.zeros(1),
    )
    tile_means(px4, px4, px4, np.zeros((1, 2, 4)), ints1 + 1, px4.copy(), px4.copy(), px4.copy())
    stderr(px4, px4, ints1, px4.copy())
    # camera samples and the rays' random numbers (`Integrator._trace`, `pmmw.rng`)
    camera.pixel_samples(2, np.zeros(1, np.int64), 2, 0)
    keys = rng.ray_keys(0, ints1)
    rng.uniforms(rng.child_keys(keys, rng.Branch.PASSED), np.zeros(1, np.int32), rng.Purpose.SURVIVAL)
    # the sky (`Integrator._sky`)
    sky_emit(np.zeros(0, np.int64), wave, empty, empty, True, acc)
    from pmmw.atmosphere.model import SKY_ELEVATIONS  # read-only, as `AtmosphereSky.brightness` passes it
    from pmmw.scene.sky import _sky_lookup

    _sky_lookup(
        empty,
        empty,
        1.0,
        1.0,
        np.zeros(1, np.int64),
        SKY_ELEVATIONS,
        SKY_ELEVATIONS[None].copy(),
        0.0,
        empty,
        np.zeros(0, np.int64),
        empty,
    )
    camera.Camera(np.zeros(3), *np.eye(3), 1.0, 2, 2).rays(np.ones(1), np.ones(1), np.zeros(1, np.int64), 0)
    # the layered atmosphere's cell walk (`AtmosphereModel.path`)
    from pmmw.atmosphere.model import _path_loop

    cells = np.array([0.0, 1.0])
    _path_loop(empty, empty, empty, cells, cells, cells, cells, cells, False, empty, empty)
