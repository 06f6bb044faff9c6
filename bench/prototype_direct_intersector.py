#!/usr/bin/env python3
"""Prototype: pmmw's trace with Embree called per ray from a compiled loop instead of through embreex.

usage: prototype_direct_intersector.py SCENARIO.yaml [--set KEY=VALUE ...] [--spp N] [--rounds 2]

`DirectIntersector` is pmmw's `EmbreeIntersector` with its ``intersect`` replaced: the wave's
float64 origins and directions go straight into ``rtcIntersect1`` (Embree 4, the library embreex
ships, through `prototype_path_loop.DirectScene`) from a numba loop, with no float32 copies of the
wave; the float64 plane distance and the grazing fallback are pmmw's. Every tile of the scenario is
traced in this process (one worker) with each intersector in turn, alternating, and the script
prints the trace time, the time inside the intersector and whether the images are identical (the
same faces are found from the same float32-rounded rays, so they must be, bit for bit).
"""

import argparse
import dataclasses
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from prototype_path_loop import DirectScene, direct, rayhit_buffers  # noqa: E402

from pmmw.trace.intersect import EmbreeIntersector, _as_rays, _plane_distance  # noqa: E402


class DirectIntersector(EmbreeIntersector):
    """`EmbreeIntersector` whose queries call ``rtcIntersect1`` per ray from numba."""

    def __init__(self, vertices, faces):
        super().__init__(vertices, faces)
        self._direct = DirectScene(self.vertices, self.faces)
        self._rf, self._ru = rayhit_buffers(1)

    def intersect(self, origins, directions):
        o, d = _as_rays(origins, directions)
        n = len(o)
        t = np.full(n, np.inf)
        prim = np.empty(n, dtype=np.int64)
        if n == 0:
            return t, np.full(n, -1, np.int64)
        direct(self._direct.ptr, self._rf, self._ru, o, d, prim)
        grazing = np.flatnonzero(_plane_distance(o, d, self._v0, self._normals, prim, t))
        if grazing.size:  # Embree's own float32 distance there, as EmbreeIntersector does
            res = self._scene.run(o[grazing].astype(np.float32), d[grazing].astype(np.float32), output=1)
            hit = res["primID"] >= 0
            t[grazing] = np.where(hit, res["tfar"].astype(np.float64), np.inf)
            prim[grazing] = np.where(hit, res["primID"], -1)
        return t, prim


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenario")
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--spp", type=int, default=None)
    ap.add_argument("--rounds", type=int, default=2)
    a = ap.parse_args()
    from numba import set_num_threads

    from pmmw.pipeline import make_job, resolve
    from pmmw.trace import kernels
    from pmmw.trace.integrator import Integrator

    set_num_threads(1)
    res = resolve(a.scenario, a.set)
    job = make_job(res, res.scenario.frequencies[0])
    if a.spp:
        job = dataclasses.replace(job, settings=dataclasses.replace(job.settings, spp=a.spp))
    kernels.warm(job.settings.stack_size)
    integrators = {
        "embreex": Integrator(job, EmbreeIntersector(job.vertices, job.faces)),
        "direct": Integrator(job, DirectIntersector(job.vertices, job.faces)),
    }
    for it in integrators.values():  # compile and load
        it.render_tile(job.tiles()[0])
    means = {}
    for r in range(a.rounds):
        for name in ("embreex", "direct") if r % 2 == 0 else ("direct", "embreex"):
            it = integrators[name]
            t0 = time.perf_counter()
            tiles = [it.render_tile(t) for t in job.tiles()]
            wall = time.perf_counter() - t0
            isect = sum(t.t_isect for t in tiles)
            rays = sum(t.rays for t in tiles)
            means[name] = np.concatenate([t.mean.ravel() for t in tiles])
            print(
                f"round {r + 1} {name:8s}: trace {wall:6.2f} s, intersector {isect:5.2f} s "
                f"({isect / rays * 1e9:4.0f} ns per segment, {rays / 1e6:.2f} M), trace / intersector {wall / isect:4.2f}",
                flush=True,
            )
    same = np.array_equal(means["embreex"], means["direct"])
    print(f"images identical: {same} (largest difference {np.max(np.abs(means['embreex'] - means['direct'])):.3g} K)")


if __name__ == "__main__":
    main()
