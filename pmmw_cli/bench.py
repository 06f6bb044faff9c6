"""``pmmw bench``: run time against error, for each scenario and sampling strategy.

For each scenario (first frequency) a converged reference is made: analytic where one exists (an
isothermal scene reads its temperature everywhere), otherwise a high-sample render with the
seed's full splitting, a tiny threshold and extra depth, cached on disk by scenario hash. Then the
scenario is rendered at increasing samples per pixel with each strategy, recording wall time,
rays traced, the time spent in Embree for exactly those rays, and the RMS and max error [K] of the
ideal image and of the sensor image before noise (both images blurred by the imager's PSF).
Results go to a Markdown table and a log-log plot of error against time.
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from pmmw_cli import __version__
from pmmw_cli.imaging.imager import blur, psf_kernel
from pmmw_cli.io.atomic import save_npz_atomic, write_text_atomic
from pmmw_cli.pipeline import make_job, resolve, scenario_hash
from pmmw_cli.trace.pool import assemble, default_workers, render_tiles

STRATEGIES = ("split", "stochastic", "hybrid")
REFERENCE_THRESHOLD = 1e-6
REFERENCE_EXTRA_DEPTH = 4


def _render(job, workers):
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
        job.settings, spp=ref_spp, strategy="split", termination="temperature",
        threshold=REFERENCE_THRESHOLD, max_depth=job.settings.max_depth + REFERENCE_EXTRA_DEPTH, target_error=None,
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
        d = (a[..., :2] - b[..., :2])
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
        kb = int(next(l for l in Path("/proc/meminfo").read_text().splitlines() if l.startswith("MemTotal")).split()[1])
        mem = f", {kb / 2**20:.0f} GiB"
    except (OSError, StopIteration, ValueError):
        pass
    return f"{cpu}, {default_workers()} cores{mem}, {platform.system()} {platform.release()}, Python {platform.python_version()}"


def bench(scenarios, *, spp_list=(1, 2, 4, 8, 16, 32), strategies=STRATEGIES, ref_spp=256, workers=None,
          overrides=(), out_md=Path("docs/benchmarks.md"), cache_dir=Path(".pmmw-cache"), command=None,
          with_scaling=False, render_times=()):
    """Run the benchmark and write ``out_md`` and one plot per scenario beside it."""
    workers = workers or default_workers()
    sections, all_rows = [], {}
    for path in scenarios:
        res = resolve(path, overrides)
        scn = res.scenario
        f = scn.frequencies[0]
        job = make_job(res, f)
        shash = scenario_hash(scn)
        t0 = time.perf_counter()
        ref, ref_desc = reference(job, workers, Path(cache_dir), shash, ref_spp)
        t_ref = time.perf_counter() - t0
        kern = (psf_kernel(job.camera.pixel_angle, job.k0, scn.imager.aperture_diameter)
                if scn.imager.aperture_diameter > 0 else None)
        rows = []
        for strategy in strategies:
            for spp in spp_list:
                st = dataclasses.replace(job.settings, spp=spp, strategy=strategy, target_error=None)
                img, wall = _render(dataclasses.replace(job, settings=st), workers)
                rows.append({
                    "strategy": strategy, "spp": spp, "wall_s": wall, "rays": img.rays,
                    "isect_s": img.t_isect, "ratio": (wall * workers) / img.t_isect if img.t_isect > 0 else float("nan"),
                    **_errors(img.mean, ref, kern),
                })
                print(f"{scn.name} {strategy:10s} spp={spp:4d}: {wall:7.2f} s, {img.rays / 1e6:7.2f} M rays, "
                      f"ideal RMS {rows[-1]['ideal_rms']:.3f} K, sensor RMS {rows[-1]['sensor_rms']:.3f} K",
                      file=sys.stderr)
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
        "relative to the physical limit of this approach on this machine (1 would be pure Embree).\n"
    )
    if render_times:
        sections.append(_render_times_section(render_times, workers))
    if with_scaling:
        res_px, spp = (128, 128), 4
        sections.append(_scaling_section(scaling(resolution=res_px, spp=spp, workers=workers), res_px, spp))
    write_text_atomic(out_md, header + "\n".join(sections))
    write_text_atomic(out_md.with_suffix(".json"), json.dumps(all_rows, indent=2))
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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=110)
    for strategy in dict.fromkeys(r["strategy"] for r in rows):
        rs = [r for r in rows if r["strategy"] == strategy]
        ax.loglog([r["wall_s"] for r in rs], [max(r["ideal_rms"], 1e-6) for r in rs], "o-", label=f"{strategy}: ideal")
        ax.loglog([r["wall_s"] for r in rs], [max(r["sensor_rms"], 1e-6) for r in rs], "s--", label=f"{strategy}: sensor")
    if noise > 0:
        ax.axhline(0.1 * noise, color="grey", lw=0.8, ls=":", label="0.1 x imager noise")
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("RMS error of Ex2, Ey2 [K]")
    ax.set_title(f"{name}: error against run time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp-{os.getpid()}.png")
    fig.savefig(tmp)
    plt.close(fig)
    os.replace(tmp, path)


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

    from pmmw_cli.scene.camera import Camera
    from pmmw_cli.scene.sky import UniformSky
    from pmmw_cli.trace.intersect import make_intersector
    from pmmw_cli.trace.job import Media, RenderSettings, TraceJob

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
        k0 = 2 * np.pi * 35e9 / 299_792_458.0
        eps = np.array([1 + 0j, 2.5 + 0.6j, 3.9 + 0.56j])
        media = Media(["ambient", "ball", "ground"], eps, np.zeros(3, np.int8), np.array([290.0, 300.0, 300.0]),
                      np.array([0.0, *(2 * k0 * np.sqrt(eps[1:]).imag)]), (None, None, None))
        cam = Camera.look_at([0, 0, 1.5], [0, 4, 1.2], [0, 0, 1], np.radians(40), resolution)
        job = TraceJob(verts, faces, normals, fmed, media, cam, UniformSky(30.0, 290.0), 35e9,
                       RenderSettings(spp=spp, max_depth=6, threshold=1e-3, tile=64))
        t0 = time.perf_counter()
        make_intersector(verts, faces)
        build = time.perf_counter() - t0
        img, wall = _render(job, workers)
        rows.append({"triangles": int(len(faces)), "build_s": build, "wall_s": wall, "isect_s": img.t_isect,
                     "rays": img.rays})
        print(f"scaling: {len(faces):9d} triangles: build {build:.2f} s, render {wall:.2f} s, "
              f"Embree {img.t_isect:.2f} s", file=sys.stderr)
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
        lines.append(f"| {r['triangles']:,} | {r['build_s']:.2f} | {r['wall_s']:.2f} | {r['isect_s']:.2f} | "
                     f"{r['rays'] / 1e6:.2f} | {r['wall_s'] * w / r['rays'] * 1e6:.2f} |")
    return "\n".join(lines) + "\n"


def _render_times_section(configs, workers):
    """Wall time of each shipped scenario rendered as shipped (full resolution, its defaults)."""
    import tempfile

    from pmmw_cli.pipeline import render

    lines = ["\n## Shipped scenarios at full resolution\n",
             f"`pmmw render CONFIG` with the config's own settings, {workers} workers; wall time of the whole "
             "command including scene loading, Embree builds, the imager model and writing the files.\n",
             "| config | pixels | spp | wall [s] |", "| --- | ---: | ---: | ---: |"]
    for path in configs:
        res = resolve(path)
        scn = res.scenario
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            render(path, out=Path(tmp), workers=workers, quiet=True)
            wall = time.perf_counter() - t0
        w, h = scn.imager.resolution
        lines.append(f"| `{path}` | {w} x {h} | {scn.render.spp} | {wall:.1f} |")
    return "\n".join(lines) + "\n"
