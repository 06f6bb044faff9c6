"""The bounce loop: a wavefront of backward rays per bounce, vectorized over rays.

Follows the flowchart of seed 000 sec. 2.2.5 (fig. 2.5). Every ray carries a Jones matrix M
(convention in `pmmw_cli.physics.jones`). At each bounce, for all rays at once:

1. intersect (Embree); rays that miss see the sky;
2. the segment just travelled attenuates M by exp(-alpha d / 2) and emits at the medium's
   temperature with weight 1 - exp(-alpha d) (eq. 2.37, 2.38);
3. media are tracked with closed orientable meshes and a per-ray medium stack (sec. 2.2.9):
   crossing a face outward-to-inward enters the face's material; crossing inward-to-outward
   leaves it if it is the current medium, or silently drops it from the stack if it is a medium
   further down (slightly interpenetrating touching objects, as the seed prescribes);
4. at an interaction, the surface's coating stack (or bare interface) gives r, t, R, T, A; the
   coating's absorption A emits at the coating temperature (eq. 2.36); ``metal`` reflects
   everything, ``blackbody`` and ``opaque`` emit the transmitted power at their temperature,
   ``thin`` sheets transmit without changing medium or direction;
5. the reflected and transmitted children continue (deterministic splitting). A child beyond
   ``max_depth`` ends on the last object's temperature (seed). A child whose weight (the power
   it can still bring to the detector) is below ``threshold`` ends by Russian roulette
   (unbiased: survivors are scaled by 1/p) or, with ``termination: temperature``, on the last
   object's temperature as the seed does.

With these rules the weights of all events of a primary ray add to 1 per polarization, so an
isothermal enclosure reads its temperature exactly (PHYSICS.md, "Energy bookkeeping").
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from pmmw_cli.physics import fresnel, multilayer
from pmmw_cli.physics.jones import basis_change, row_power, stokes_terms
from pmmw_cli.scene.camera import pixel_samples
from pmmw_cli.trace.intersect import offset_along
from pmmw_cli.trace.job import BLACKBODY, DIELECTRIC, METAL, OPAQUE, THIN, TraceJob

_Z = np.array([0.0, 0.0, 1.0])
_TINY = 1e-12
_A_ROUNDING = 1e-12  # absorbed fractions below this are rounding of lossless interfaces


@dataclass
class TileResult:
    """What one tile produced.

    Attributes
    ----------
    index : int
    box : tuple (x0, y0, x1, y1)
    mean : ndarray, shape (h, w, 4), float64
        Per-pixel mean of (Ex2, Ey2, U, V) over samples [K].
    stderr : ndarray, shape (h, w, 4), float64
        Monte Carlo standard error of that mean [K] (zero with one sample).
    depth : ndarray, shape (h, w), float64
        Mean first-hit distance [m] (inf where every sample saw the sky).
    material : ndarray, shape (h, w), float64
        Medium index hit by the pixel's first sample (-1: sky).
    rays : int
        Ray segments intersected.
    samples : ndarray, shape (h, w), int32
        Samples taken per pixel (fewer than ``spp`` where adaptive sampling stopped early).
    t_isect : float
        Seconds spent in the intersector (the bare Embree cost of exactly these rays).
    """

    index: int
    box: tuple
    mean: np.ndarray
    stderr: np.ndarray
    depth: np.ndarray
    material: np.ndarray
    rays: int
    samples: np.ndarray
    t_isect: float = 0.0


class _Wave:
    """Struct of arrays for the rays of one bounce."""

    __slots__ = ("o", "d", "s", "p", "m", "sid", "depth", "stack", "top", "last_t")

    def __init__(self, **kw):
        for k, v in kw.items():
            setattr(self, k, v)

    def take(self, idx):
        if idx.dtype == bool:
            idx = np.flatnonzero(idx)  # once, not once per array: half the cost of a take
        return _Wave(**{k: getattr(self, k)[idx] for k in self.__slots__})

    @staticmethod
    def concat(waves):
        waves = [w for w in waves if w is not None and w.o.shape[0] > 0]
        if not waves:
            return None
        return _Wave(**{k: np.concatenate([getattr(w, k) for w in waves]) for k in _Wave.__slots__})

    def __len__(self):
        return self.o.shape[0]


def _stderr(s1, s2, count):
    """Standard error of the mean from shifted sums of values and squares; 0 for one sample."""
    c = count[:, None].astype(float)
    var = np.maximum(s2 - s1 * s1 / c, 0.0) / np.maximum(c - 1.0, 1.0)
    return np.where(c > 1, np.sqrt(var / c), 0.0)


def _normalize(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _scale_columns(m, a, b):
    """M @ diag(a, b) for (n, 2, 2) M and (n,) a, b."""
    out = m.copy()
    out[:, :, 0] *= a[:, None]
    out[:, :, 1] *= b[:, None]
    return out


def _amplitude(amp, power):
    """An amplitude with the phase of ``amp`` and the magnitude sqrt(power) (renormalized R, T)."""
    mag = np.abs(amp)
    phase = np.where(mag > 0.0, amp / np.where(mag > 0.0, mag, 1.0), 1.0)
    return phase * np.sqrt(np.maximum(power, 0.0))


def surface_response(job: TraceJob, cur, face_med, other, leaving, cos1):
    """Interface coefficients for a group of rays with the same media and orientation.

    Parameters
    ----------
    job : TraceJob
    cur, face_med, other : int
        Medium of the incident side, medium of the face's object, medium on the far side.
    leaving : bool
        The ray leaves ``face_med`` (coating layers are then met innermost first).
    cos1 : ndarray, shape (n,), float64
        Cosine of the incidence angle in the incident medium.

    Returns
    -------
    coeffs : fresnel.Fresnel
        Amplitudes and powers, arrays of shape (n,).
    t_coat : float
        Temperature at which the coating's absorption emits [K]. For a bare interface the
        absorbed remainder only exists when the incident medium is lossy (homogeneous-wave
        approximation, PHYSICS.md) and is emitted at the incident medium's temperature.
    """
    media = job.media
    kind = media.kind[face_med]
    eps1 = media.eps[cur]
    coat = media.coating[face_med]
    if kind == METAL and coat is None:
        n = cos1.shape[0]
        one, zero = np.ones(n), np.zeros(n)
        c = fresnel.Fresnel(-one + 0j, one + 0j, zero + 0j, zero + 0j, one, one, zero, zero, zero, zero)
        return c, float(media.temperature[face_med])
    if kind == THIN:
        eps2 = eps1  # the sheet keeps the incident medium on both sides
    elif kind == BLACKBODY:
        # index-matched body: nothing reflects at its own surface, all that enters is absorbed
        eps2 = coat.eps[-1] if coat is not None else eps1
    else:
        eps2 = media.eps[other]
    if coat is None:
        c = fresnel.interface(np.full(cos1.shape, eps1), np.full(cos1.shape, eps2), cos1)
        return c, float(media.temperature[cur])
    layers_eps, layers_d = coat.eps, coat.thickness
    if leaving:
        layers_eps, layers_d = layers_eps[::-1], layers_d[::-1]
    eps = np.concatenate([[eps1], layers_eps, [eps2]])
    substrate = "metal" if kind == METAL else "dielectric"
    c = multilayer.stack(eps[None, :], layers_d[None, :], cos1, job.k0, substrate=substrate)
    return c, coat.temperature


def brightness_bounds(job: TraceJob, source_range=()):
    """(T_lo, T_hi) [K]: bounds of every temperature an event of a ray tree can add.

    Media and coating temperatures (emission, the depth cut-off), the sky's range, and the given
    atmospheric source temperatures. None when the sky cannot say its range.
    """
    sky_range = getattr(job.sky, "temperature_range", None)
    if sky_range is None:
        return None
    ts = [*job.media.temperature, *sky_range(), *source_range]
    ts += [c.temperature for c in job.media.coating if c is not None]
    return float(min(ts)), float(max(ts))


def atmosphere_skip_length(job: TraceJob) -> float:
    """Ambient segments shorter than this [m] skip the layered atmosphere (0: none do).

    Error budget (``render.atmosphere_tolerance`` = E [K]). A segment of length L through cells of
    extinction at most alpha_max loses 1 - exp(-tau) <= alpha_max L of the brightness T_far that
    reaches its far end and adds that fraction of a mean source temperature S of its cells
    (`AtmosphereModel.path`); skipping it changes the ray's brightness by
    (1 - exp(-tau)) (S - T_far), at most alpha_max L dT with dT = max(S_max - T_lo, T_hi - S_min)
    (`brightness_bounds`; alpha_max, S_min, S_max over the cells between the lowest and highest
    point of the scene and the imager). A path has at most ``max_depth`` segments, and at each depth
    the powers of a split ray tree add to at most 1 per polarization, so skipping every segment
    with alpha_max L dT <= E / max_depth moves any pixel's Ex2 and Ey2 by at most E (exactly with
    ``termination: temperature``, in expectation with Russian roulette; a face crossed without
    interacting, rare, cuts a segment in two and adds one more). The test is one comparison per
    segment; `AtmosphereModel.path` walks the cells of each one.
    """
    st, atm = job.settings, job.atmosphere
    if atm is None or st.atmosphere_tolerance <= 0.0:
        return 0.0
    cam = job.camera
    r_ap = getattr(cam, "aperture_radius", 0.0)
    z = job.vertices[:, 2]
    z_lo = min(float(z.min()) if z.size else np.inf, cam.position[2] - r_ap)
    z_hi = max(float(z.max()) if z.size else -np.inf, cam.position[2] + r_ap)
    alpha_max, s_min, s_max = atm.extremes(z_lo, z_hi)
    bounds = brightness_bounds(job, (s_min, s_max))
    if bounds is None or alpha_max <= 0.0:
        return 0.0 if bounds is None else np.inf
    t_lo, t_hi = bounds
    d_t = max(s_max - t_lo, t_hi - s_min)
    if d_t <= 0.0:
        return np.inf  # isothermal: the atmosphere changes nothing
    return st.atmosphere_tolerance / (st.max_depth * alpha_max * d_t)


class Integrator:
    """Renders tiles of one `TraceJob` with one intersector (built once per worker)."""

    def __init__(self, job: TraceJob, intersector):
        self.job = job
        self.isect = intersector
        self.atm_skip_length = atmosphere_skip_length(job)

    # -- public -----------------------------------------------------------------------------
    def render_tile(self, tile) -> TileResult:
        """Render one tile: all its pixels, in sampling passes.

        Without ``target_error`` one pass takes every sample. With it, a first pass of
        ``min_spp`` samples estimates each pixel's Monte Carlo standard error; pixels still above
        ``target_error * error_footprint`` get passes of doubling size until they reach it or
        ``spp`` samples. With a blurring imager, error_footprint = 1 / sqrt(sum psf^2): the
        pixels' errors are independent, so the blurred error sqrt(sum_k psf_k^2 sigma_k^2) is at
        most that many times the largest sigma_k of the footprint, and stopping every pixel at
        sigma <= target / sqrt(sum psf^2) keeps the sensor image's error at or below the target
        (up to how well a few samples estimate sigma).
        """
        index, x0, y0, x1, y1 = tile
        st, cam = self.job.settings, self.job.camera
        w, h = x1 - x0, y1 - y0
        cols, rows = np.meshgrid(np.arange(x0, x1), np.arange(y0, y1))
        pixels = (rows * cam.width + cols).ravel().astype(np.int64)
        npx = pixels.size
        self.rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([st.seed, index])))
        self.rays = 0
        self.t_isect = 0.0
        adaptive = st.target_error is not None and st.spp > st.min_spp
        ref = np.zeros((npx, 4))  # per-pixel shift of the running sums (first pass mean)
        s1, s2 = np.zeros((npx, 4)), np.zeros((npx, 4))
        count = np.zeros(npx, np.int64)
        depth = np.full(npx, np.inf)
        material = np.full(npx, -1.0)
        active = np.arange(npx)
        done = 0
        batch = st.min_spp if adaptive else st.spp
        while active.size and done < st.spp:
            nb = min(batch, st.spp - done)
            vals, first_t, first_m = self._trace(pixels[active], done, nb)
            v = vals.reshape(active.size, nb, 4)
            if done == 0:
                ref[active] = v.mean(axis=1)
                with np.errstate(invalid="ignore"):
                    depth[active] = first_t.reshape(active.size, nb).mean(axis=1)
                material[active] = first_m.reshape(active.size, nb)[:, 0]
            dv = v - ref[active][:, None, :]
            s1[active] += dv.sum(axis=1)
            s2[active] += (dv * dv).sum(axis=1)
            count[active] += nb
            done += nb
            if not adaptive:
                break
            err = _stderr(s1[active], s2[active], count[active])
            active = active[np.max(err[:, :2], axis=1) > st.target_error * st.error_footprint]
            batch = done  # double the samples of the pixels that still need them
        mean = ref + s1 / count[:, None]
        stderr = _stderr(s1, s2, count)
        return TileResult(
            index, (x0, y0, x1, y1), mean.reshape(h, w, 4), stderr.reshape(h, w, 4),
            depth.reshape(h, w), material.reshape(h, w), self.rays,
            count.reshape(h, w).astype(np.int32), self.t_isect,
        )

    def _trace(self, pixels, start, nb):
        """Trace samples ``start .. start+nb-1`` of each pixel; per-sample (Ex2, Ey2, U, V)."""
        st, cam = self.job.settings, self.job.camera
        u, v, pix = pixel_samples(cam.width, pixels, nb, st.seed, start=start, total=st.spp)
        n = u.shape[0]
        self.acc = np.zeros((n, 4))
        self.first_t = np.full(n, np.inf)
        self.first_m = np.full(n, -1.0)
        sample_no = np.tile(np.arange(start, start + nb, dtype=np.int64), pixels.size)
        origins, d = cam.rays(u, v, pix * st.spp + sample_no, st.seed)
        s = _normalize(cam.x[None, :] - np.einsum("ij,j->i", d, cam.x)[:, None] * d)
        p = np.cross(-d, s)
        # The pixel's polarization basis is (s, p): the imager's x projected perpendicular to
        # the ray and y completing it (jones.py), so M starts as the identity (eq. 2.11b).
        m = np.zeros((n, 2, 2), complex)
        m[:, 0, 0] = m[:, 1, 1] = 1.0
        wave = _Wave(
            o=origins, d=d, s=s, p=p, m=m,
            sid=np.arange(n), depth=np.zeros(n, np.int32), stack=np.zeros((n, st.stack_size), np.int16),
            top=np.zeros(n, np.int32), last_t=np.full(n, np.nan),
        )
        first = True
        while wave is not None and len(wave) > 0:
            wave = self._bounce(wave, first)
            first = False
        return self.acc, self.first_t, self.first_m

    # -- one bounce -----------------------------------------------------------------------
    def _emit(self, sid, m, ta, tb=None):
        """Add incoherent emission seen through N = m (already scaled by emission amplitudes)."""
        if sid.size == 0:
            return
        terms = stokes_terms(m, ta, ta if tb is None else tb)
        nsamp = self.acc.shape[0]
        for c in range(4):
            self.acc[:, c] += np.bincount(sid, weights=terms[:, c], minlength=nsamp)

    def _bounce(self, wave: _Wave, first: bool):
        job = self.job
        media = job.media
        n = len(wave)
        t0 = time.perf_counter()
        t, prim = self.isect.intersect(wave.o, wave.d)
        self.t_isect += time.perf_counter() - t0
        self.rays += n
        miss = prim < 0
        if first:
            self.first_t[wave.sid] = t
            self.first_m[wave.sid[~miss]] = job.face_medium[prim[~miss]]
        if miss.any():
            self._sky(wave.take(miss))
        hit = ~miss
        if not hit.any():
            return None
        wv = wave.take(hit)
        t, prim = t[hit], prim[hit]
        rows = np.arange(len(wv))
        cur = wv.stack[rows, wv.top].astype(np.int64)

        # The layered atmosphere along ambient segments: transmittance and own emission of the
        # layers crossed, seen from the segment's near end (issue 3; exact for straight segments).
        if job.atmosphere is not None:
            amb = (cur == 0) & (t > self.atm_skip_length)  # shorter ones: below the error budget
            if amb.any():
                trans, emission = job.atmosphere.path(wv.o[amb, 2], wv.o[amb, 2] + t[amb] * wv.d[amb, 2], t[amb])
                self._emit(wv.sid[amb], wv.m[amb], emission)
                wv.m[amb] *= np.sqrt(trans)[:, None, None]

        # Absorption and emission along the segment just travelled (eq. 2.37, 2.38).
        alpha = media.alpha[cur]
        lossy = alpha > 0.0
        if lossy.any():
            tau = np.exp(-alpha[lossy] * t[lossy])
            e = np.sqrt(1.0 - tau)
            self._emit(wv.sid[lossy], wv.m[lossy] * e[:, None, None], media.temperature[cur[lossy]])
            wv.m[lossy] *= np.sqrt(tau)[:, None, None]

        pos = wv.o + t[:, None] * wv.d
        face_med = job.face_medium[prim].astype(np.int64)
        nf = job.face_normals[prim]
        cosf = np.einsum("ij,ij->i", wv.d, nf)
        kind = media.kind[face_med]
        entering = cosf < 0.0
        below = wv.stack[rows, np.maximum(wv.top - 1, 0)].astype(np.int64)
        below = np.where(wv.top > 0, below, 0)
        dielectric = kind == DIELECTRIC
        leaving_cur = dielectric & ~entering & (face_med == cur)
        full = wv.top >= wv.stack.shape[1] - 1
        enter_ok = dielectric & entering & ~full
        interact = (~dielectric | enter_ok | leaving_cur) & (cosf != 0.0)

        out = []
        passing = ~interact
        if passing.any():
            out.append(self._pass_through(wv.take(passing), pos[passing], face_med[passing], prim[passing]))
        if interact.any():
            idx = np.nonzero(interact)[0]
            other = np.where(kind[idx] != DIELECTRIC, face_med[idx], np.where(entering[idx], face_med[idx], below[idx]))
            n_in = np.where(cosf[idx, None] < 0.0, nf[idx], -nf[idx])  # normal facing the incident side
            leaving = ~entering[idx] & dielectric[idx]
            out.extend(
                self._interact(wv.take(idx), pos[idx], n_in, cur[idx], face_med[idx], other, leaving, prim[idx])
            )
        return _Wave.concat(out)

    def _sky(self, wv: _Wave):
        sky = self.job.sky
        ta, tb = sky.brightness(wv.d, heights=wv.o[:, 2])
        if sky.unpolarized:
            self._emit(wv.sid, wv.m, np.asarray(ta, float))
            return
        k = -wv.d
        hvec = np.cross(_Z[None, :], k)
        norm = np.linalg.norm(hvec, axis=1, keepdims=True)
        hvec = np.where(norm > _TINY, hvec / np.where(norm > _TINY, norm, 1.0), wv.s)
        vvec = np.cross(k, hvec)
        m = wv.m @ basis_change(wv.s, wv.p, hvec, vvec)
        self._emit(wv.sid, m, np.asarray(tb, float), np.asarray(ta, float))  # columns (h, v) = (Th, Tv)

    def _pass_through(self, wv: _Wave, pos, face_med, prim):
        """Cross a face without interacting; drop its medium from the stack if it is there."""
        wv.o = offset_along(pos, self.job.face_normals[prim], wv.d, self.isect.face_offset[prim])
        depth_idx = np.arange(wv.stack.shape[1])[None, :]
        in_stack = (wv.stack == face_med[:, None]) & (depth_idx <= wv.top[:, None]) & (depth_idx > 0)
        has = in_stack.any(axis=1)
        if has.any():
            rows = np.nonzero(has)[0]
            pos_k = np.argmax(in_stack[rows], axis=1)
            for r, kpos in zip(rows, pos_k):  # rare: only at interpenetrating objects
                top = wv.top[r]
                wv.stack[r, kpos:top] = wv.stack[r, kpos + 1 : top + 1]
                wv.top[r] = top - 1
        return wv

    def _interact(self, wv: _Wave, pos, n_in, cur, face_med, other, leaving, prim):
        job = self.job
        step = self.isect.face_offset[prim]
        media = job.media
        nr = len(wv)
        cos1 = np.clip(-np.einsum("ij,ij->i", wv.d, n_in), 0.0, 1.0)

        # Coefficients per group of equal (cur, face medium, other, leaving).
        coeff = {k: np.empty(nr, complex) for k in ("rs", "rp", "ts", "tp")}
        coeff.update({k: np.empty(nr) for k in ("Rs", "Rp", "Ts", "Tp", "As", "Ap")})
        t_coat = np.zeros(nr)
        key = ((cur * 4096 + face_med) * 4096 + other) * 2 + leaving
        for kv in np.unique(key):
            g = key == kv
            i0 = np.argmax(g)
            c, tc = surface_response(job, int(cur[i0]), int(face_med[i0]), int(other[i0]), bool(leaving[i0]), cos1[g])
            for name in coeff:
                coeff[name][g] = getattr(c, name)
            t_coat[g] = tc

        # Local (s, p) basis of the outgoing wave k = -d (eq. 2.23).
        k_out = -wv.d
        s = np.cross(n_in, k_out)
        norm = np.linalg.norm(s, axis=1, keepdims=True)
        s = np.where(norm > 1e-9, s / np.where(norm > 1e-9, norm, 1.0), wv.s)
        p_out = np.cross(k_out, s)
        ml = wv.m @ basis_change(wv.s, wv.p, s, p_out)

        kind = media.kind[face_med]
        t_body = media.temperature[face_med]
        absorb = (coeff["As"] > _A_ROUNDING) | (coeff["Ap"] > _A_ROUNDING)
        if absorb.any():
            a = absorb
            self._emit(wv.sid[a], _scale_columns(ml[a], np.sqrt(coeff["As"][a]), np.sqrt(coeff["Ap"][a])), t_coat[a])
        sink = (kind == BLACKBODY) | (kind == OPAQUE)
        if sink.any():
            a = sink
            self._emit(wv.sid[a], _scale_columns(ml[a], np.sqrt(coeff["Ts"][a]), np.sqrt(coeff["Tp"][a])), t_body[a])

        children = []
        trans = ((kind == DIELECTRIC) | (kind == THIN)) & ((coeff["Ts"] > 0.0) | (coeff["Tp"] > 0.0))
        keep_r, keep_t, gain_r, gain_t = self._choose_branches(wv, coeff, trans)

        # Reflected child (eq. 2.21, 2.39).
        if keep_r.any():
            i = np.nonzero(keep_r)[0]
            cosd = np.einsum("ij,ij->i", wv.d[i], n_in[i])
            d_r = wv.d[i] - 2.0 * cosd[:, None] * n_in[i]
            m_r = _scale_columns(ml[i], gain_r[i] * _amplitude(coeff["rs"][i], coeff["Rs"][i]),
                                 gain_r[i] * _amplitude(coeff["rp"][i], coeff["Rp"][i]))
            children.append(_Wave(
                o=offset_along(pos[i], n_in[i], d_r, step[i]), d=d_r, s=s[i], p=np.cross(-d_r, s[i]),
                m=m_r, sid=wv.sid[i], depth=wv.depth[i] + 1, stack=wv.stack[i].copy(), top=wv.top[i].copy(),
                last_t=t_body[i],
            ))

        # Transmitted child (eq. 2.19, 2.40): dielectrics refract into the other medium, thin
        # sheets pass straight through.
        if keep_t.any():
            i = np.nonzero(keep_t)[0]
            d_t = wv.d[i].copy()
            diel = kind[i] == DIELECTRIC
            if diel.any():
                j = i[diel]
                d_t[diel] = _refract(wv.d[j], n_in[j], media.eps[cur[j]], media.eps[other[j]])
            m_t = _scale_columns(ml[i], gain_t[i] * _amplitude(coeff["ts"][i], coeff["Ts"][i]),
                                 gain_t[i] * _amplitude(coeff["tp"][i], coeff["Tp"][i]))
            stack, top = wv.stack[i].copy(), wv.top[i].copy()
            enter = diel & ~leaving[i]
            top[enter] += 1
            stack[np.nonzero(enter)[0], top[enter]] = face_med[i][enter]
            leave = diel & leaving[i]
            top[leave] -= 1
            children.append(_Wave(
                o=offset_along(pos[i], n_in[i], d_t, step[i]), d=d_t, s=s[i], p=np.cross(-d_t, s[i]), m=m_t,
                sid=wv.sid[i], depth=wv.depth[i] + 1, stack=stack, top=top, last_t=t_body[i],
            ))

        nxt = _Wave.concat(children)
        return [self._terminate(nxt)] if nxt is not None else []

    def _choose_branches(self, wv: _Wave, coeff, trans):
        """Which children to follow (``render.strategy``) and their amplitude gains.

        ``split`` follows both (the seed's deterministic splitting). ``stochastic`` follows one,
        reflected with probability P = (Rs + Rp) / (Rs + Rp + Ts + Tp), and divides its power by
        the probability of the choice (unbiased). ``hybrid`` splits for the first
        ``split_depth`` interactions of a path and chooses after that.
        """
        st = self.job.settings
        n = len(wv)
        keep_r, keep_t = np.ones(n, bool), trans.copy()
        gain_r, gain_t = np.ones(n), np.ones(n)
        if st.strategy == "split":
            return keep_r, keep_t, gain_r, gain_t
        choose = trans & ((wv.depth >= st.split_depth) if st.strategy == "hybrid" else True)
        if choose.any():
            r = coeff["Rs"][choose] + coeff["Rp"][choose]
            t = coeff["Ts"][choose] + coeff["Tp"][choose]
            p_r = r / np.maximum(r + t, _TINY)
            take_r = self.rng.random(p_r.shape[0]) < p_r
            idx = np.nonzero(choose)[0]
            keep_r[idx[~take_r]] = False
            keep_t[idx[take_r]] = False
            gain_r[idx[take_r]] = 1.0 / np.sqrt(p_r[take_r])
            gain_t[idx[~take_r]] = 1.0 / np.sqrt(1.0 - p_r[~take_r])
        return keep_r, keep_t, gain_r, gain_t

    def _terminate(self, wv: _Wave):
        """Depth cut-off and weight threshold (seed 000 sec. 2.2.5, 2.2.9)."""
        st = self.job.settings
        weight = row_power(wv.m)
        dead = weight <= 0.0
        at_depth = (wv.depth >= st.max_depth) & ~dead
        if at_depth.any():
            self._emit(wv.sid[at_depth], wv.m[at_depth], wv.last_t[at_depth])
        low = (weight < st.threshold) & ~at_depth & ~dead
        if low.any():
            if st.termination == "temperature":
                self._emit(wv.sid[low], wv.m[low], wv.last_t[low])
                dead |= low
            else:
                q = weight[low] / st.threshold
                survive = self.rng.random(q.shape[0]) < q
                idx = np.nonzero(low)[0]
                wv.m[idx[survive]] /= np.sqrt(q[survive])[:, None, None]
                dead[idx[~survive]] = True
        keep = ~(dead | at_depth)
        return wv.take(keep) if not keep.all() else wv


def _refract(d, n_in, eps1, eps2):
    """Real transmitted direction under the homogeneous-wave assumption (seed 000 sec. 2.2.4).

    The tangential wave-vector component is conserved (eq. 2.18) and the normal component is
    Re q2 = Re sqrt(eps2 - eps1 sin^2 th1) (eq. 2.20, outgoing branch Re q2 >= 0), so that for
    lossless media this is Snell's law exactly.

    Parameters
    ----------
    d : ndarray, shape (n, 3)
        Incident (trace) direction.
    n_in : ndarray, shape (n, 3)
        Unit normal facing the incident side (d . n_in < 0).
    eps1, eps2 : ndarray, shape (n,), complex128

    Returns
    -------
    ndarray, shape (n, 3), float64
    """
    cos1 = -np.einsum("ij,ij->i", d, n_in)
    tang = d + cos1[:, None] * n_in  # |tang| = sin th1
    sin2 = np.clip(1.0 - cos1**2, 0.0, 1.0)
    n1 = np.sqrt(eps1 + 0j)
    # the wave runs away from the interface (eq. 2.20): the outgoing root, Re q2 >= 0, which is
    # also the decaying one unless the incident medium is lossy
    q2 = fresnel.normal_component(eps2, eps1 * sin2, branch="outgoing")
    dt = n1.real[:, None] * tang - q2.real[:, None] * n_in
    return _normalize(dt)
