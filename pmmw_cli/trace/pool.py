"""Render the tiles of a job on a process pool.

Each worker builds the Embree scene once (in the pool initializer) and renders whole tiles.
Tiles are fixed by the job (not by the worker count) and each tile seeds its own random stream
from (run seed, tile index), so images are identical whatever ``--workers`` is.

Finished tiles are saved atomically to ``tile_dir`` as they arrive; with ``resume`` the tiles
already there are loaded instead of re-rendered, so an interrupted render loses nothing.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pmmw_cli.io.atomic import save_npz_atomic
from pmmw_cli.trace.integrator import Integrator, TileResult
from pmmw_cli.trace.intersect import make_intersector
from pmmw_cli.trace.job import TraceJob

_WORKER: Integrator | None = None


def _init_worker(job: TraceJob, kind: str):
    global _WORKER
    _WORKER = Integrator(job, make_intersector(job.vertices, job.faces, kind=kind))


def _render(tile) -> TileResult:
    return _WORKER.render_tile(tile)


def _tile_path(tile_dir: Path, index: int) -> Path:
    return tile_dir / f"tile_{index:06d}.npz"


def _save_tile(tile_dir: Path, r: TileResult):
    save_npz_atomic(
        _tile_path(tile_dir, r.index), index=r.index, box=np.array(r.box), mean=r.mean,
        stderr=r.stderr, depth=r.depth, material=r.material, rays=r.rays, samples=r.samples,
        t_isect=r.t_isect, truncated=r.truncated, replicate_diff=r.replicate_diff,
    )


def _load_tile(path: Path) -> TileResult | None:
    try:
        with np.load(path) as z:
            return TileResult(
                int(z["index"]), tuple(int(v) for v in z["box"]), z["mean"], z["stderr"],
                z["depth"], z["material"], int(z["rays"]), z["samples"], float(z["t_isect"]),
                z["truncated"], z["replicate_diff"],
            )
    except Exception:  # a damaged tile file is simply rendered again
        return None


def default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def render_tiles(job: TraceJob, workers: int | None = None, tile_dir: Path | None = None,
                 resume: bool = False, intersector: str = "embree", progress=None,
                 tiles=None) -> list[TileResult]:
    """Render ``tiles`` (default: all of the job's tiles) and return their results.

    Parameters
    ----------
    job : TraceJob
    workers : int, optional
        Processes; default all cores. 1 renders in this process.
    tile_dir : Path, optional
        Where finished tiles are saved (and, with ``resume``, loaded from).
    progress : callable(done, total, rays, elapsed), optional
    """
    tiles = job.tiles() if tiles is None else tiles
    results: dict[int, TileResult] = {}
    if tile_dir is not None:
        tile_dir.mkdir(parents=True, exist_ok=True)
        if resume:
            for t in tiles:
                path = _tile_path(tile_dir, t[0])
                if path.exists():
                    r = _load_tile(path)
                    if r is not None and r.box == tuple(t[1:]):
                        results[t[0]] = r
    todo = [t for t in tiles if t[0] not in results]
    workers = default_workers() if workers is None else max(1, int(workers))
    workers = min(workers, max(1, len(todo)))
    start = time.perf_counter()
    rays = sum(r.rays for r in results.values())

    def _collect(r: TileResult):
        nonlocal rays
        results[r.index] = r
        rays += r.rays
        if tile_dir is not None:
            _save_tile(tile_dir, r)
        if progress is not None:
            progress(len(results), len(tiles), rays, time.perf_counter() - start)

    if todo and workers == 1:
        _init_worker(job, intersector)
        for t in todo:
            _collect(_render(t))
    elif todo:
        ctx = mp.get_context("fork" if sys.platform.startswith("linux") else "spawn")
        with ctx.Pool(workers, initializer=_init_worker, initargs=(job, intersector)) as pool:
            for r in pool.imap_unordered(_render, todo, chunksize=1):
                _collect(r)
    return [results[t[0]] for t in tiles]


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
    img = Image(np.zeros((h, w, 4)), np.zeros((h, w, 4)), np.zeros((h, w)), np.zeros((h, w)),
                np.zeros((h, w), np.int32), 0, 0.0, np.zeros((h, w, 2)), np.zeros((h, w, 4)))
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
