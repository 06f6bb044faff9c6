"""Render the tiles of a job on worker processes.

Each worker builds the Embree scene once and then renders whole tiles, one at a time, that the
parent sends it over a pipe, two ahead (the next tile waits in the pipe while it renders, so a
worker does not wait for the parent between tiles). A forked worker writes a finished tile's
arrays into memory it shares with the parent (`_Slots`) and sends the rest through the pipe.
Each ray's random numbers come from its own key (`pmmw.rng`) and a tile is rendered whole by one
process, so an image is identical whatever ``--workers`` is. It is identical whatever
``render.tile`` is only without adaptive sampling (``render.target_error``), whose neighbour rule
looks at the pixels of a tile, so that its sample counts depend on the tiles by design.

Finished tiles are saved atomically to ``tile_dir`` as they arrive; with ``resume`` the tiles
already there are checked and loaded instead of re-rendered, so an interrupted render loses
nothing.

The parent waits on every worker's pipe and process sentinel together, so a worker that dies (the
kernel's OOM killer sends SIGKILL) is seen at once, with the tile it was rendering: that tile is
rendered once more by another process (the tile waiting in its pipe goes back to the queue too), and if it kills that one too the render stops with an
`EnvironmentProblem` naming it. (``multiprocessing.Pool`` never notices a dead worker and waits
forever; ``concurrent.futures`` does notice but cannot say which task killed it.) Workers ignore
SIGINT; the parent kills and reaps them on every way out (`pmmw.interrupt`).
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import mmap
import multiprocessing as mp
import os
import pickle
import signal
import sys
import threading
import time
import traceback
import types
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import wait
from pathlib import Path

import numpy as np

from pmmw import interrupt, jit, procfs, timings
from pmmw.errors import EnvironmentProblem, exception_text, warn
from pmmw.io.atomic import save_npz_atomic
from pmmw.trace import kernels
from pmmw.trace.compile import compile_kernels
from pmmw.trace.integrator import Integrator, TileResult, prime
from pmmw.trace.intersect import embree_used, make_intersector
from pmmw.trace.job import TraceJob

_WORKER: Integrator | None = None

#: Renders more of a tile whose worker process died, each in another process.
_RETRIES = 1
# [s] a worker holding tiles whose CPU time has not moved for this long is hung, not slow (a tile
# always computes): it is killed and its tile rendered again (`_stalled`). Seen once: a worker
# forked while the parent's Embree (TBB) thread pool held a lock waited forever in rtcCommitScene.
_STALL_S = 60.0
_WATCH_S = 5.0  # [s] the longest the workers' CPU time (Linux: /proc; no watch elsewhere) goes unread

#: What a saved tile must hold (`TileResult`): per array, its channels after (h, w) (None: none),
#: dtype kind, and the test every value passes. Depth is inf where every sample saw the sky.
_TILE_ARRAYS = {
    "mean": (4, "f", np.isfinite),
    "stderr": (4, "f", lambda a: np.isfinite(a) & (a >= 0.0)),
    "depth": (None, "f", lambda a: a >= 0.0),
    "material": (None, "f", lambda a: np.isfinite(a) & (a >= -1.0)),
    "samples": (None, "i", lambda a: a >= 1),
    "truncated": (2, "f", np.isfinite),
    "replicate_diff": (4, "f", np.isfinite),
}


#: glibc's mallopt parameters (malloc.h) and the values a rendering process sets
#: (`_reuse_freed_memory`): no arrays in their own mappings below 1 GiB, and up to 1 GiB of freed
#: memory kept at the top of the heap, with 256 MiB asked of the system at a time.
_MALLOPT = ((-3, 1 << 30), (-1, 1 << 30), (-2, 1 << 28))  # M_MMAP_THRESHOLD, M_TRIM_THRESHOLD, M_TOP_PAD


def _reuse_freed_memory():
    """Let glibc's malloc keep the memory of freed arrays for the next ones, in this process.

    Every bounce makes its wave's arrays afresh (megabytes each). By default glibc hands back to
    the system what is freed at the top of the heap beyond twice the largest array freed so far,
    so the next wave's arrays are fresh pages that the kernel faults in and zeroes again: 15 % of
    the landing scene's time on the workers (`docs/benchmarks.md`). Kept, they are reused. The
    peak resident memory does not change (landing, rough cinderblocks, CWD indoors, SAR: within
    1 %); a worker keeps it until it exits. Nothing happens where the C library has no
    ``mallopt`` (not glibc).
    """
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (AttributeError, OSError):  # pragma: no cover - not glibc
        return
    for param, value in _MALLOPT:
        mallopt(ctypes.c_int(param), ctypes.c_int(value))


#: `timings`' phase of a worker's set-up before its first tile (its Embree scene: the BVH).
WORKER_SETUP = "worker's scene (Embree)"
#: `timings` phase of the tiles' tracing alone (the workers' start-up in, the kernels' loading out)
TILES = "tiles traced"


def _init_worker(job: TraceJob, kind: str) -> float:
    """Make this process's `Integrator` (its Embree scene); returns the seconds it took."""
    global _WORKER
    t0 = time.perf_counter()
    _reuse_freed_memory()
    _WORKER = Integrator(job, make_intersector(job.vertices, job.faces, kind=kind))
    return time.perf_counter() - t0


def _render(tile) -> TileResult:
    return _WORKER.render_tile(tile)


#: A tile's per-pixel arrays (`TileResult`) and their channels, in the order of a `_Slots` row.
_PLANES = (
    ("mean", 4),
    ("stderr", 4),
    ("depth", 1),
    ("material", 1),
    ("samples", 1),
    ("truncated", 2),
    ("replicate_diff", 4),
)
_WIDTH = sum(c for _, c in _PLANES)


class _Slots:
    """Room in memory shared with one forked worker for the per-pixel arrays of its tiles in flight.

    The worker writes a finished tile's arrays into the slot the parent named with the tile and
    sends only the small rest of its `TileResult` through the pipe; the parent copies them out
    before it sends the tile that will reuse the slot. (Through the pipe, 0.5 MB per landing tile
    cost each worker about 7 % of its time, waiting in 64 kB pieces for the parent to read.)
    Integer sample counts are kept as float64: exact below 2**53.
    """

    def __init__(self, count: int, pixels: int):
        self._buffer = mmap.mmap(-1, max(1, count * pixels * _WIDTH * 8))  # anonymous: shared with children
        self.rows = np.frombuffer(self._buffer, np.float64, count * pixels * _WIDTH).reshape(count, pixels, _WIDTH)

    def put(self, k: int, r: TileResult) -> TileResult:
        """Write ``r``'s arrays to slot ``k``; ``r`` without them (what goes through the pipe)."""
        c = 0
        for name, channels in _PLANES:
            a = getattr(r, name)
            self.rows[k, : a.shape[0] * a.shape[1], c : c + channels] = a.reshape(-1, channels)
            setattr(r, name, None)
            c += channels
        return r

    def take(self, k: int, r: TileResult) -> TileResult:
        """``r`` with its arrays copied back from slot ``k``."""
        x0, y0, x1, y1 = r.box
        h, w = y1 - y0, x1 - x0
        c = 0
        for name, channels in _PLANES:
            a = self.rows[k, : h * w, c : c + channels].reshape((h, w) if channels == 1 else (h, w, channels))
            setattr(r, name, a.astype(np.int32) if name == "samples" else a.copy())
            c += channels
        return r


def _render_to(order, slots: _Slots | None) -> TileResult:
    """Render the tile of an order ``(tile, slot)``; its arrays go to ``slots`` when there are."""
    tile, k = order
    r = _render(tile)
    return r if slots is None else slots.put(k, r)


_COST_TRIANGLES = 20_000  # triangles `_by_cost` projects at the most


def _by_cost(job: TraceJob, tiles: list) -> list:
    """``tiles`` in the order the workers take them: those with the most of the scene's triangles
    in view first, empty sky last (ties in index order).

    The cost of a tile varies twentyfold in the shipped scenes (sand against a lossy block that
    splits every ray), and a costly tile taken last keeps one worker busy while the others wait
    (the cinderblocks: one idle for the last 40-60 ms of 0.47 s in index order). The estimate:
    each triangle's screen bounding box from the pinhole (the part in front of the imager: a
    triangle reaching behind it is cut at a plane just in front), counted per tile on the grid of
    ``render.tile`` (a summed-area table). It orders the work only: each ray's random numbers
    depend on the ray alone (`pmmw.rng`).
    """
    cam, ts = job.camera, job.settings.tile
    nx, ny = -(-cam.width // ts), -(-cam.height // ts)
    # every triangle up to _COST_TRIANGLES, an even sample of them beyond (a few ms either way)
    faces = job.faces[:: -(-len(job.faces) // _COST_TRIANGLES)] if len(job.faces) else job.faces
    tri = job.vertices[faces] - cam.position  # (n, 3 corners, 3), from the imager
    z = tri @ cam.k
    near = 1e-9 * max(float(np.abs(z).max(initial=0.0)), 1.0)
    # the corners in front, and where each edge crosses the near plane
    points, valid = [tri], [z > near]
    for i, j in ((0, 1), (1, 2), (2, 0)):
        za, zb = z[:, i], z[:, j]
        cross = (za > near) != (zb > near)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(cross, (near - za) / (zb - za), 0.0)
        points.append((tri[:, i] + t[:, None] * (tri[:, j] - tri[:, i]))[:, None])
        valid.append(cross[:, None])
    points, valid = np.concatenate(points, axis=1), np.concatenate(valid, axis=1)
    u, v, _ = cam.image_coordinates(points.reshape(-1, 3) + cam.position)
    u, v = u.reshape(valid.shape), v.reshape(valid.shape)
    lo_u, hi_u = np.where(valid, u, np.inf).min(axis=1), np.where(valid, u, -np.inf).max(axis=1)
    lo_v, hi_v = np.where(valid, v, np.inf).min(axis=1), np.where(valid, v, -np.inf).max(axis=1)
    seen = (hi_u >= 0.0) & (lo_u < cam.width) & (hi_v >= 0.0) & (lo_v < cam.height)
    tx0, tx1 = (np.clip(a[seen], 0, cam.width - 1).astype(np.int64) // ts for a in (lo_u, hi_u))
    ty0, ty1 = (np.clip(a[seen], 0, cam.height - 1).astype(np.int64) // ts for a in (lo_v, hi_v))
    count = np.zeros((ny + 1, nx + 1), np.int64)
    for dy, dx, sign in ((ty0, tx0, 1), (ty0, tx1 + 1, -1), (ty1 + 1, tx0, -1), (ty1 + 1, tx1 + 1, 1)):
        np.add.at(count, (dy, dx), sign)
    count = count.cumsum(axis=0).cumsum(axis=1)
    key = [-count[y0 // ts, x0 // ts] for _, x0, y0, _, _ in tiles]
    return [tiles[i] for i in np.argsort(key, kind="stable")]


def _tile_path(tile_dir: Path, index: int) -> Path:
    return tile_dir / f"tile_{index:06d}.npz"


def _save_tile(tile_dir: Path, r: TileResult):
    # not fsync'ed (0.4 s per 256 tiles here): `_load_tile` checks every tile it resumes from, so
    # one that a crash of the machine left empty or torn is rendered again
    save_npz_atomic(
        _tile_path(tile_dir, r.index),
        durable=False,
        index=r.index,
        box=np.array(r.box),
        mean=r.mean,
        stderr=r.stderr,
        depth=r.depth,
        material=r.material,
        rays=r.rays,
        samples=r.samples,
        t_isect=r.t_isect,
        truncated=r.truncated,
        replicate_diff=r.replicate_diff,
    )


def _load_tile(path: Path, tile) -> TileResult | None:
    """The result saved at ``path`` for ``tile`` (index, x0, y0, x1, y1), or None (render it again)
    when the file is missing, damaged, another tile's, or holds a wrong shape, dtype or value."""
    index, x0, y0, x1, y1 = tile
    try:
        with np.load(path) as z:
            arrays = {k: z[k] for k in _TILE_ARRAYS}
            r = TileResult(
                int(z["index"]),
                tuple(int(v) for v in z["box"]),
                arrays["mean"],
                arrays["stderr"],
                arrays["depth"],
                arrays["material"],
                int(z["rays"]),
                arrays["samples"],
                float(z["t_isect"]),
                arrays["truncated"],
                arrays["replicate_diff"],
            )
    except Exception:  # unreadable, a key missing, a scalar that is not one
        return None
    if r.index != index or r.box != (x0, y0, x1, y1) or r.rays < 0 or not r.t_isect >= 0.0:
        return None
    for key, (channels, kind, valid) in _TILE_ARRAYS.items():
        a = arrays[key]
        shape = (y1 - y0, x1 - x0) + (() if channels is None else (channels,))
        if a.shape != shape or a.dtype.kind != kind or not np.all(valid(a)):
            return None
    return r


def default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def render_tiles(
    job: TraceJob,
    workers: int | None = None,
    tile_dir: Path | None = None,
    resume: bool = False,
    intersector: str = "embree",
    progress=None,
    tiles=None,
    counts: dict | None = None,
    client=None,
    notify=None,
) -> list[TileResult]:
    """Render ``tiles`` (default: all of the job's tiles) and return their results.

    Parameters
    ----------
    job : TraceJob
    workers : int, optional
        Processes; default all cores, at most one per tile to render. 1 (or one tile to render)
        renders in this process, which then has built an Embree scene: its later renders spawn
        their workers (`_context`).
    tile_dir : Path, optional
        Where finished tiles are saved (and, with ``resume``, loaded from).
    progress : callable(done, total, rays, elapsed, left), optional
        Told after each tile: tiles done (reused ones included) and in all, rays traced, seconds
        since the tiles were sent, and the seconds left (`_Pace`; None while unknown).
    counts : dict, optional
        Filled with ``reused`` (tiles loaded from ``tile_dir``) and ``rendered``.
    client : dask.distributed.Client, optional
        Render the tiles as tasks on its cluster's workers instead (`_render_on_dask`).
    notify : callable(str), optional
        Told when the kernels are compiled here first (`prepare_kernels`), so that a first run
        does not look hung; the time-left estimate of ``progress`` starts after that.

    Raises
    ------
    EnvironmentProblem
        A tile's worker process died on every try (`_RETRIES`), or workers keep dying before
        they render anything, or the Dask scheduler of ``client`` went away. The tiles finished
        by then are saved.
    """
    tiles = job.tiles() if tiles is None else tiles
    results: dict[int, TileResult] = {}
    if tile_dir is not None:
        tile_dir.mkdir(parents=True, exist_ok=True)
        if resume:
            for t in tiles:
                r = _load_tile(_tile_path(tile_dir, t[0]), t)
                if r is not None:
                    results[t[0]] = r
    todo = [t for t in tiles if t[0] not in results]
    if counts is not None:
        counts.update(reused=len(tiles) - len(todo), rendered=len(todo))
    workers = default_workers() if workers is None else max(1, int(workers))
    workers = min(workers, max(1, len(todo)))
    if todo and client is None:
        with timings.phase("kernels"):
            prepare_kernels(job, notify)
        timings.mark("kernels loaded")
    start = time.perf_counter()
    rays = sum(r.rays for r in results.values())
    pace = _Pace(len(todo), workers)

    def _collect(r: TileResult, seconds: float | None = None):
        nonlocal rays
        results[r.index] = r
        rays += r.rays
        if tile_dir is not None:
            _save_tile(tile_dir, r)
        elapsed = time.perf_counter() - start
        pace.add(seconds, elapsed)
        if progress is not None:
            progress(len(results), len(tiles), rays, elapsed, pace.left())

    if todo and client is not None:
        try:
            _render_on_dask(client, job, intersector, todo, _collect)
        except _SchedulerGone as e:
            kept = "; rerun with --resume to keep them" if tile_dir is not None else ""
            raise EnvironmentProblem(
                f"the Dask scheduler at {e} went away during the render ({len(results)} of "
                f"{len(tiles)} tiles done{kept})"
            ) from None
    elif todo and workers == 1:
        timings.mark("first tile sent")
        timings.add(WORKER_SETUP, _init_worker(job, intersector))
        timings.mark("first ray")
        for t in todo:
            t0 = time.perf_counter()
            r = _render(t)
            _collect(r, time.perf_counter() - t0)
    elif todo:
        _render_on_workers(job, intersector, todo, workers, _collect)
    if todo:  # the tiles alone: from their sending (kernels loaded) to the last one back
        timings.add(TILES, time.perf_counter() - start)
    return [results[t[0]] for t in tiles]


def kernels_to_compile(job: TraceJob) -> bool:
    """Whether `prepare_kernels` compiles rather than loads: nothing cached yet, or a rough scene
    after smooth ones only (a smooth scene leaves out the rough kernels, `settle` among them)."""
    if not (jit.is_cached("trace/kernels.py") and jit.is_cached("surface/kernels.py")):
        return True
    return job.media.any_rough and not jit.is_cached("surface/kernels.py", "settle")


def prepare_kernels(job: TraceJob, notify=None) -> float:
    """Compile (once after an install or an update) or load the tracer's kernels in this process,
    telling ``notify`` (a callable taking one line) before and after when they are not cached yet;
    then one pixel of the job is traced here, so that the camera's, sky's and atmosphere's compiled
    code is ready too and the first tile's time is its own (with the NumPy intersector: Embree
    here would make the workers spawned rather than forked, `_context`). Returns the seconds it
    took."""
    cold = kernels_to_compile(job)
    if cold and notify is not None:
        notify(
            "compiling the tracer's kernels: once after an install or an update of pmmw, "
            "about 20 s on 2 cores (more with rough surfaces) ..."
        )
    t0 = time.perf_counter()
    if cold:  # in two processes at once (`compile.compile_kernels`)
        compile_kernels(job.settings.stack_size, rough=job.media.any_rough)
    else:
        kernels.warm(job.settings.stack_size, rough=job.media.any_rough)
    if cold:  # the camera's, sky's and atmosphere's compiled code too, with this job's types: one pixel
        idx, x0, y0 = job.tiles()[0][:3]
        # at 1 spp: the NumPy intersector is O(faces) per ray, and one sample compiles as many
        one = dataclasses.replace(job, settings=dataclasses.replace(job.settings, spp=1))
        Integrator(one, make_intersector(job.vertices, job.faces, kind="numpy")).render_tile(
            (idx, x0, y0, x0 + 1, y0 + 1)
        )
    took = time.perf_counter() - t0
    if cold and notify is not None:
        notify(f"kernels compiled in {took:.0f} s; rendering")
    return took


class _Pace:
    """The time left of a render, from the tiles' own durations: the mean seconds a worker took
    per tile so far, times the tiles left, over the workers rendering them. Unlike the elapsed
    time per tile done, it leaves out the workers' start-up (their Embree scenes, the sky tables),
    which made the estimate at the first tile several times too long. Tiles go out costliest
    first (`_by_cost`), so the early estimate errs long. Without durations (tiles rendered on a
    Dask cluster): the elapsed time per tile done since the first one came back."""

    def __init__(self, todo: int, workers: int) -> None:
        self.todo, self.workers = todo, max(1, workers)
        self.done = 0
        self.busy = 0.0  # summed seconds of the tiles with a duration
        self.timed = 0
        self.first: float | None = None  # elapsed when the first tile came back [s]
        self.last = 0.0  # elapsed when the latest came back [s]

    def add(self, seconds: float | None, elapsed: float) -> None:
        """One tile done, ``seconds`` a worker spent on it (None: unknown), at ``elapsed``."""
        self.done += 1
        if self.first is None:
            self.first = elapsed
        self.last = elapsed
        if seconds is not None and seconds >= 0.0:
            self.busy += seconds
            self.timed += 1

    def left(self) -> float | None:
        """Seconds left [s], or None when nothing tells yet (one tile back, no duration)."""
        remaining = self.todo - self.done
        if remaining <= 0:
            return 0.0
        if self.timed:
            return self.busy / self.timed * remaining / min(self.workers, remaining)
        if self.done >= 2 and self.first is not None:
            return (self.last - self.first) / (self.done - 1) * remaining
        return None


class _Worker:
    """A worker process, the parent's end of its pipe, the tiles sent to it and not yet returned
    (the first is the one it renders) with the slot each one's arrays will come back in, and
    those slots (`_Slots`; None: the arrays come through the pipe)."""

    def __init__(self, process, conn, slots):
        self.process = process
        self.conn = conn
        self.slots = slots
        self.tiles = deque()
        self.slot_of = deque()
        self.free_at = time.perf_counter()  # when it last said it was ready or sent a tile [s]
        self.cpu: tuple[float, float] | None = None  # (when, its CPU seconds then): `_stalled`
        self.hung = False  # stopped by `_stalled`: its death is a hang, not a lack of memory

    def free_slot(self) -> int:
        return min(set(range(_IN_FLIGHT)) - set(self.slot_of))


def _cpu_seconds(pid: int) -> float | None:
    """CPU time [s] a process has used (Linux: /proc/PID/stat utime + stime), None where unknown."""
    fields = procfs.stat_fields(pid)
    try:
        return (int(fields[procfs.UTIME]) + int(fields[procfs.STIME])) / os.sysconf("SC_CLK_TCK") if fields else None
    except (ValueError, IndexError):
        return None


def _stalled(w: _Worker, now: float) -> bool:
    """Whether worker ``w``, holding tiles, has used no CPU for `_STALL_S` (hung); samples its CPU
    time. A worker without tiles waits for them and is never stalled."""
    if not w.tiles:
        w.cpu = None
        return False
    cpu = _cpu_seconds(w.process.pid)
    if cpu is None:
        return False
    if w.cpu is None or cpu != w.cpu[1]:
        w.cpu = (now, cpu)
        return False
    return now - w.cpu[0] >= _STALL_S


class _WorkerTraceback(Exception):
    """The traceback of an exception raised in a worker: the cause of the one re-raised here."""


def _attempt(fn, *args):
    """``("ok", fn(*args))``, or ``("error", (exception, traceback))`` for the parent to raise."""
    try:
        return "ok", fn(*args)
    except Exception as e:
        text = traceback.format_exc()
        try:
            pickle.loads(pickle.dumps(e))
        except Exception:
            e = RuntimeError(f"{type(e).__name__}: {e}")
        return "error", (e, text)


def _work(conn, job: TraceJob, kind: str, inherited, slots: _Slots | None = None):
    """A worker's life: build the scene (then say so), render each tile the parent sends.

    ``inherited`` are the parent's ends of pipes that the fork copied here; closed, so that a
    worker sees EOF (and returns) once its parent is gone. ``slots``: where the tiles' arrays go
    (None: through the pipe).
    """
    interrupt.as_worker()
    for c in inherited:
        c.close()
    try:
        conn.send(_attempt(_init_worker, job, kind))
        while True:
            conn.send(_attempt(_render_to, conn.recv(), slots))
    except (EOFError, OSError):  # the parent is done with us, or gone
        return


def _death(exitcode: int, remedy: str) -> str:
    """How a worker process ended, from its exit code (-N: signal N), and what to try."""
    if exitcode >= 0:
        return f"exited with status {exitcode}"
    try:
        name = f"signal {-exitcode} ({signal.Signals(-exitcode).name})"
    except ValueError:
        name = f"signal {-exitcode}"
    if -exitcode == signal.SIGKILL:  # what the kernel's OOM killer sends
        return f"was killed by {name}, probably for lack of memory ({remedy})"
    return f"died of {name}"


_KEPT = "finished tiles are kept: run again with --resume"
_IN_FLIGHT = 2  # tiles sent to a worker ahead of its results (`_render_on_workers`)


def _context():
    """How the workers start: forked on Linux (they inherit the loaded kernels and the sky tables,
    and start at once), spawned elsewhere, and spawned on Linux too once this process has built an
    Embree scene (`intersect.embree_used`: a fork then copies Embree's thread pool without its
    threads, and a worker's own scene build can wait for good on a lock they held). The command
    line's renders build none here (`prepare_kernels`' pixel uses the NumPy intersector) unless
    one renders in this process (``--workers 1``, or a single tile to render); the Python API's
    and the tests' renders with ``workers=1`` do. A spawned worker costs about 1 s more to start
    on 2 cores (it imports pmmw, loads the cached kernels and builds the sky tables itself; more
    when the workers outnumber the cores), and its tiles' arrays come back through its pipe rather
    than shared memory (`_Slots`: a few per cent)."""
    fork = sys.platform.startswith("linux") and not embree_used()
    return mp.get_context("fork" if fork else "spawn")


@contextlib.contextmanager
def _spawning():
    """While a spawned worker starts (within `interrupt.deferred`):

    - an empty ``__main__``. Multiprocessing has a spawned process run the parent's main script
      again (as ``__mp_main__``), for the functions it may define: an unguarded script would
      render again in each worker, and ``python -`` fails (no file '<stdin>'). A worker needs
      pmmw's code alone; a job holding an object of a class defined in the main script cannot be
      sent to it (a PicklingError names the class), nor to a Dask worker.
    - SIGINT ignored, which the new process keeps through its exec until `interrupt.as_worker`
      ignores it for good: a Ctrl-C while it imports pmmw would end it with a traceback. SIGINT is
      blocked here, so one that comes meanwhile waits for the parent's own handler (in the main
      thread only: signal handlers are the main thread's)."""
    main = sys.modules.get("__main__")  # none in some embedding interpreters
    sys.modules["__main__"] = types.ModuleType("__main__")
    quiet = threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is not None
    old = signal.signal(signal.SIGINT, signal.SIG_IGN) if quiet else None
    try:
        yield
    finally:
        if quiet:
            signal.signal(signal.SIGINT, old)
        if main is None:
            del sys.modules["__main__"]
        else:
            sys.modules["__main__"] = main


def _render_on_workers(job: TraceJob, kind: str, todo: list, n: int, collect):
    """Render the tiles ``todo`` on ``n`` worker processes, calling ``collect`` with each result."""
    ctx = _context()
    forked = ctx.get_start_method() == "fork"
    if forked:  # the kernels are compiled or loaded here already (`prepare_kernels`): every worker inherits them
        with timings.phase("sky tables"):
            prime(job)
    pixels = max((x1 - x0) * (y1 - y0) for _, x0, y0, x1, y1 in todo)
    queue = deque(_by_cost(job, todo))
    deaths = dict.fromkeys((t[0] for t in todo), 0)
    idle_deaths = 0
    ready_seen = False
    live: list[_Worker] = []
    retired: list[_Worker] = []

    def start():
        ours, theirs = ctx.Pipe()
        inherited = [w.conn for w in live] + [ours] if forked else []
        slots = _Slots(_IN_FLIGHT, pixels) if forked else None
        with interrupt.deferred():
            p = ctx.Process(target=_work, args=(theirs, job, kind, inherited, slots), daemon=True)
            with contextlib.nullcontext() if forked else _spawning():
                p.start()
            live.append(_Worker(p, ours, slots))
        theirs.close()

    try:
        timings.mark("first tile sent")
        for _ in range(n):
            start()
        while live:
            ready = set(wait([w.conn for w in live] + [w.process.sentinel for w in live], timeout=_WATCH_S))
            for w in [w for w in live if not w.hung and _stalled(w, time.perf_counter())]:  # once each
                index = w.tiles[0][0]
                warn(
                    f"a worker process used no CPU for {_STALL_S:g} s while rendering tile {index}: hung, "
                    "so it was stopped and the tile is rendered again"
                )
                w.hung = True
                w.process.kill()  # its sentinel says so next time round: a death, handled below
            for w in [w for w in live if w.conn in ready or w.process.sentinel in ready]:
                reply = None
                if w.conn in ready:
                    try:
                        reply = w.conn.recv()
                    except (EOFError, OSError):  # it died: its sentinel is ready too
                        pass
                if reply is not None:
                    status, value = reply
                    if status == "error":
                        raise value[0] from _WorkerTraceback(value[1])
                    now = time.perf_counter()
                    if isinstance(value, float):  # the worker is ready: its set-up's seconds
                        if not ready_seen:  # the first worker's: the one that traces the first ray
                            timings.add(WORKER_SETUP, value)
                            ready_seen = True
                    else:  # a tile: rendered since the worker was ready or sent its last one
                        w.tiles.popleft()
                        k = w.slot_of.popleft()
                        collect(value if w.slots is None else w.slots.take(k, value), now - w.free_at)
                    w.free_at = now
                if reply is None or w.process.sentinel in ready:
                    live.remove(w)
                    w.process.join()
                    w.conn.close()
                    if not w.tiles:
                        idle_deaths += 1
                        if idle_deaths > n:
                            how = _death(w.process.exitcode, "use fewer --workers")
                            raise EnvironmentProblem(
                                f"{idle_deaths} worker processes died before rendering a "
                                f"tile, the last one {how}; {_KEPT}"
                            )
                    else:
                        index, x0, y0, x1, y1 = w.tiles[0]  # the one it was rendering
                        deaths[index] += 1
                        if deaths[index] > _RETRIES:
                            how = (
                                f"hung (no CPU for {_STALL_S:g} s; stopped)"
                                if w.hung
                                else _death(
                                    w.process.exitcode, "lower render.spp or render.tile, or use fewer --workers"
                                )
                            )
                            raise EnvironmentProblem(
                                f"tile {index} (pixels x {x0}..{x1 - 1}, y {y0}..{y1 - 1}): the "
                                f"worker process rendering it {how}, on each of "
                                f"{deaths[index]} tries; {_KEPT}"
                            )
                        queue.extendleft(reversed(w.tiles))  # back to the front, in their order
                    if queue:
                        start()
                    continue
                # keep _IN_FLIGHT tiles with it: the next one waits in its pipe while it renders,
                # so it never waits for this process between tiles; but not at the end, where a
                # tile waiting here would keep a worker that is done sooner idle
                while queue and len(w.tiles) < _IN_FLIGHT and (not w.tiles or len(queue) >= len(live)):
                    w.slot_of.append(w.free_slot())
                    w.tiles.append(queue.popleft())
                    try:
                        w.conn.send((w.tiles[-1], w.slot_of[-1]))
                    except OSError:  # it died just now: its sentinel says so next
                        break
                    timings.mark("first ray")  # a ready worker traces it at once
                if not w.tiles:  # nothing left for it: EOF ends it
                    live.remove(w)
                    w.conn.close()
                    retired.append(w)
    finally:
        with interrupt.deferred():
            for w in live + retired:
                w.conn.close()
                w.process.kill()
            for w in live + retired:
                w.process.join()


_DASK_INTEGRATORS: dict = {}  # per Dask worker process: the job token -> its Integrator


def _dask_tile(job: TraceJob, kind: str, token: str, tile) -> TileResult | str:
    """One tile on a Dask worker (the worker builds the Embree scene once per job), or the
    traceback's text if it raised: an exception object crossing Dask can hang its client when its
    traceback does not pickle."""
    try:
        integ = _DASK_INTEGRATORS.get(token)
        if integ is None:
            _DASK_INTEGRATORS.clear()  # one job at a time: drop an earlier frequency's scene
            _reuse_freed_memory()
            integ = _DASK_INTEGRATORS[token] = Integrator(job, make_intersector(job.vertices, job.faces, kind=kind))
        return integ.render_tile(tile)
    except Exception as e:  # noqa: BLE001 - reported by the parent, with the tile
        return exception_text(e)


class _SchedulerGone(Exception):
    """The Dask scheduler (its address is the message) went away: the client's futures are cancelled."""


def _render_on_dask(client, job: TraceJob, kind: str, todo: list, collect):
    """Render ``todo`` as one Dask task per tile on ``client``'s workers, results to ``collect``
    as they finish. The job is sent to every worker once. A task whose worker is lost is
    rescheduled by the scheduler; a tile that raises, or whose workers keep dying, stops the
    render with an `EnvironmentProblem` naming it (finished tiles are already saved); a lost
    scheduler raises `_SchedulerGone`. Tasks only return their tiles: ``collect`` saves them
    here, so no task of a render that ended (its scheduler gone, pmmw stopped) can write a file.
    The tasks left are cancelled on the way out."""
    import uuid

    from dask.distributed import as_completed

    from pmmw.distributed import cancel_quietly, scheduler_lost

    token = uuid.uuid4().hex
    futures = {}
    try:
        try:
            [job_f] = client.scatter([job], broadcast=True, hash=False)
        except Exception as e:  # noqa: BLE001 - each a line, not a traceback
            if scheduler_lost(client):
                raise _SchedulerGone(client.scheduler.address) from None
            # a TimeoutError is an OSError, which the caller would blame on the tile folder
            raise EnvironmentProblem(
                f"the Dask cluster at {client.scheduler.address} did not take the job "
                f"({type(e).__name__}: {str(e)[:200]}): does it have workers?"
            ) from None
        futures = {
            client.submit(_dask_tile, job_f, kind, token, t, key=f"pmmw-tile-{token}-{t[0]}", pure=False): t
            for t in todo
        }
        for fut in as_completed(futures):
            t = futures[fut]
            try:
                r = fut.result()
            except Exception as e:  # KilledWorker: its workers were lost too often
                if scheduler_lost(client, e):
                    raise _SchedulerGone(client.scheduler.address) from None
                r = f"{type(e).__name__}: {str(e)[:300]}"
            if isinstance(r, str):
                raise EnvironmentProblem(
                    f"tile {t[0]} (pixels x {t[1]}..{t[3] - 1}, y {t[2]}..{t[4] - 1}) failed on the Dask cluster: "
                    f"{r.strip()}; finished tiles are kept: run again with --resume"
                )
            collect(r)
    finally:
        cancel_quietly(client, futures)


def assemble(job: TraceJob, results: list[TileResult]):
    """Stitch tile results into full images.

    Returns
    -------
    Image
        ``mean``, ``stderr`` (H, W, 4); ``depth``, ``material``, ``samples`` (H, W); ``rays``;
        ``t_isect`` [s] summed over tiles; ``truncated`` (H, W, 2), ``replicate_diff``
        (H, W, 4) (`TileResult`).
    """
    w, h = job.camera.width, job.camera.height
    img = Image(
        np.zeros((h, w, 4)),
        np.zeros((h, w, 4)),
        np.zeros((h, w)),
        np.zeros((h, w)),
        np.zeros((h, w), np.int32),
        0,
        0.0,
        np.zeros((h, w, 2)),
        np.zeros((h, w, 4)),
    )
    for r in results:
        x0, y0, x1, y1 = r.box
        img.mean[y0:y1, x0:x1] = r.mean
        img.stderr[y0:y1, x0:x1] = r.stderr
        img.depth[y0:y1, x0:x1] = r.depth
        img.material[y0:y1, x0:x1] = r.material
        img.samples[y0:y1, x0:x1] = r.samples
        img.truncated[y0:y1, x0:x1] = r.truncated
        img.replicate_diff[y0:y1, x0:x1] = r.replicate_diff
        img.rays += r.rays
        img.t_isect += r.t_isect
    return img


@dataclass
class Image:
    """A whole image assembled from tiles (see `assemble`)."""

    mean: np.ndarray
    stderr: np.ndarray
    depth: np.ndarray
    material: np.ndarray
    samples: np.ndarray
    rays: int
    t_isect: float
    truncated: np.ndarray
    replicate_diff: np.ndarray
