"""The bounce loop: a wavefront of backward rays per bounce, vectorized over rays.

Follows the flowchart of Murakowski 2014 sec. 2.2.5 (fig. 2.5). Every ray carries a Jones matrix M
(convention in `pmmw_cli.physics.jones`). At each bounce, for all rays at once:

1. intersect (Embree); rays that miss see the sky;
2. the segment just travelled attenuates M by exp(-alpha d / 2) and emits at the medium's
   temperature with weight 1 - exp(-alpha d) (eq. 2.37, 2.38);
3. media are tracked with closed orientable meshes and a per-ray medium stack (sec. 2.2.9):
   crossing a face outward-to-inward enters the face's material; crossing inward-to-outward
   leaves it if it is the current medium, or silently drops it from the stack if it is a medium
   further down (slightly interpenetrating touching objects, as Murakowski 2014 prescribes);
4. at an interaction, the surface's coating stack (or bare interface) gives r, t, R, T, A; the
   coating's absorption A emits at the coating temperature (eq. 2.36); ``metal`` reflects
   everything, ``blackbody`` and ``opaque`` emit the transmitted power at their temperature,
   ``thin`` sheets transmit without changing medium or direction;
5. the reflected and transmitted children continue (deterministic splitting). A child beyond
   ``max_depth`` ends on the last object's temperature (Murakowski 2014). A child whose weight (the power
   it can still bring to the detector) is below ``threshold`` ends by Russian roulette
   (unbiased: survivors are scaled by 1/p) or, with ``termination: temperature``, on the last
   object's temperature as Murakowski 2014 does.

With these rules the weights of all events of a primary ray add to 1 per polarization, so an
isothermal enclosure reads its temperature exactly (PHYSICS.md, "Energy bookkeeping").
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import binary_dilation

from pmmw_cli.physics import fresnel
from pmmw_cli.physics.jones import rebase
from pmmw_cli.physics.roughness import MAX_REHITS, NOT_ROUGH, OTHER_CODE
from pmmw_cli.physics.vec import cross
from pmmw_cli.scene.camera import REPLICATES, pixel_samples
from pmmw_cli.trace import kernels
from pmmw_cli.trace.job import C0, DIELECTRIC, TraceJob

_Z = np.array([0.0, 0.0, 1.0])
_TINY = 1e-12
_NEIGHBOURS = np.ones((3, 3), bool)  # a pixel and its 8 neighbours (adaptive sampling)
_NO_RANDOM = np.zeros(0)  # the kernels' "no uniforms drawn"
_NO_CODE = np.zeros(0, np.int8)  # `kernels.scatter` does not read the codes of `kernels.arrive`
_MAX_WALK = 1000  # facet events of one walk through rough coating layers (never reached in tests)
MAX_WAVE = 1 << 16  # camera rays traced at once: a tile's pass of more is split, so memory is flat in spp


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
        Standard error of that mean [K] as if the samples were independent (zero with one
        sample): the adaptive sampler's criterion; it overstates the error of the
        low-discrepancy samples (`pixel_samples`) where a pixel's value varies smoothly or has
        an edge.
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
    truncated : ndarray, shape (h, w, 2), float64
        Per-pixel mean over samples of (the fraction of the detector's power, mean of the Ex and
        Ey rows, whose path was ended on the last object's temperature instead of being traced:
        by ``max_depth``, or below ``threshold`` with ``termination: temperature``; the largest
        change of Ex2 or Ey2 that tracing those paths on could bring [K]).
       replicate_diff : ndarray, shape (h, w, 4), float64
        Mean of the even samples minus mean of the odd ones (the two independent replicates of
        `pixel_samples`) [K]; zero where either is empty. ``replicate_diff**2 / 4`` is an
        unbiased estimate of the variance of ``mean`` (exactly so for equal halves), with one
        degree of freedom per pixel: sums over many pixels (region means) are what it is for.
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
    truncated: np.ndarray | None = None
    replicate_diff: np.ndarray | None = None


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
        if len(waves) == 1:
            return waves[0]
        return _Wave(**{k: np.concatenate([getattr(w, k) for w in waves]) for k in _Wave.__slots__})

    def __len__(self):
        return self.o.shape[0]

    def arrays(self):
        """The fields as the tuple the compiled kernels take (`pmmw_cli.trace.kernels`)."""
        return tuple(getattr(self, k) for k in self.__slots__)

    @staticmethod
    def empty(n, stack_size):
        """Room for ``n`` rays (filled by `kernels.scatter`)."""
        return _Wave(o=np.empty((n, 3)), d=np.empty((n, 3)), s=np.empty((n, 3)), p=np.empty((n, 3)),
                     m=np.empty((n, 2, 2), complex), sid=np.empty(n, np.int64), depth=np.empty(n, np.int32),
                     stack=np.empty((n, stack_size), np.int16), top=np.empty(n, np.int32), last_t=np.empty(n))

    def head(self, n):
        """The first ``n`` rays (views)."""
        return _Wave(**{k: getattr(self, k)[:n] for k in self.__slots__})


def _stderr(s1, s2, count):
    """Standard error of the mean from shifted sums of values and squares; 0 for one sample."""
    c = count[:, None].astype(float)
    var = np.maximum(s2 - s1 * s1 / c, 0.0) / np.maximum(c - 1.0, 1.0)
    return np.where(c > 1, np.sqrt(var / c), 0.0)


def _normalize(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def surface_response(job: TraceJob, cur, face_med, other, leaving, cos1):
    """`surface_coefficients` for a group of rays with the same media and orientation (scalars
    ``cur``, ``face_med``, ``other``, ``leaving``); ``t_coat`` is then one temperature."""
    n = cos1.shape[0]
    c, t_coat, q2 = surface_coefficients(job, np.full(n, cur), np.full(n, face_med), np.full(n, other),
                                         np.full(n, bool(leaving)), cos1)
    return c, (float(t_coat[0]) if n else 0.0), (q2 if n and not np.isnan(q2[0]) else None)


def surface_coefficients(job: TraceJob, cur, face_med, other, leaving, cos1):
    """Interface coefficients of rays meeting faces, each with its own media and orientation:
    `kernels.coefficients`, the tracer's own, over arrays (for `pmmw po` and the tests).

    Parameters
    ----------
    job : TraceJob
    cur, face_med, other : ndarray, shape (n,), int
        Medium of the incident side, medium of the face's object, medium on the far side.
    leaving : ndarray, shape (n,), bool
        The ray leaves ``face_med`` (coating layers are then met innermost first).
    cos1 : ndarray, shape (n,), float64
        Cosine of the incidence angle in the incident medium.

    Returns
    -------
    coeffs : fresnel.Fresnel
        Amplitudes and powers, arrays of shape (n,).
    t_coat : ndarray, shape (n,), float64
        Temperature at which the absorbed part emits [K]: the films'; the body's for a bare
        perfect conductor; for a bare interface the absorbed remainder only exists when the
        incident medium is lossy (homogeneous-wave approximation, PHYSICS.md) and is emitted at
        the incident medium's temperature.
    q2 : ndarray, shape (n,), complex128
        The far medium's normal component (outgoing root) that refraction uses; NaN for a
        perfect conductor.
    """
    media, films = _kernel_tables(job)[:2]
    n = cos1.shape[0]
    amp, power, q2, t_coat = np.empty((n, 4), complex), np.empty((n, 6)), np.empty(n, complex), np.empty(n)
    kernels.coefficients(np.ascontiguousarray(cur, np.int64), np.ascontiguousarray(face_med, np.int64),
                         np.ascontiguousarray(other, np.int64), np.ascontiguousarray(leaving, bool),
                         np.ascontiguousarray(cos1, float), media, films, amp, power, q2, t_coat)
    return fresnel.Fresnel(*(amp[:, k] for k in range(4)), *(power[:, k] for k in range(6))), t_coat, q2


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


def _scene_heights(job: TraceJob) -> tuple[float, float]:
    """Lowest and highest height [m] of the scene's geometry and the imager's aperture."""
    cam = job.camera
    r_ap = getattr(cam, "aperture_radius", 0.0)
    z = job.vertices[:, 2]
    z_lo = min(float(z.min()) if z.size else np.inf, cam.position[2] - r_ap)
    z_hi = max(float(z.max()) if z.size else -np.inf, cam.position[2] + r_ap)
    return z_lo, z_hi


def atmosphere_source_range(job: TraceJob) -> tuple:
    """(S_min, S_max) [K] of the layered atmosphere's cells the scene's segments can cross; ()
    without a layered atmosphere."""
    if job.atmosphere is None:
        return ()
    _, s_min, s_max = job.atmosphere.extremes(*_scene_heights(job))
    return s_min, s_max


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
    alpha_max, s_min, s_max = atm.extremes(*_scene_heights(job))
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

    def __init__(self, job: TraceJob, intersector, compiled: bool | None = None):
        self.job = job
        self.isect = intersector
        media = job.media
        # which media have rough coating layers (None: none, the common case)
        layered = np.array([bool(media.rough_layers(k)) for k in range(len(media.ids))])
        self.layered = layered if layered.any() else None
        self.rough_scene = media.any_rough  # smooth scenes skip every roughness and bump step
        self.atm_skip_length = atmosphere_skip_length(job)
        # what a path ended on a guessed temperature could have brought instead (truncation bound)
        bounds = brightness_bounds(job, atmosphere_source_range(job))
        self.t_bounds = bounds if bounds is not None else (-np.inf, np.inf)
        st = job.settings
        self._limits = (int(st.max_depth), float(st.threshold), st.termination == "roulette",
                        float(self.t_bounds[0]), float(self.t_bounds[1]))
        self._choice = (kernels.STRATEGIES[st.strategy], int(st.split_depth))
        # smooth scenes interact in one compiled pass (`kernels.scatter`); rough surfaces and bump
        # maps run the same kernel about drawn facets, then `kernels.settle` (`_interact`), and so
        # does each facet event of the walk through rough layers (`_walk_layers`); ``compiled=False``
        # sends smooth scenes through `_interact` too (the reference of tests/test_compiled_tracer.py)
        self.compiled = not self.rough_scene if compiled is None else bool(compiled and not self.rough_scene)
        self._faces = (np.ascontiguousarray(job.face_medium, np.int32), np.ascontiguousarray(job.face_normals, float),
                       np.ascontiguousarray(intersector.face_offset, float))
        self._media, self._films, self._rough, self._rough_models, self._layer_media = _kernel_tables(job)
        self._rough_other = bool((self._rough[0] == OTHER_CODE).any())

    # -- public -----------------------------------------------------------------------------
    def render_tile(self, tile) -> TileResult:
        """Render one tile: all its pixels, in sampling passes.

        Without ``target_error`` one pass takes every sample. With it, a first pass of
        ``min_spp`` samples estimates each pixel's Monte Carlo standard error; pixels still above
        ``target_error * error_footprint``, and their 8 neighbours in the tile, get passes of
        doubling size until they reach it or ``spp`` samples. (The neighbours: a pixel that a
        small object covers in part can miss it with all of its first samples and read zero
        variance; the seed-to-seed spread of a sub-pixel target's contrast came from such
        pixels.) With a blurring imager, error_footprint = 1 / sqrt(sum psf^2): the pixels' errors are independent, so the blurred error sqrt(sum_k psf_k^2 sigma_k^2) is at
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
        r1 = np.zeros((npx, REPLICATES, 4))  # per replicate: summed shifted values
        depth = np.full(npx, np.inf)
        material = np.full(npx, -1.0)
        trunc = np.zeros((npx, 2))  # summed over samples: ended weight, bound [K]
        active = np.arange(npx)
        done = 0
        batch = st.min_spp if adaptive else st.spp
        while active.size and done < st.spp:
            end = min(done + batch, st.spp)
            while done < end:  # the pass in chunks of at most MAX_WAVE camera rays: memory stays flat in spp
                nb = min(end - done, max(1, MAX_WAVE // active.size))
                vals, first_t, first_m, cut = self._trace(pixels[active], done, nb)
                v = vals.reshape(active.size, nb, 4)
                trunc[active] += cut.reshape(active.size, nb, 2).sum(axis=1)
                if done == 0:
                    ref[active] = v.mean(axis=1)
                    with np.errstate(invalid="ignore"):
                        depth[active] = first_t.reshape(active.size, nb).mean(axis=1)
                    material[active] = first_m.reshape(active.size, nb)[:, 0]
                dv = v - ref[active][:, None, :]
                s1[active] += dv.sum(axis=1)
                s2[active] += (dv * dv).sum(axis=1)
                count[active] += nb
                for r in range(REPLICATES):
                    r1[active, r] += dv[:, (r - done) % REPLICATES::REPLICATES].sum(axis=1)
                done += nb
            if not adaptive:
                break
            err = _stderr(s1[active], s2[active], count[active])
            need = np.zeros(npx, bool)
            need[active[np.max(err[:, :2], axis=1) > st.target_error * st.error_footprint]] = True
            # a pixel that a small object covers in part may miss it with every one of its first
            # samples (zero variance): its neighbours that did see the edge keep it sampling
            grown = binary_dilation(need.reshape(h, w), structure=_NEIGHBOURS).ravel()
            active = active[grown[active]]
            batch = done  # double the samples of the pixels that still need them
        mean = ref + s1 / count[:, None]
        stderr = _stderr(s1, s2, count)
        # every pixel took samples 0 .. count-1: replicate r holds the sample numbers = r mod 2
        rcount = np.stack([(count + REPLICATES - 1 - r) // REPLICATES for r in range(REPLICATES)], axis=1)
        halves = r1 / np.maximum(rcount, 1)[:, :, None]
        diff = np.where((rcount > 0).all(axis=1)[:, None], halves[:, 0] - halves[:, 1], 0.0)
        return TileResult(
            index, (x0, y0, x1, y1), mean.reshape(h, w, 4), stderr.reshape(h, w, 4),
            depth.reshape(h, w), material.reshape(h, w), self.rays,
            count.reshape(h, w).astype(np.int32), self.t_isect,
            (trunc / count[:, None]).reshape(h, w, 2), diff.reshape(h, w, 4),
        )

    def _trace(self, pixels, start, nb):
        """Trace samples ``start .. start+nb-1`` of each pixel; per-sample (Ex2, Ey2, U, V)."""
        st, cam = self.job.settings, self.job.camera
        u, v, pix = pixel_samples(cam.width, pixels, nb, st.seed, start=start, total=st.spp)
        n = u.shape[0]
        self.acc = np.zeros((n, 4))
        self.cut = np.zeros((n, 2))
        self.first_t = np.full(n, np.inf)
        self.first_m = np.full(n, -1.0)
        sample_no = np.tile(np.arange(start, start + nb, dtype=np.int64), pixels.size)
        origins, d = cam.rays(u, v, pix * st.spp + sample_no, st.seed)
        s = _normalize(cam.x[None, :] - np.einsum("ij,j->i", d, cam.x)[:, None] * d)
        p = cross(-d, s)
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
        return self.acc, self.first_t, self.first_m, self.cut

    # -- one bounce -----------------------------------------------------------------------
    def _emit(self, sid, m, ta, tb=None):
        """Add incoherent emission seen through N = m (already scaled by emission amplitudes)."""
        n = sid.size
        if n == 0:
            return
        ta = np.ascontiguousarray(np.broadcast_to(np.asarray(ta, float), (n,)))
        tb = ta if tb is None else np.ascontiguousarray(np.broadcast_to(np.asarray(tb, float), (n,)))
        kernels.emit(self.acc, np.ascontiguousarray(sid, np.int64), np.ascontiguousarray(m, complex), ta, tb)

    def _intersect(self, wave: _Wave, first: bool):
        """Intersect a wave (counting rays and Embree's time), note the first hits, and send the
        rays that miss to the sky. Returns (t, prim, miss)."""
        t0 = time.perf_counter()
        t, prim = self.isect.intersect(wave.o, wave.d)
        self.t_isect += time.perf_counter() - t0
        self.rays += len(wave)
        miss = prim < 0
        if first:
            self.first_t[wave.sid] = t
            self.first_m[wave.sid[~miss]] = self.job.face_medium[prim[~miss]]
        if miss.any():
            self._sky(wave, np.flatnonzero(miss))
        return t, prim, miss

    def _bounce(self, wave: _Wave, first: bool):
        """One bounce of a wave: intersect; the sky for the rays that miss; for the others the
        segment just travelled and the face they hit (`kernels.arrive`); the interactions:
        compiled for smooth scenes (`kernels.scatter`), `_interact` / `_walk_layers` about
        facets, bumps and rough layers otherwise. Returns the next wave (None: empty)."""
        job = self.job
        n = len(wave)
        t, prim, miss = self._intersect(wave, first)
        if miss.all():
            return None
        atm = (_NO_RANDOM, _NO_RANDOM)
        if job.atmosphere is not None:
            # the layered atmosphere along ambient segments (shorter ones: below the error budget)
            amb = ~miss & (wave.stack[np.arange(n), wave.top] == 0) & (t > self.atm_skip_length)
            if amb.any():
                trans, emission = np.ones(n), np.zeros(n)
                trans[amb], emission[amb] = job.atmosphere.path(wave.o[amb, 2], wave.o[amb, 2] + t[amb] * wave.d[amb, 2],
                                                                t[amb])
                atm = (trans, emission)
        hit = (np.empty((n, 3)), np.empty((n, 3)), np.empty(n), np.empty(n, np.int64), np.empty(n, np.int64),
               np.empty(n, np.int64), np.empty(n, bool), np.empty(n, np.int8))
        arrays = wave.arrays()
        kernels.arrive(arrays, t, prim, atm, self._faces, self._media, self.acc, hit)
        rows = np.flatnonzero(hit[7] == 2)
        passing = np.flatnonzero(hit[7] == 1)
        out = [wave.take(passing)] if passing.size else []
        if not rows.size:
            return _Wave.concat(out)
        if self.compiled:
            u_choose = self.rng.random(rows.size) if job.settings.strategy != "split" else _NO_RANDOM
            u_roul = self.rng.random(2 * rows.size) if self._limits[2] else _NO_RANDOM
            kids = _Wave.empty(2 * rows.size, wave.stack.shape[1])
            count = kernels.scatter(rows, arrays, hit, self._films, prim, self._faces, self._media, self._choice, u_choose,
                                    u_roul, self._limits, self.acc, self.cut, kids.arrays(), kernels.NO_SETTLE)
            out.append(kids.head(count))
            return _Wave.concat(out)
        # the interacting rays to the front of the wave, in place (its other rays are done with)
        wv = wave.head(kernels.compact(arrays, hit[7] == 2))
        pos, n_in, cur, face_med, other, leaving = (hit[k][rows] for k in (0, 1, 3, 4, 5, 6))
        prim = prim[rows]
        n_mac = self._bumped(pos, wv.d, n_in, face_med)
        layered = self.layered[face_med] if self.layered is not None else None
        if layered is None or not layered.any():
            kids = self._interact(wv, pos, n_in, n_mac, cur, face_med, other, leaving, prim)
        else:
            a, b = np.nonzero(~layered)[0], np.nonzero(layered)[0]
            kids = self._interact(wv.take(a), pos[a], n_in[a], n_mac[a], cur[a], face_med[a], other[a], leaving[a],
                                  prim[a]) if a.size else []
            kids += self._walk_layers(wv.take(b), pos[b], n_in[b], n_mac[b], cur[b], face_med[b], other[b],
                                      leaving[b], prim[b])
        children = _Wave.concat(kids)
        if children is not None:
            out.append(self._terminate(children))
        return _Wave.concat(out)

    def _bumped(self, pos, d, n_in, face_med):
        """Macro normals tilted by the bump maps of the faces' materials (the face normal elsewhere).

        Where the tilt exceeds the incidence (the ray would meet the back of the bump: shading
        normals cannot model that shadowing) the face normal is kept.
        """
        media = self.job.media
        out = n_in
        values = _values(face_med)
        for k in values:
            bump = media.bump_map(int(k))
            if bump is None:
                continue
            if values.size == 1:
                return bump.shade(pos, n_in, d)  # the usual case: every ray on one material
            g = face_med == k
            if out is n_in:
                out = n_in.copy()
            out[g] = bump.shade(pos[g], n_in[g], d[g])
        return out

    def _sky(self, wave: _Wave, rows):
        """The sky's brightness seen by the rays ``rows`` of a wave (which missed every face)."""
        sky = self.job.sky
        d, sid, m = wave.d[rows], wave.sid[rows], wave.m[rows]
        ta, tb = sky.brightness(d, heights=wave.o[rows, 2])
        if sky.unpolarized:
            self._emit(sid, m, np.asarray(ta, float))
            return
        s = wave.s[rows]
        k = -d
        hvec = cross(_Z[None, :], k)
        norm = np.linalg.norm(hvec, axis=1, keepdims=True)
        hvec = np.where(norm > _TINY, hvec / np.where(norm > _TINY, norm, 1.0), s)
        vvec = cross(k, hvec)
        m = rebase(m, s, wave.p[rows], hvec, vvec)
        self._emit(sid, m, np.asarray(tb, float), np.asarray(ta, float))  # columns (h, v) = (Th, Tv)

    def _interact(self, wv: _Wave, pos, n_geo, n_mac, cur, face_med, other, leaving, prim, rehit=0):
        """Interaction of rays with one face: emission of what it absorbs, reflected and
        transmitted children.

        ``n_geo`` is the face's geometric normal and ``n_mac`` its macro (shading) normal, a
        bump map's tilt of it, both facing the incident side. On a rough surface each ray
        first draws a microfacet normal visible from it (`pmmw_cli.physics.roughness`, "How the
        renderer uses this") and the smooth-surface code below runs about that facet; children
        masked by the microsurface re-hit the same point at once (``rehit`` counts the chain).
        """
        step = self.isect.face_offset[prim]
        n_fac, tangent, rough = n_mac, None, None
        if self.rough_scene:
            n_fac, tangent, rough = self._facets(wv, n_mac, face_med)
        nr = len(wv)
        cos1 = np.clip(-np.einsum("ij,ij->i", wv.d, n_fac), 0.0, 1.0)
        # the smooth code about the facets (`kernels.scatter`), its children left at the hit
        # points for the masking test
        hit = (np.ascontiguousarray(pos), np.ascontiguousarray(n_fac), cos1, cur, face_med, other, leaving, _NO_CODE)
        rows = np.arange(nr)
        u_choose = self.rng.random(nr) if self.job.settings.strategy != "split" else _NO_RANDOM
        kids = _Wave.empty(2 * nr, wv.stack.shape[1])
        src, branch = np.empty(2 * nr, np.int64), np.empty(2 * nr, np.int8)
        count = kernels.scatter(rows, wv.arrays(), hit, self._films, prim, self._faces, self._media, self._choice, u_choose,
                                _NO_RANDOM, self._limits, self.acc, self.cut, kids.arrays(), (False, src, branch))
        leave, back = self._settle(kids.head(count), src[:count], branch[:count], pos, n_geo, n_mac, tangent, rough,
                                   face_med, prim, step, cur, other, leaving, rehit)
        out = [leave]
        if back is not None:
            # masked children of both branches hit the same points again, as one group (with the
            # weight threshold applied first: both children of a facet may be masked, so a chain
            # could otherwise double its rays at every step)
            back, args = back[0], list(back[1:])
            keep = self._survivors(back)
            if not keep.all():
                back, args = back.head(kernels.compact(back.arrays(), keep)), [a[keep] for a in args]
            if len(back):
                out += self._interact(back, *args, rehit + 1)
        return [w for w in out if w is not None and len(w)]

    def _facets(self, wv: _Wave, n_mac, face_med):
        """Microfacet normals for the rays on rough faces (the macro normal elsewhere).

        Returns
        -------
        n_fac : ndarray, shape (n, 3)
            Facet (or macro) normals; rays whose draw found no visible facet (weight 0, only for
            degenerate input) are emitted at the surface temperature and carry on with zero power.
        tangent : ndarray, shape (n, 3) or None
            Anisotropy tangent: world X projected onto the macro plane (Y where that degenerates).
        rough : ndarray, shape (n,), bool or None
        """
        media = self.job.media
        models = {k: media.rough(int(k)) for k in _values(face_med)}
        models = {k: mdl for k, mdl in models.items() if mdl is not None}
        if not models:
            return n_mac, None, None
        tangent = _tangents(n_mac)
        n_fac = n_mac.copy()
        rough = np.zeros(len(wv), bool)
        for k, mdl in models.items():
            g = np.nonzero(face_med == k)[0]
            n_fac[g] = self._draw_facets(mdl, wv, g, n_mac[g], tangent[g], self.job.media.temperature[k])
            rough[g] = True
        return n_fac, tangent, rough

    def _draw_facets(self, model, wv: _Wave, rows, n, tangent, t_surface):
        """Facet normals visible from rays ``rows`` of ``wv`` (macro normals n, facing them).

        The draw's weight multiplies the power (Jones matrix by its square root; 1 for the
        built-in models but in their rare fallback); a ray for which no facet is visible (weight
        0, degenerate input only) emits its power at ``t_surface`` and goes on with none, keeping
        the macro normal.
        """
        u = self.rng.random((2, rows.size))
        m, w = model.sample_normals(n, tangent, -wv.d[rows], u[0], u[1])
        lost = w <= 0.0
        if lost.any():
            j = rows[lost]
            self._emit(wv.sid[j], wv.m[j], t_surface if np.ndim(t_surface) == 0 else t_surface[lost])
            wv.m[j] = 0.0
        scaled = (w > 0.0) & (w != 1.0)
        if scaled.any():
            wv.m[rows[scaled]] *= np.sqrt(w[scaled])[:, None, None]
        return np.where(w[:, None] > 0.0, m, n)

    def _settle(self, child: _Wave, i, branch, pos, n_geo, n_mac, tangent, rough, face_med, prim, step, cur, other,
                leaving, rehit):
        """Send children off the surface, or back onto it.

        Returns the children that leave and, for those that do not, the arguments of their
        re-hit (`_interact` merges those of both branches into one call), or None.

        A child of a rough facet leaves with Smith's masking probability G1 about the macro
        normal of its side (0 on the wrong side); the others hit the same point again at once
        (`_interact` with ``rehit + 1``, no intersection), up to ``roughness.MAX_REHITS`` after
        which the chain's power is emitted at the surface temperature. On its way to the next
        facet a re-hitting child crosses one wavelength of its side's medium (`kernels.settle`):
        a metal-like body swallows what it transmits (as `pmmw_cli.brdf` does with a lossy
        substrate), a clear one lets it walk on. A child on the wrong side of the *geometric*
        face (a bump map's tilt) is mirrored through the face's plane, keeping its power.
        ``branch`` (per child) is +1 for reflected children (incident side), -1 for transmitted
        ones (far side); ``i`` their rows in the interaction's arrays. The masking probability
        comes from each face's model; the rest is one pass of `kernels.settle`.
        """
        n = len(child)
        u, p_leave = np.zeros(n), _NO_RANDOM
        if rough is not None:
            rk = rough[i]
            u[rk] = self.rng.random(np.count_nonzero(rk))
            if self._rough_other:  # models without compiled masking
                r = np.flatnonzero(self._rough[0][face_med[i]] == OTHER_CODE)
                fm, ir = face_med[i][r], i[r]
                n_x = branch[r][:, None] * n_mac[ir]
                p_leave = np.zeros(n)
                for k in _values(fm):
                    g = fm == k
                    p_leave[r[g]] = self._rough_models[int(k)].masking(n_x[g], tangent[ir[g]], child.d[r[g]])
        else:
            tangent = n_mac  # not read
        leave, back = _Wave.empty(n, child.stack.shape[1]), _Wave.empty(n, child.stack.shape[1])
        side = (np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n, bool), np.empty(n))
        hit = (pos, n_geo, _NO_RANDOM, cur, face_med, other, leaving, _NO_CODE)
        t_face = self._media[2][face_med]
        chain_end = (np.full(len(pos), rehit + 1 > MAX_REHITS), np.stack([t_face, t_face], axis=1))
        nl, nb = kernels.settle(child.arrays(), i, branch, u, p_leave, hit, n_mac, tangent, step, chain_end,
                                self._media, self._rough, C0 / self.job.frequency, self.acc, leave.arrays(),
                                back.arrays(), side, (np.empty(n, np.int64), np.empty(n)), True)
        if not nb:
            return leave.head(nl), None
        j, cur, other, leaving, sign = (a[:nb] for a in side)
        return leave.head(nl), (back.head(nb), pos[j], sign[:, None] * n_geo[j], sign[:, None] * n_mac[j], cur,
                                face_med[j], other, leaving, prim[j])

    # -- rough coating layers (Optics Express 2016) ----------------------------------------------------------
    def _walk_layers(self, wv: _Wave, pos, n_geo, n_mac, cur, face_med, other, leaving, prim):
        """Rays meeting a surface with rough coating layers: the Optics Express 2016 walk through them.

        The surface is a pile of interfaces at one point: interface j < L is the rough top of
        rough layer j (`RoughLayer`, with its coherent films), interface L the substrate's own
        surface (its ``coating`` films and ``roughness``). A ray on it is at an interface j, on its
        upper or lower side. Each step (`_layer_step`): draw a facet (the interface's model, or its
        macro normal), split by Fresnel / the films' multilayer about it (absorption emitted at the
        films' temperature) and mask each child, by the same kernels as any surface (each rough
        layer is a medium of the kernels' tables, `_kernel_tables`; masked children stay at
        interface j on their side after one wavelength of that side's medium), and send the others across the layer they are in,
        attenuated by exp(-alpha t / cos) and emitting at the layer's temperature, to the next
        interface. A child leaving the top interface upward or the substrate's interface downward
        is a real child of the scene: reflected or transmitted as for a smooth surface. Russian
        roulette below ``render.threshold`` ends walks unbiasedly; a walk longer than
        ``_MAX_WALK`` steps is emitted at the layer's temperature. Every step keeps or splits the
        power, so an isothermal scene still reads its temperature exactly.
        """
        media = self.job.media
        out = []
        key = ((face_med * 4096 + cur) * 4096 + other) * 2 + leaving
        for kv in np.unique(key):
            g = np.nonzero(key == kv)[0]
            k, lv = int(face_med[g[0]]), bool(leaving[g[0]])
            pile = _Pile(media, k, int(other[g[0]]) if lv else int(cur[g[0]]), self._layer_media[k])
            up = -1.0 if lv else 1.0  # side normals facing the outside
            w = wv.take(g)
            n_up, g_up, p_g, step = up * n_mac[g], up * n_geo[g], pos[g], self.isect.face_offset[prim[g]]
            tangent = _tangents(n_up)
            nr = len(w)
            lvl = np.full(nr, pile.n if lv else 0)
            above = np.full(nr, not lv)
            rehits = np.zeros(nr, np.int64)
            rows = np.arange(nr)  # index into the group's per-ray constants
            for _ in range(_MAX_WALK):
                n_in = np.where(above[:, None], n_up[rows], -n_up[rows])
                walk = []
                for j in np.unique(lvl):
                    j = int(j)
                    model = pile.roughness(j)
                    for a in (True, False):
                        sel = np.nonzero((lvl == j) & (above == a))[0]
                        if not sel.size:
                            continue
                        n_fac = n_in[sel]
                        if model is not None:
                            n_fac = self._draw_facets(model, w, sel, n_fac, tangent[rows[sel]],
                                                      pile.end_temperature(j, a))
                        exits, more = self._layer_step(w.take(sel), p_g[rows[sel]], pile, j, a, n_in[sel], n_fac,
                                                       tangent[rows[sel]], rehits[sel], rows[sel])
                        out += [self._layer_exit(child, r, exit_up, lv, k, p_g, g_up, step, pile.t_body)
                                for exit_up, child, r in exits]
                        walk += more
                walk = _merge_walk(walk)
                if walk is None:
                    break
                w, lvl, above, rehits, rows = walk
                # below the threshold the scene's termination rule; "the last object" is the
                # medium the ray is in (the body itself on its outer and inner sides)
                w.last_t = pile.end_temperatures(lvl, above)
                keep = self._survivors(w)
                if not keep.all():
                    w, lvl, above, rehits, rows = w.take(keep), lvl[keep], above[keep], rehits[keep], rows[keep]
            else:  # _MAX_WALK facet events: what is left emits where it is
                self._emit(w.sid, w.m, pile.end_temperatures(lvl, above))
        return out

    def _layer_step(self, w, pos, pile, j, a, n_in, n_fac, tangent, rehits, rows):
        """One facet event at interface j for rays on side ``a`` (True: above) at points ``pos``, by the kernels
        of every surface: `kernels.scatter` about the facets (the interface's coefficients, with
        its films; the emission of what it absorbs or a sink swallows; the branch choice), then
        `kernels.settle` without leaving the point (the interface's masking; masked children
        back at interface j on their side after one wavelength of its medium).

        Returns the real exits ``[(exit_up, wave, rows)]`` and the parts of the walk that go on,
        ``[(wave, lvl, above, rehits, rows)]``.
        """
        nr = len(w)
        cur, other = pile.index(j, a), pile.index(j, not a)
        fm = pile.index(j, False)  # the medium whose top surface interface j is
        cos1 = np.clip(-np.einsum("ij,ij->i", w.d, n_fac), 0.0, 1.0)
        hit = (np.ascontiguousarray(pos), np.ascontiguousarray(n_fac), cos1, np.full(nr, cur), np.full(nr, fm),
               np.full(nr, other), np.full(nr, not a), _NO_CODE)
        u_choose = self.rng.random(nr) if self.job.settings.strategy != "split" else _NO_RANDOM
        kids = _Wave.empty(2 * nr, w.stack.shape[1])
        src, branch = np.empty(2 * nr, np.int64), np.empty(2 * nr, np.int8)
        none = np.zeros(nr, np.int64)
        count = kernels.scatter(np.arange(nr), w.arrays(), hit, self._films, none, self._faces, self._media,
                                self._choice, u_choose, _NO_RANDOM, self._limits, self.acc, self.cut, kids.arrays(),
                                (False, src, branch))
        kids, src, branch = kids.head(count), src[:count], branch[:count]
        kids.top[:] = w.top[src]  # inside the pile the media stack stays as it was (`_layer_exit`)
        model = self._rough_models[fm]
        u, p_leave = np.zeros(count), _NO_RANDOM
        if model is not None:
            u = self.rng.random(count)
            if self._rough[0][fm] == OTHER_CODE:
                p_leave = model.masking(branch[:, None] * n_in[src], tangent[src], kids.d)
        t_end = np.array([pile.end_temperature(j, a), pile.end_temperature(j, not a)])
        chain_end = (rehits + 1 > MAX_REHITS, np.broadcast_to(t_end, (nr, 2)).copy())
        leave, back = _Wave.empty(count, w.stack.shape[1]), _Wave.empty(count, w.stack.shape[1])
        b_side = (np.empty(count, np.int64), np.empty(count, np.int64), np.empty(count, np.int64),
                  np.empty(count, bool), np.empty(count))
        l_side = (np.empty(count, np.int64), np.empty(count))
        nl, nb = kernels.settle(kids.arrays(), src, branch, u, p_leave, hit, np.ascontiguousarray(n_in),
                                np.ascontiguousarray(tangent), np.zeros(nr), chain_end, self._media, self._rough,
                                C0 / self.job.frequency, self.acc, leave.arrays(), back.arrays(), b_side, l_side,
                                False)
        exits, walk = [], []
        if nb:
            i, sign = b_side[0][:nb], b_side[4][:nb]
            walk.append((back.head(nb), np.full(nb, j), np.where(sign > 0, a, not a), rehits[i] + 1, rows[i]))
        leave = leave.head(nl)
        leave.depth -= 1  # the walk is one interaction, counted where it leaves (`_layer_exit`)
        i_all, sign_all = l_side[0][:nl], l_side[1][:nl]
        for side in (a, not a):
            sel = np.flatnonzero((sign_all > 0) == (side == a))
            if not sel.size:
                continue
            fwd, i = leave.take(sel), i_all[sel]
            if (side and j == 0) or (not side and j == pile.n):
                exits.append((side, fwd, rows[i]))
                continue
            # across the layer it is in to the neighbouring interface
            lay = pile.layers[j - 1] if side else pile.layers[j]
            cos_t = np.maximum(np.abs(np.einsum("ij,ij->i", fwd.d, n_in[i])), 1e-6)
            tau = np.exp(-lay.alpha * lay.thickness / cos_t)
            em = tau < 1.0
            if em.any():
                self._emit(fwd.sid[em], fwd.m[em] * np.sqrt(1.0 - tau[em])[:, None, None], lay.temperature)
                fwd.m *= np.sqrt(tau)[:, None, None]
            walk.append((fwd, np.full(len(fwd), j - 1 if side else j + 1), np.full(len(fwd), not side),
                         np.zeros(len(fwd), np.int64), rows[i]))
        return exits, walk

    def _layer_exit(self, child, r, exit_up, leaving, k, pos, g_up, step, t_body):
        """A child leaving the layered surface: on the outside (``exit_up``) or into the body,
        with the media stack of a reflected or transmitted child and the smooth code's offset."""
        g = np.ascontiguousarray(g_up[r] if exit_up else -g_up[r])
        child.o = pos[r]
        kernels.off_surface(child.arrays(), g, np.ascontiguousarray(step[r]))
        child.depth = child.depth + 1
        child.last_t = np.full(len(child), t_body)
        stack, top = child.stack.copy(), child.top.copy()
        crossed = exit_up == leaving  # left the body outward, or entered it from outside
        if crossed and not leaving:
            top += 1
            stack[np.arange(len(child)), top] = k
        elif crossed and leaving:
            top -= 1
        child.stack, child.top = stack, top
        return child

    def _terminate(self, wv: _Wave):
        """Depth cut-off and weight threshold (Murakowski 2014 sec. 2.2.5, 2.2.9)."""
        keep = self._survivors(wv)
        return wv.head(kernels.compact(wv.arrays(), keep)) if not keep.all() else wv

    def _survivors(self, wv: _Wave):
        """Which rays go on after the depth cut-off and the weight threshold (`kernels.survive`:
        the others' power is emitted at the last object's temperature or, by Russian roulette,
        dropped with the survivors scaled up). Returns a boolean mask."""
        n = len(wv)
        u = self.rng.random(n) if self._limits[2] else _NO_RANDOM
        keep = np.empty(n, bool)
        kernels.survivors(wv.arrays(), u, self._limits, self.acc, self.cut, keep)
        return keep


def _kernel_tables(job: TraceJob):
    """The media as the kernels take them (`kernels.scatter`, `kernels.settle`), with each rough
    coating layer (`job.RoughLayer`) a dielectric medium of its own after the scene's media.

    Returns
    -------
    media : tuple (kind, alpha, temperature, n1_real, has_coat, eps) of arrays, one entry per medium
    films : tuple (start, count, eps, thickness, temperature, k0)
        The coherent films of each medium (outermost first), flattened.
    rough : tuple (code, alpha_x, alpha_y, orientation)
        Each medium's roughness model for the masking test (`roughness.smith_g1` codes).
    models : list
        Each medium's roughness model (None: smooth).
    layer_media : list of list of int
        ``layer_media[k][j]``: the medium index of rough layer j of medium k.
    """
    m = job.media
    n = len(m.ids)
    kind, alpha, temp, eps = list(m.kind), list(m.alpha), list(m.temperature), list(m.eps)
    coats, models = list(m.coating), [m.rough(k) for k in range(n)]
    layer_media = []
    for k in range(n):
        idx = []
        for layer in m.rough_layers(k):
            idx.append(len(kind))
            kind.append(DIELECTRIC)
            alpha.append(layer.alpha)
            temp.append(layer.temperature)
            eps.append(layer.eps)
            coats.append(layer.films)
            models.append(layer.roughness)
        layer_media.append(idx)
    eps = np.array(eps, complex)
    media = (np.array(kind, np.int8), np.array(alpha, float), np.array(temp, float), np.sqrt(eps).real.copy(),
             np.array([c is not None for c in coats]), eps)
    sizes = [0 if c is None else c.eps.size for c in coats]
    present = [c for c in coats if c is not None]
    films = (np.cumsum([0] + sizes[:-1]).astype(np.int64), np.array(sizes, np.int64),
             np.concatenate([c.eps for c in present] + [np.ones(1)]).astype(complex),
             np.concatenate([c.thickness for c in present] + [np.zeros(1)]).astype(float),
             np.array([0.0 if c is None else c.temperature for c in coats], float), float(job.k0))
    # GGX and Beckmann are masked in the kernel; others (``OTHER_CODE``) by their array code
    rough = (np.array([NOT_ROUGH if r is None else getattr(r, "code", OTHER_CODE) for r in models], np.int8),
             np.array([getattr(r, "ax", 1.0) for r in models], float),
             np.array([getattr(r, "ay", 1.0) for r in models], float),
             np.array([getattr(r, "orientation", 0.0) for r in models], float))
    return media, films, rough, models, layer_media


class _Pile:
    """The interfaces of one surface with rough coating layers, seen by one group of rays.

    Interface j < n is the rough top of ``layers[j]`` (with that layer's coherent films);
    interface n is the body's own surface (its ``coating`` films and ``roughness``). Above
    interface 0 is the outside medium, below interface n the body (index k).
    """

    def __init__(self, media, k, outside, layer_media):
        self.layers = media.rough_layers(k)
        # medium indices in the kernels' tables (`_kernel_tables`): above interface 0 the outside,
        # then the layers, below interface n the body
        self._index = [int(outside)] + list(layer_media) + [int(k)]
        self.n = len(self.layers)
        self.t_body = float(media.temperature[k])
        self._media, self._k = media, k
        # where a walk that ends early emits: the layer it is in, the body on either outer side
        self._end_above = np.array([self.t_body] + [x.temperature for x in self.layers])
        self._end_below = np.array([x.temperature for x in self.layers] + [self.t_body])

    def index(self, j, above):
        """Medium index (kernels' tables) on one side of interface j."""
        return self._index[j] if above else self._index[j + 1]

    def roughness(self, j):
        return self.layers[j].roughness if j < self.n else self._media.rough(self._k)

    def end_temperature(self, j, above):
        return float(self._end_above[j] if above else self._end_below[j])

    def end_temperatures(self, lvl, above):
        return np.where(above, self._end_above[lvl], self._end_below[lvl])


def _merge_walk(parts):
    """Concatenate ``(wave, lvl, above, rehits, rows)`` tuples (None when empty)."""
    parts = [p for p in parts if len(p[0])]
    if not parts:
        return None
    return (_Wave.concat([p[0] for p in parts]),) + tuple(np.concatenate([p[i] for p in parts]) for i in range(1, 5))


def _values(a):
    """The distinct values of a small integer array (`numpy.unique`), without its sort for the
    usual case of one value (a wave on one material)."""
    if a.size and a.min() == a.max():
        return a[:1]
    return np.unique(a)


def _tangents(n):
    """Unit tangents: world X projected onto the plane normal to n (world Y where n ~ X),
    `kernels.tangents`; shape (n, 3)."""
    n = np.ascontiguousarray(n, dtype=np.float64)
    out = np.empty_like(n)
    kernels.tangents(n, out)
    return out


