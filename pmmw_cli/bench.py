"""``pmmw bench``: run time against error, for each scenario and sampling strategy.

For each scenario (first frequency) a converged reference is made: analytic where one exists (an
isothermal scene reads its temperature everywhere), otherwise a high-sample render with the
thesis's full splitting, a tiny threshold and extra depth, cached on disk by scenario hash. Then the
scenario is rendered at increasing samples per pixel with each strategy, recording wall time,
rays traced, the time spent in Embree for exactly those rays, and the RMS and max error [K] of the
ideal image and of the sensor image before noise (both images blurred by the imager's PSF).
Results go to a Markdown table and a log-log plot of error against time.
"""

from __future__ import annotations

import dataclasses
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

from pmmw import __version__
from pmmw.constants import C0
from pmmw.imaging.imager import blur, psf_kernel
from pmmw.io.atomic import save_npz_atomic, write_text_atomic
from pmmw.io.preview import save_figure
from pmmw.pipeline import aux_channels, make_job, resolve, scenario_hash
from pmmw.trace import kernels
from pmmw.trace.pool import assemble, default_workers, render_tiles
from pmmw_cli import bench_anchor

STRATEGIES = ("split", "stochastic", "hybrid")
REFERENCE_THRESHOLD = 1e-6
REFERENCE_EXTRA_DEPTH = 4


def _render(job, workers):
    kernels.warm(job.settings.stack_size)  # the first render would otherwise time numba's start (~0.4 s)
    t0 = time.perf_counter()
    img = assemble(job, render_tiles(job, workers=workers))
    return img, time.perf_counter() - t0


def _isothermal_temperature(job):
    """The temperature of a scene in which everything that can be seen has one temperature."""
    media, sky = job.media, job.sky
    temps = {float(t) for i, t in enumerate(media.temperature) if i > 0}
    if media.alpha[0] > 0:
        temps.add(float(media.temperature[0]))
    sky_t = getattr(sky, "temperature", None)
    if getattr(sky, "ground_temperature", None) is None or sky_t is None or type(sky).__name__ != "UniformSky":
        return None
    temps |= {float(sky_t), float(sky.ground_temperature)}
    return temps.pop() if len(temps) == 1 else None


def reference(job, workers, cache_dir: Path, shash: str, ref_spp: int):
    """(mean image (H, W, 4), description): analytic if isothermal, else a cached render."""
    t_iso = _isothermal_temperature(job)
    if t_iso is not None:
        ref = np.zeros((job.camera.height, job.camera.width, 4))
        ref[..., 0] = ref[..., 1] = t_iso
        return ref, f"analytic (isothermal scene at {t_iso:g} K)"
    path = cache_dir / f"{shash}_ref{ref_spp}.npz"
    if path.exists():
        with np.load(path) as z:
            return z["mean"], f"{ref_spp} spp split render (cached {path.name})"
    st = dataclasses.replace(
        job.settings,
        spp=ref_spp,
        strategy="split",
        termination="temperature",
        threshold=REFERENCE_THRESHOLD,
        max_depth=job.settings.max_depth + REFERENCE_EXTRA_DEPTH,
        target_error=None,
    )
    img, _ = _render(dataclasses.replace(job, settings=st), workers)
    save_npz_atomic(path, mean=img.mean)
    return img.mean, f"{ref_spp} spp split render, threshold {REFERENCE_THRESHOLD:g}, depth {st.max_depth}"


def _errors(mean, ref, kern):
    out = {}
    for label, a, b in (("ideal", mean, ref), ("sensor", None, None)):
        if label == "sensor":
            if kern is None:
                a, b = mean, ref
            else:
                a = np.stack([blur(mean[..., c], kern) for c in (0, 1)], axis=-1)
                b = np.stack([blur(ref[..., c], kern) for c in (0, 1)], axis=-1)
        d = a[..., :2] - b[..., :2]
        out[f"{label}_rms"] = float(np.sqrt(np.mean(d * d)))
        out[f"{label}_max"] = float(np.max(np.abs(d)))
    return out


def machine() -> str:
    cpu = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(
            next(
                line for line in Path("/proc/meminfo").read_text().splitlines() if line.startswith("MemTotal")
            ).split()[1]
        )
        mem = f", {kb / 2**20:.0f} GiB"
    except (OSError, StopIteration, ValueError):
        pass
    return f"{cpu}, {default_workers()} cores{mem}, {platform.system()} {platform.release()}, Python {platform.python_version()}"


def bench(
    scenarios,
    *,
    spp_list=(1, 2, 4, 8, 16, 32),
    strategies=STRATEGIES,
    ref_spp=256,
    workers=None,
    overrides=(),
    out_md=Path("docs/benchmarks.md"),
    cache_dir=Path(".pmmw-cache"),
    command=None,
    with_scaling=False,
    render_times=(),
    skip_configs=(),
    anchor=None,
    anchor_rounds=3,
):
    """Run the benchmark and write ``out_md`` and one plot per scenario beside it. ``anchor``: the
    Python of an environment with Mitsuba 3 (the ``bench`` extra): adds pmmw against Mitsuba on
    the speed anchor, ``anchor_rounds`` alternating rounds (`pmmw_cli.bench_anchor`)."""
    if anchor is not None:
        bench_anchor.check(anchor)  # before the scenarios: a wrong Python found after them costs minutes
    workers = workers or default_workers()
    sections, all_rows = [], {}
    for path in scenarios:
        res = resolve(path, overrides)
        scn = res.scenario
        f = scn.frequencies[0]
        job = make_job(res, f)
        shash = scenario_hash(scn, res.db)
        t0 = time.perf_counter()
        ref, ref_desc = reference(job, workers, Path(cache_dir), shash, ref_spp)
        t_ref = time.perf_counter() - t0
        kern = (
            psf_kernel(job.camera.pixel_angle, job.k0, scn.imager.aperture_diameter)
            if scn.imager.aperture_diameter > 0
            else None
        )
        rows = []
        for strategy in strategies:
            for spp in spp_list:
                st = dataclasses.replace(job.settings, spp=spp, strategy=strategy, target_error=None)
                img, wall = _render(dataclasses.replace(job, settings=st), workers)
                rows.append(
                    {
                        "strategy": strategy,
                        "spp": spp,
                        "wall_s": wall,
                        "rays": img.rays,
                        "isect_s": img.t_isect,
                        "ratio": (wall * workers) / img.t_isect if img.t_isect > 0 else float("nan"),
                        **_errors(img.mean, ref, kern),
                    }
                )
                print(
                    f"{scn.name} {strategy:10s} spp={spp:4d}: {wall:7.2f} s, {img.rays / 1e6:7.2f} M rays, "
                    f"ideal RMS {rows[-1]['ideal_rms']:.3f} K, sensor RMS {rows[-1]['sensor_rms']:.3f} K",
                    file=sys.stderr,
                )
        plot = out_md.parent / f"benchmarks_{scn.name}.png"
        _plot(rows, plot, scn.name, scn.imager.noise)
        all_rows[scn.name] = rows
        sections.append(_section(scn, job, ref_desc, t_ref, rows, plot.name, workers))
    header = (
        "# Benchmarks: run time against error\n\n"
        f"Generated by `{command or 'pmmw bench'}` with pmmw {__version__}.\n\n"
        f"Machine: {machine()}; {workers} worker processes.\n\n"
        "Errors are over Ex2 and Ey2 [K] against the reference named per scenario; *sensor* is the "
        "image after the imager's PSF and before noise. *ratio* is (wall time x workers) / time spent "
        "inside Embree for exactly the rays traced: the cost of everything that is not intersection, "
        "relative to the physical limit of this approach on this machine (1 would be pure Embree).\n\n"
        "Wall times are single runs: on a machine shared with other jobs they carry a few tens of percent "
        "of noise (compare the split and hybrid rows at 1 spp, which trace identical rays); the errors do "
        "not depend on it.\n\n"
        "Physical optics (`pmmw po`: direct sum against octree, 1e3-1e6 facets x 1e2-1e5 directions) is "
        "measured by `pmmw bench --po` in [benchmarks_po.md](benchmarks_po.md). Paths per second against "
        "Mitsuba 3 on the same scene (the speed anchor): its section below (`--anchor`), and the history "
        "in [benchmarks_anchor.md](benchmarks_anchor.md).\n"
    )
    if skip_configs:
        all_rows["skips"] = skips(skip_configs, workers=workers, cache_dir=cache_dir, ref_spp=ref_spp)
        sections.append(_skips_section(all_rows["skips"], workers))
    if render_times:
        sections.append(_render_times_section(render_times, workers))
    if with_scaling:
        res_px, spp = (128, 128), 4
        sections.append(_scaling_section(scaling(resolution=res_px, spp=spp, workers=workers), res_px, spp))
    if anchor is not None:
        all_rows["anchor"] = bench_anchor.run(anchor, rounds=anchor_rounds, workers=workers)
        sections.append(bench_anchor.section(all_rows["anchor"], machine(), command or "pmmw bench"))
    write_text_atomic(out_md, header + "\n".join(sections))
    write_text_atomic(out_md.with_suffix(".json"), json.dumps(all_rows, indent=2, default=float))
    return all_rows


def _section(scn, job, ref_desc, t_ref, rows, plot_name, workers):
    lines = [
        f"\n## {scn.name}\n",
        f"{job.camera.width} x {job.camera.height} pixels at {job.frequency / 1e9:g} GHz, "
        f"{job.faces.shape[0]} triangles, max_depth {job.settings.max_depth}, threshold {job.settings.threshold:g}, "
        f"termination {job.settings.termination}; imager noise {scn.imager.noise:g} K. "
        f"Reference: {ref_desc} ({t_ref:.1f} s).\n",
        f"![error against time]({plot_name})\n",
        "| strategy | spp | wall [s] | rays [M] | Embree [s] | ratio | ideal RMS [K] | ideal max [K] | sensor RMS [K] | sensor max [K] |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        lines.append(
            f"| {r['strategy']} | {r['spp']} | {r['wall_s']:.2f} | {r['rays'] / 1e6:.2f} | {r['isect_s']:.2f} | "
            f"{r['ratio']:.1f} | {r['ideal_rms']:.3f} | {r['ideal_max']:.2f} | {r['sensor_rms']:.3f} | {r['sensor_max']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def _plot(rows, path: Path, name: str, noise: float):
    from pmmw.io.preview import subplots

    fig, ax = subplots(figsize=(6.4, 4.4), dpi=110)
    for strategy in dict.fromkeys(r["strategy"] for r in rows):
        rs = [r for r in rows if r["strategy"] == strategy]
        ax.loglog([r["wall_s"] for r in rs], [max(r["ideal_rms"], 1e-6) for r in rs], "o-", label=f"{strategy}: ideal")
        ax.loglog(
            [r["wall_s"] for r in rs], [max(r["sensor_rms"], 1e-6) for r in rs], "s--", label=f"{strategy}: sensor"
        )
    if noise > 0:
        ax.axhline(0.1 * noise, color="grey", lw=0.8, ls=":", label="0.1 x imager noise")
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("RMS error of Ex2, Ey2 [K]")
    ax.set_title(f"{name}: error against run time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path)


def scaling(levels=(2, 3, 4, 5, 6, 7, 8), resolution=(128, 128), spp=4, workers=None):
    """Cost against triangle count: an icosphere of growing subdivision over a lossy ground.

    The same pixels, samples and materials for every level (the sphere fills most of the view and
    the image barely changes), so the time differences are those of the geometry alone.

    Returns
    -------
    list of dict
        triangles, build_s (Embree scene), wall_s, isect_s, rays per level.
    """
    import trimesh

    from pmmw.scene.camera import Camera
    from pmmw.scene.sky import UniformSky
    from pmmw.trace.job import Media, RenderSettings, TraceJob

    workers = workers or default_workers()
    rows = []
    for level in levels:
        ball = trimesh.creation.icosphere(subdivisions=level, radius=1.0)
        ball.apply_translation([0, 4, 1.2])
        ground = trimesh.creation.box(extents=[200, 200, 2])
        ground.apply_translation([0, 0, -1])
        verts = np.concatenate([ball.vertices, ground.vertices])
        faces = np.concatenate([ball.faces, ground.faces + len(ball.vertices)])
        normals = np.concatenate([ball.face_normals, ground.face_normals])
        fmed = np.concatenate([np.full(len(ball.faces), 1), np.full(len(ground.faces), 2)]).astype(np.int32)
        k0 = 2 * np.pi * 35e9 / C0
        eps = np.array([1 + 0j, 2.5 + 0.6j, 3.9 + 0.56j])
        media = Media(
            ["ambient", "ball", "ground"],
            eps,
            np.zeros(3, np.int8),
            np.array([290.0, 300.0, 300.0]),
            np.array([0.0, *(2 * k0 * np.sqrt(eps[1:]).imag)]),
            (None, None, None),
        )
        cam = Camera.look_at([0, 0, 1.5], [0, 4, 1.2], [0, 0, 1], np.radians(40), resolution)
        job = TraceJob(
            verts,
            faces,
            normals,
            fmed,
            media,
            cam,
            UniformSky(30.0, 290.0),
            35e9,
            RenderSettings(spp=spp, max_depth=6, threshold=1e-3, tile=64),
        )
        build = _in_a_fork(_build_seconds, verts, faces, 1)[0]
        img, wall = _render(job, workers)
        rows.append(
            {"triangles": int(len(faces)), "build_s": build, "wall_s": wall, "isect_s": img.t_isect, "rays": img.rays}
        )
        print(
            f"scaling: {len(faces):9d} triangles: build {build:.2f} s, render {wall:.2f} s, Embree {img.t_isect:.2f} s",
            file=sys.stderr,
        )
    return rows


def _scaling_section(rows, resolution, spp):
    lines = [
        "\n## Cost against triangle count\n",
        f"An icosphere of growing subdivision over a lossy ground, {resolution[0]} x {resolution[1]} pixels, "
        f"{spp} spp, split strategy, 35 GHz (`pmmw bench --scaling`). *per ray* is wall time x workers "
        "divided by rays traced. The render wall time includes each worker building its own Embree "
        "scene once (the build column, in parallel), which dominates at a million triangles for this "
        "small image; the intersection time itself grows slowly with the triangle count.\n",
        "| triangles | Embree build [s] | render wall [s] | Embree [s] | rays [M] | per ray [us] |",
        "| ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    w = default_workers()
    for r in rows:
        lines.append(
            f"| {r['triangles']:,} | {r['build_s']:.2f} | {r['wall_s']:.2f} | {r['isect_s']:.2f} | "
            f"{r['rays'] / 1e6:.2f} | {r['wall_s'] * w / r['rays'] * 1e6:.2f} |"
        )
    return "\n".join(lines) + "\n"


TRACE_REPEATS = 2  # the shipped scenarios' trace times take the fastest of this many runs


def _render_times_section(configs, workers):
    """Each shipped scenario rendered as shipped (full resolution, its defaults): the tracing
    alone against Embree's time for the same rays (the issue's speed measure), and the whole
    command."""
    import tempfile

    from pmmw.pipeline import render

    lines = [
        "\n## Shipped scenarios at full resolution\n",
        f"Each config with its own settings, {workers} workers. *trace* is the tracing alone (the tiles "
        f"on the workers, fastest of {TRACE_REPEATS} runs), *Embree* the time spent inside Embree for exactly "
        "those rays (summed over the workers), *ratio* = trace x workers / Embree (1 would be pure "
        "intersection); *command* is the wall time of `pmmw render CONFIG`, including scene loading, Embree "
        "builds, the imager model, writing the files and the report's figures (not Python's start).\n",
        "| config | pixels | spp | rays [M] | trace [s] | Embree [s] | ratio | command [s] |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for path in configs:
        res = resolve(path)
        scn = res.scenario
        job = make_job(res, scn.frequencies[0])
        best = None
        for _ in range(TRACE_REPEATS):
            t0 = time.perf_counter()
            tiles = render_tiles(job, workers=workers)
            wall = time.perf_counter() - t0
            if best is None or wall < best[0]:
                best = (wall, sum(t.t_isect for t in tiles), sum(t.rays for t in tiles))
        trace, isect, rays = best
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            render(path, out=Path(tmp), workers=workers, quiet=True)
            command = time.perf_counter() - t0
        w, h = scn.imager.resolution
        ratio = trace * workers / isect if isect > 0 else float("nan")
        lines.append(
            f"| `{path}` | {w} x {h} | {scn.render.spp} | {rays / 1e6:.3g} | {trace:.2f} | {isect:.3f} | "
            f"{ratio:.1f} | {command:.1f} |"
        )
    return "\n".join(lines) + "\n"


# -- what each skip saves -----------------------------------------------------------------------
SKIP_ADAPTIVE_SPP = 16  # cap of the adaptive renders compared in the skips section
SKIP_ADAPTIVE_MIN_SPP = 2
SKIP_REPEATS = 2  # paired timings take the fastest of this many alternating runs


def _paired(workers, *jobs):
    """Fastest render time [s] of each job over SKIP_REPEATS alternating runs."""
    best = [np.inf] * len(jobs)
    for _ in range(SKIP_REPEATS):
        for i, j in enumerate(jobs):
            best[i] = min(best[i], _render(j, workers)[1])
    return best


class _CountingIntersector:
    """An intersector that records how many hits land on each medium (for the skips section)."""

    def __init__(self, inner, face_medium, n_media):
        self._inner = inner
        self._face_medium = face_medium
        self.hits = np.zeros(n_media, np.int64)

    def intersect(self, origins, directions):
        t, prim = self._inner.intersect(origins, directions)
        self.hits += np.bincount(self._face_medium[prim[prim >= 0]], minlength=self.hits.size)
        return t, prim

    def __getattr__(self, name):
        return getattr(self._inner, name)


class _RecordingSky:
    """A sky that records the directions and heights of the rays it is asked about."""

    def __init__(self, inner):
        self._inner = inner
        self.dirs, self.heights = [], []

    def brightness(self, directions, heights=None):
        self.dirs.append(np.array(directions))
        self.heights.append(np.zeros(len(directions)) if heights is None else np.array(heights))
        return self._inner.brightness(directions, heights=heights)

    def __getattr__(self, name):
        return getattr(self._inner, name)


def _in_a_fork(fn, *args):
    """``fn(*args)`` in a forked child process: what builds an Embree scene stays out of this one,
    so that the renders measured here fork their workers as the command line's do, rather than
    spawning them (`pmmw.trace.pool._context`), which would add their start-up to the times.
    Where the workers are spawned anyway (not Linux), here."""
    import concurrent.futures
    import multiprocessing

    if not sys.platform.startswith("linux"):
        return fn(*args)
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork")) as ex:
        return ex.submit(fn, *args).result()


def _build_seconds(vertices, faces, repeats):
    """Seconds to build the Embree scene of this triangle soup, ``repeats`` times, after a
    one-triangle build that starts Embree (its device, once per process) untimed."""
    from pmmw.trace.intersect import make_intersector

    make_intersector(np.eye(3), np.array([[0, 1, 2]]))
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        make_intersector(vertices, faces)
        out.append(time.perf_counter() - t0)
    return out


def _instrumented(job):
    """One in-process render that counts hits per medium, ambient segments sent to the layered
    atmosphere, and records the rays that reach the sky."""
    from pmmw.trace.integrator import Integrator
    from pmmw.trace.intersect import make_intersector

    sky = _RecordingSky(job.sky)
    job = dataclasses.replace(job, sky=sky)
    isect = _CountingIntersector(make_intersector(job.vertices, job.faces), job.face_medium, len(job.media.ids))
    segs = [0, 0.0]  # segments sent to AtmosphereModel.path, seconds inside it
    if job.atmosphere is not None:
        model = job.atmosphere
        orig = model.path

        def path(z0, z1, length):
            t0 = time.perf_counter()
            out = orig(z0, z1, length)
            segs[0] += len(z0)
            segs[1] += time.perf_counter() - t0
            return out

        model.path = path
    integ = Integrator(job, isect)
    rays = 0
    t0 = time.perf_counter()
    try:
        for tile in job.tiles():
            rays += integ.render_tile(tile).rays
    finally:
        if job.atmosphere is not None:
            del model.path
    dirs = np.concatenate(sky.dirs) if sky.dirs else np.zeros((0, 3))
    heights = np.concatenate(sky.heights) if sky.heights else np.zeros(0)
    return {
        "hits": isect.hits,
        "rays": rays,
        "atm_segments": segs[0],
        "atm_path_s": segs[1],
        "wall_s": time.perf_counter() - t0,
        "sky_dirs": dirs,
        "sky_heights": heights,
    }


def _sky_rt_cost(model, dirs, heights, chunk=20000):
    """Seconds of per-ray radiative transfer (Murakowski 2014 sec. 2.2.7) for these rays, each from its
    own height: the work the cached sky tables avoid."""
    from pmmw.atmosphere.model import layered_sky_temperature

    el = np.arcsin(np.clip(dirs[:, 2], -1.0, 1.0))
    up = el >= 0.0
    el, h = el[up], heights[up]
    t0 = time.perf_counter()
    for start in range(0, el.size, chunk):
        sl = slice(start, start + chunk)
        # one observer height per call: rays of a chunk share the chunk's mean height, which
        # costs the same as each ray's own (the work is per ray and per cell)
        layered_sky_temperature(
            model.edges,
            model.alpha,
            model.source,
            el[sl],
            observer_height=float(np.mean(h[sl])),
            refractive_index=model.refractive_index,
        )
    return time.perf_counter() - t0, int(up.sum())


def skips(configs, *, workers=None, cache_dir=Path(".pmmw-cache"), ref_spp=32):
    """Measure what each of the renderer's skips saves, per config (first frequency).

    Returns
    -------
    dict
        config path -> measurements (seconds, counts), as written to docs/benchmarks.json.
    """
    import tempfile

    from pmmw.imaging.imager import error_footprint
    from pmmw.scene.sky import AtmosphereSky
    from pmmw.trace.integrator import atmosphere_skip_length
    from pmmw.trace.job import BLACKBODY, METAL, OPAQUE

    workers = workers or default_workers()
    out = {}
    for path in configs:
        res = resolve(path)
        scn = res.scenario
        job = make_job(res, scn.frequencies[0])
        row = {"pixels": job.camera.width * job.camera.height, "spp": job.settings.spp, "workers": workers}
        _, row["render_s"] = _render(job, workers)
        img, row["render_s"] = _render(job, workers)  # second run: caches and page faults warm
        row["rays"] = img.rays
        per_ray = row["render_s"] * workers / img.rays

        # geometry and Embree scene once per worker, not per tile
        row["build_s"] = float(np.median(_in_a_fork(_build_seconds, job.vertices, job.faces, 3)))
        row["tiles"] = len(job.tiles())

        # no transmitted branch into metal, blackbody, opaque: one child per such hit avoided
        inst = _in_a_fork(_instrumented, job)
        sinks = np.isin(job.media.kind, (METAL, BLACKBODY, OPAQUE))
        row["sink_hits"] = int(inst["hits"][sinks].sum())
        row["sink_child_s"] = row["sink_hits"] * per_ray / workers

        # sky from cached tables, not per-ray radiative transfer
        row["sky_rays"] = int(inst["sky_dirs"].shape[0])
        if isinstance(job.sky, AtmosphereSky):
            t0 = time.perf_counter()
            job.sky.brightness(inst["sky_dirs"], heights=inst["sky_heights"])
            row["sky_table_s"] = time.perf_counter() - t0
            row["sky_rt_s"], row["sky_rt_rays"] = _sky_rt_cost(job.atmosphere, inst["sky_dirs"], inst["sky_heights"])

        # the layered atmosphere: none vs layered, and the short-segment skip
        variants = [("", job)]
        if job.atmosphere is None:
            res_atm = resolve(path, ["atmosphere={profile: standard}"])
            variants.append((" (atmosphere: {profile: standard})", make_job(res_atm, scn.frequencies[0])))
        for label, j in variants:
            if j.atmosphere is None:
                continue
            a = {"label": label, "skip_length_m": atmosphere_skip_length(j)}
            off = dataclasses.replace(j, settings=dataclasses.replace(j.settings, atmosphere_tolerance=0.0))
            a["with_s"], a["none_s"] = _paired(workers, j, dataclasses.replace(j, atmosphere=None))
            a["skip_on_s"], a["skip_off_s"] = _paired(workers, j, off)
            i_on, i_off = _in_a_fork(_instrumented, j), _in_a_fork(_instrumented, off)
            a["segments_on"], a["segments_off"] = i_on["atm_segments"], i_off["atm_segments"]
            a["path_on_s"], a["path_off_s"], a["inproc_s"] = i_on["atm_path_s"], i_off["atm_path_s"], i_off["wall_s"]
            # the bias of the skip alone: deterministic termination, so that no random stream shifts
            det = {"termination": "temperature"}
            img_on, _ = _render(dataclasses.replace(j, settings=dataclasses.replace(j.settings, **det)), workers)
            img_off, _ = _render(dataclasses.replace(off, settings=dataclasses.replace(off.settings, **det)), workers)
            a["skip_max_diff_K"] = float(np.max(np.abs(img_on.mean[..., :2] - img_off.mean[..., :2])))
            row.setdefault("atmosphere", []).append(a)

        # no roughness sampling on smooth surfaces: the same scene with every surface given a
        # roughness that changes nothing visible (Blinn-Phong m = 1e6, facets within ~0.1 degree)
        from pmmw.physics.roughness import BlinnPhong

        smooth_rough = BlinnPhong(1e6)
        rough_media = dataclasses.replace(job.media, roughness=(None,) + (smooth_rough,) * (len(job.media.ids) - 1))
        j_rough = dataclasses.replace(job, media=rough_media)
        row["rough_off_s"], row["rough_on_s"] = _paired(workers, job, j_rough)
        det = {"termination": "temperature"}
        img_s, _ = _render(dataclasses.replace(job, settings=dataclasses.replace(job.settings, **det)), workers)
        img_r, _ = _render(dataclasses.replace(j_rough, settings=dataclasses.replace(j_rough.settings, **det)), workers)
        diff = img_s.mean[..., :2] - img_r.mean[..., :2]
        row["rough_max_diff_K"] = float(np.max(np.abs(diff)))
        row["rough_rms_diff_K"] = float(np.sqrt(np.mean(diff**2)))

        # auxiliary channels: the whole command with and without all of them
        # auxiliary channels: the tracer keeps its per-pixel sums either way; asking adds the
        # channels to the EXR (the stderr images and writing them), timed here alone
        from pmmw.io.exr import write_exr
        from pmmw.physics.jones import stokes_images

        ideal = stokes_images(img.mean)
        chans = {c: ideal[c].astype(np.float32) for c in ("I", "Q", "U", "V", "Ex2", "Ey2")}
        chans.update({f"ideal.{c}": v for c, v in chans.items()})
        for _ in range(SKIP_REPEATS + 1):
            for key, with_aux in (("aux_off_s", False), ("aux_on_s", True)):
                with tempfile.TemporaryDirectory() as tmp:
                    t0 = time.perf_counter()
                    ch = dict(chans)
                    if with_aux:
                        ch.update(aux_channels(img, ("stderr", "depth", "material", "samples")))
                    write_exr(Path(tmp) / "x.exr", ch, {})
                    row[key] = min(row.get(key, np.inf), time.perf_counter() - t0)

        # adaptive sampling to the error after the blur vs per pixel, at 0.1 x the imager noise
        if scn.imager.aperture_diameter > 0 and scn.imager.noise > 0:
            ref, _ = reference(job, workers, Path(cache_dir), scenario_hash(scn, res.db), ref_spp)
            kern = psf_kernel(job.camera.pixel_angle, job.k0, scn.imager.aperture_diameter)
            target = 0.1 * scn.imager.noise
            row["adaptive"] = {
                "target_K": target,
                "spp_cap": SKIP_ADAPTIVE_SPP,
                "min_spp": SKIP_ADAPTIVE_MIN_SPP,
                "footprint_factor": error_footprint(kern),
            }
            for rule, f in (("fixed", None), ("pixel", 1.0), ("footprint", error_footprint(kern))):
                st = (
                    job.settings
                    if f is None
                    else dataclasses.replace(
                        job.settings,
                        spp=SKIP_ADAPTIVE_SPP,
                        min_spp=SKIP_ADAPTIVE_MIN_SPP,
                        target_error=target,
                        error_footprint=f,
                    )
                )
                img_a, wall = _render(dataclasses.replace(job, settings=st), workers)
                row["adaptive"][rule] = {
                    "wall_s": wall,
                    "mean_spp": float(img_a.samples.mean()),
                    "at_min": float(np.mean(img_a.samples <= st.min_spp)),
                    **_errors(img_a.mean, ref, kern),
                }
        out[str(path)] = row
        print(f"skips {path}: done", file=sys.stderr)
    return out


def _skips_section(rows, workers):
    lines = [
        "\n## What each skip saves\n",
        f"`pmmw bench --skips CONFIG`: each config as shipped (first frequency, {workers} workers), render "
        "times of the tracer alone (no files) unless noted; on/off pairs are the fastest of "
        f"{SKIP_REPEATS} alternating runs. Where a skip cannot be switched off without nonsense, the "
        "cost of the work it avoids is measured instead. On a machine shared with other jobs, "
        "differences below ~10 % are noise.\n",
    ]
    for path, r in rows.items():
        t = r["render_s"]
        lines += [
            f"\n### `{path}`\n",
            f"{r['pixels']} pixels x {r['spp']} spp: {t:.2f} s, {r['rays'] / 1e6:.2f} M ray segments.\n",
            "| skip | with it | without it (or the work it avoids) | saves |",
            "| --- | --- | --- | ---: |",
        ]
        lines.append(
            f"| no transmitted branch into metal, blackbody, opaque | {r['sink_hits']:,} hits end there "
            f"({100 * r['sink_hits'] / r['rays']:.2g} % of segments) | a child each: {r['sink_child_s']:.2f} s at "
            f"{t * r['workers'] / r['rays'] * 1e6:.1f} us per segment (estimate) | {100 * r['sink_child_s'] / t:.0f} % |"
        )
        for a in r.get("atmosphere", []):
            lines.append(
                f"| no path-atmosphere work with `atmosphere: none`{a['label']} | none: {a['none_s']:.2f} s | "
                f"layered: {a['with_s']:.2f} s, of which {a['path_off_s']:.2f} s of {a['inproc_s']:.2f} s inside "
                f"`AtmosphereModel.path` (one process) | {100 * (a['with_s'] - a['none_s']) / a['with_s']:.0f} % "
                f"({100 * a['path_off_s'] / a['inproc_s']:.0f} % in `path`) |"
            )
            lines.append(
                f"| no path-atmosphere work on segments below the loss bound{a['label']} (skip length "
                f"{a['skip_length_m'] * 100:.2g} cm, tolerance 0.01 K) | {a['skip_on_s']:.2f} s; "
                f"{a['segments_on']:,} segments, {a['path_on_s']:.3f} s in `path` | {a['skip_off_s']:.2f} s; "
                f"{a['segments_off']:,}, {a['path_off_s']:.3f} s (images differ by {a['skip_max_diff_K']:.1e} K "
                f"at most, `termination: temperature`) | "
                f"{100 * (1 - a['segments_on'] / max(a['segments_off'], 1)):.0f} % of segments, "
                f"{a['path_off_s'] - a['path_on_s']:.3f} s |"
            )
        if "atmosphere" not in r:
            lines.append("| no path-atmosphere work | `atmosphere: none`: nothing to skip | | |")
        if "sky_rt_s" in r:
            lines.append(
                f"| sky from cached tables | {r['sky_rays']:,} sky rays: {r['sky_table_s'] * 1e3:.1f} ms | "
                f"per-ray radiative transfer: {r['sky_rt_s']:.2f} s | {100 * r['sky_rt_s'] / t:.0f} % of the render |"
            )
        else:
            lines.append(
                "| sky from cached tables | the sky is not the layered atmosphere's: closed form per ray | | |"
            )
        if "rough_on_s" in r:
            lines.append(
                f"| no roughness sampling on smooth surfaces | smooth: {r['rough_off_s']:.2f} s | every surface "
                f"nearly smooth, Blinn-Phong m = 1e6 (images differ by {r['rough_rms_diff_K']:.2g} K RMS, "
                f"{r['rough_max_diff_K']:.2g} K at most, where grazing rays meet the residual masking): "
                f"{r['rough_on_s']:.2f} s "
                f"| {100 * (r['rough_on_s'] - r['rough_off_s']) / r['rough_on_s']:.0f} % |"
            )
        lines.append(
            f"| no auxiliary channels unless asked (EXR channels made and written) | 12 channels: "
            f"{r['aux_off_s'] * 1e3:.0f} ms | + stderr (3), depth, material, samples: {r['aux_on_s'] * 1e3:.0f} ms | "
            f"{(r['aux_on_s'] - r['aux_off_s']) * 1e3:.0f} ms ({100 * (r['aux_on_s'] - r['aux_off_s']) / t:.0f} % of the render) |"
        )
        per_tile = r["build_s"] * r["tiles"]
        lines.append(
            f"| Embree scene built once per worker | {r['workers']} builds of {r['build_s'] * 1e3:.1f} ms | "
            f"one per tile: {r['tiles']} x = {per_tile:.2f} s of CPU | {100 * per_tile / (t * r['workers']):.0f} % |"
        )
        if "adaptive" in r:
            ad = r["adaptive"]
            lines += [
                "",
                f"Adaptive sampling at `target_error` = {ad['target_K']:g} K (0.1 x the imager noise), "
                f"`min_spp` {ad['min_spp']}, `spp` {ad['spp_cap']}: per pixel (stop at the target) and per PSF "
                f"footprint (stop at target x {ad['footprint_factor']:.1f} = target / sqrt(sum psf^2)), against the "
                "config's fixed spp. Errors against the reference of the scenario's section above.\n",
                "| rule | wall [s] | mean spp | pixels at min_spp | ideal RMS [K] | sensor RMS [K] | sensor max [K] |",
                "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
            ]
            for rule in ("fixed", "pixel", "footprint"):
                a = ad[rule]
                at_min = "-" if rule == "fixed" else f"{100 * a['at_min']:.0f} %"
                lines.append(
                    f"| {rule} | {a['wall_s']:.2f} | {a['mean_spp']:.2f} | {at_min} | "
                    f"{a['ideal_rms']:.3f} | {a['sensor_rms']:.3f} | {a['sensor_max']:.2f} |"
                )
    return "\n".join(lines) + "\n"
