"""The bounce loop: a wavefront of backward rays per bounce, vectorized over rays.

Follows the flowchart of Murakowski 2014 sec. 2.2.5 (fig. 2.5). Every ray carries a Jones matrix M
(convention in `pmmw.physics.jones`). At each bounce, for all rays at once:

1. intersect (Embree); rays that miss see the sky;
2. the segment just travelled attenuates M by exp(-alpha d / 2) and emits at the medium's
   temperature with weight 1 - exp(-alpha d) (eq. 2.37, 2.38);
3. media are tracked with closed orientable meshes and a per-ray medium stack (sec. 2.2.9):
   crossing a face outward-to-inward enters the face's material; crossing inward-to-outward
   leaves it if it is the current medium, or silently drops it from the stack if it is a medium
   further down (slightly interpenetrating touching objects, as Murakowski 2014 prescribes);
4. at an interaction (`pmmw.surface.Surfaces.interact`), the surface's coating stack (or bare interface) gives r, t, R, T, A; the
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

from pmmw import rng
from pmmw.rng import Branch, Purpose
from pmmw.scene.camera import REPLICATES, pixel_samples
from pmmw.surface import Surfaces, Wave
from pmmw.surface.records import Choice, Faces, Hit, HitCode, Limits
from pmmw.trace import kernels
from pmmw.trace.job import TraceJob

_NEIGHBOURS = np.ones((3, 3), bool)  # a pixel and its 8 neighbours (adaptive sampling)
_NO_RANDOM = np.zeros(0)  # the kernels' "no uniforms drawn"
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


COLUMN_CELLS = 16  # an imager above this many atmosphere cells over the scene gets a `camera_column`


def camera_column(job: TraceJob):
    """The layered atmosphere's column between the imager and the top of the scene, tabulated for
    the imager's first segments (`AtmosphereModel.column`, `AtmosphereModel.walk_below`), or None.

    Every ray of a pinhole imager starts at its height, and each that hits a face crosses the
    column down to the scene's top in full, cell by cell (37 cells for SAR's 3 km, 18 % of its
    trace). Tabulated against the slope (within 1e-9 K of the cell walk), only the part below the
    scene's top is walked. Not for a thin lens (its rays start across the aperture), nor where
    the column holds fewer than `COLUMN_CELLS` cells (the table's array steps then cost more than
    the walk they save)."""
    atm, cam = job.atmosphere, job.camera
    if atm is None or not job.vertices.size or (cam.focus_distance is not None and cam.aperture_radius > 0.0):
        return None
    z_top, z_bottom = min(float(cam.position[2]), atm.top), max(float(job.vertices[:, 2].max()), 0.0)
    if np.searchsorted(atm.edges, z_top) - np.searchsorted(atm.edges, z_bottom) < COLUMN_CELLS:
        return None
    # the slopes of the imager's rays that go down (from a 65 x 65 grid over the image; a ray
    # outside the table's range walks in full)
    u, v = np.meshgrid(np.linspace(0.0, cam.width, 65), np.linspace(0.0, cam.height, 65))
    _, d, _, _ = cam.rays(u.ravel(), v.ravel(), np.zeros(u.size, np.int64), 0)
    down = -d[:, 2][d[:, 2] < 0.0]
    if not down.size:
        return None
    s_lo, s_hi = 1.0 / down.max(), min(1.0 / down.min(), 1e3)
    margin = 0.01 * (s_hi - s_lo)
    return atm.column(z_top, z_bottom, s_lo - margin, s_hi + margin)


def observe_from_imager(job: TraceJob):
    """The layered sky seen from the imager's own height for its rays that miss every face
    (`AtmosphereSky.observe`): a pinhole imager's rays all start there (a thin lens's start
    across its aperture and read the tables of their levels)."""
    observe, cam = getattr(job.sky, "observe", None), job.camera
    if observe is not None and not (cam.focus_distance is not None and cam.aperture_radius > 0.0):
        observe(float(cam.position[2]))


def prime(job: TraceJob):
    """Build what rendering would otherwise build lazily in every worker process: the layered
    sky's tables at the heights of the scene and the imager (`AtmosphereSky.prepare`,
    `observe_from_imager`). Called once before the workers fork."""
    prepare = getattr(job.sky, "prepare", None)
    if prepare is not None:
        prepare(*_scene_heights(job))
    observe_from_imager(job)


class Integrator:
    """Renders tiles of one `TraceJob` with one intersector (built once per worker)."""

    def __init__(self, job: TraceJob, intersector, compiled: bool | None = None):
        self.job = job
        self.isect = intersector
        st = job.settings
        bounds = brightness_bounds(job, atmosphere_source_range(job))
        # what a path ended on a guessed temperature could have brought instead (truncation bound)
        self.t_bounds = bounds if bounds is not None else (-np.inf, np.inf)
        limits = Limits(
            int(st.max_depth),
            float(st.threshold),
            st.termination == "roulette",
            float(self.t_bounds[0]),
            float(self.t_bounds[1]),
        )
        faces = Faces(
            np.ascontiguousarray(job.face_medium, np.int32),
            np.ascontiguousarray(job.face_normals, float),
            np.ascontiguousarray(intersector.face_offset, float),
        )
        # the surfaces' interactions (`pmmw.surface`); ``compiled=False`` sends smooth scenes
        # through the rough-surface steps (the reference of tests/trace/test_compiled_tracer.py)
        self.roulette, self.threshold = limits.roulette, limits.threshold
        self.surfaces = Surfaces(
            job.media,
            job.frequency,
            faces,
            limits,
            Choice(kernels.STRATEGIES[st.strategy], int(st.split_depth)),
            compiled,
        )
        self._faces, self._media = faces, self.surfaces.media_table
        self.compiled = self.surfaces.compiled
        self.atm_skip_length = atmosphere_skip_length(job)
        self.column = camera_column(job)
        observe_from_imager(job)  # (built already where `prime` ran before the workers forked)

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
                # the sums of the samples' values shifted by the first chunk's mean (`kernels.tally`)
                kernels.tally(
                    active,
                    vals,
                    cut,
                    first_t,
                    first_m,
                    done,
                    REPLICATES,
                    ref,
                    s1,
                    s2,
                    r1,
                    count,
                    trunc,
                    depth,
                    material,
                )
                done += nb
            if not adaptive:
                break
            err = np.empty((active.size, 4))
            kernels.stderr(s1[active], s2[active], count[active], err)
            need = np.zeros(npx, bool)
            need[active[np.max(err[:, :2], axis=1) > st.target_error * st.error_footprint]] = True
            # a pixel that a small object covers in part may miss it with every one of its first
            # samples (zero variance): its neighbours that did see the edge keep it sampling
            from scipy.ndimage import binary_dilation  # adaptive sampling only: not imported before a first ray

            grown = binary_dilation(need.reshape(h, w), structure=_NEIGHBOURS).ravel()
            active = active[grown[active]]
            batch = done  # double the samples of the pixels that still need them
        # every pixel took samples 0 .. count-1: replicate r holds the sample numbers = r mod 2
        mean, stderr, diff = np.empty((npx, 4)), np.empty((npx, 4)), np.empty((npx, 4))
        kernels.tile_means(ref, s1, s2, r1, count, mean, stderr, diff)
        return TileResult(
            index,
            (x0, y0, x1, y1),
            mean.reshape(h, w, 4),
            stderr.reshape(h, w, 4),
            depth.reshape(h, w),
            material.reshape(h, w),
            self.rays,
            count.reshape(h, w).astype(np.int32),
            self.t_isect,
            (trunc / count[:, None]).reshape(h, w, 2),
            diff.reshape(h, w, 4),
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
        self.surfaces.start(self.acc, self.cut)
        sample_no = np.tile(np.arange(start, start + nb, dtype=np.int64), pixels.size)
        ident = pix * st.spp + sample_no
        # the pixel's polarization basis (s, p): the imager's x projected perpendicular to the
        # ray and y completing it (jones.py), so M starts as the identity (eq. 2.11b)
        origins, d, s, p = cam.rays(u, v, ident, st.seed)
        m = np.zeros((n, 2, 2), complex)
        m[:, 0, 0] = m[:, 1, 1] = 1.0
        wave = Wave(
            o=origins,
            d=d,
            s=s,
            p=p,
            m=m,
            sid=np.arange(n),
            depth=np.zeros(n, np.int32),
            stack=np.zeros((n, st.stack_size), np.int16),
            top=np.zeros(n, np.int32),
            last_t=np.full(n, np.nan),
            key=rng.ray_keys(st.seed, ident),  # each ray's random numbers (`pmmw.rng`)
        )
        first = True
        while wave is not None and len(wave) > 0:
            wave = self._bounce(wave, first)
            first = False
        return self.acc, self.first_t, self.first_m, self.cut

    # -- one bounce -----------------------------------------------------------------------
    def _intersect(self, wave: Wave, first: bool):
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

    def _bounce(self, wave: Wave, first: bool):
        """One bounce of a wave: intersect; the sky for the rays that miss; for the others the
        segment just travelled and the face they hit (`kernels.arrive`); the interactions with the
        faces (`Surfaces.interact`). Returns the next wave (None: empty)."""
        job = self.job
        n = len(wave)
        t, prim, miss = self._intersect(wave, first)
        if miss.all():
            return None
        atm = (_NO_RANDOM, _NO_RANDOM)
        if job.atmosphere is not None:
            # the layered atmosphere along ambient segments (shorter ones: below the error budget)
            z0, z1, length = np.empty(n), np.empty(n), np.empty(n)
            if kernels.ambient_segments(
                wave.arrays(), t, prim, self.atm_skip_length, job.atmosphere.top, z0, z1, length
            ):
                atm = (np.empty(n), np.empty(n))
                if first and self.column is not None:  # the imager's rays: the column above the scene tabulated
                    job.atmosphere.walk_below(self.column, z0, z1, length, *atm)
                else:
                    job.atmosphere.walk(z0, z1, length, *atm)
        hit = Hit.empty(n)
        arrays = wave.arrays()
        # Russian roulette where a segment's absorption left a ray below the threshold: it is
        # played before the interaction, which the ended rays (about half of those that would
        # interact, in the shipped scenes) then skip
        u = rng.uniforms(wave.key, wave.depth, Purpose.ARRIVAL_ROULETTE) if self.roulette else _NO_RANDOM
        kernels.arrive(arrays, t, prim, atm, self._faces, self._media, self.acc, hit, u, self.threshold)
        rows = np.flatnonzero(hit.code == HitCode.INTERACTS)
        passing = np.flatnonzero(hit.code == HitCode.PASSED)
        out = []
        if passing.size:  # a new key: the next face's arrival draws its own numbers
            out = [wave.take(passing)]
            out[0].key = rng.child_keys(out[0].key, Branch.PASSED)
        if not rows.size:
            return Wave.concat(out)
        return Wave.concat(out + self.surfaces.interact(wave, hit, prim, rows))

    def _sky(self, wave: Wave, rows):
        """The sky's brightness seen by the rays ``rows`` of a wave (which missed every face):
        its model's (Tv, Th), then the rays' Jones matrices in its (h, v) basis (`kernels.sky_emit`)."""
        sky = self.job.sky
        ta, tb = sky.brightness(wave.d[rows], heights=wave.o[rows, 2])
        n = rows.size
        # always C-contiguous and writable: one compiled specialization whether or not they were broadcast
        ta = np.require(np.broadcast_to(np.asarray(ta, float), (n,)), requirements="CW")
        tb = ta if sky.unpolarized else np.require(np.broadcast_to(np.asarray(tb, float), (n,)), requirements="CW")
        kernels.sky_emit(rows, wave.arrays(), ta, tb, not sky.unpolarized, self.acc)
