"""`pmmw bench --po`: the physical-optics far field, direct sum against octree, in time and error.

Targets are metal spheres 20 wavelengths in radius, meshed ever finer (facets 1e3..1e6), and one
of 100 wavelengths with 1.3e6 facets, lit by one plane wave; observation grids of 1e2..1e5
directions cover the sphere. Each cell
times the octree on the whole grid and the direct sum on at most `DIRECT_SAMPLE` of its
directions (the direct sum is exactly linear in the directions: its time is scaled up, which the
table marks), and the error is the octree's largest deviation from the direct sum on those
directions, relative to the pattern's peak.
"""

from __future__ import annotations

import itertools
import math
import platform
import time
from pathlib import Path

import numpy as np
import trimesh

from pmmw.io.atomic import write_text_atomic
from pmmw.physical_optics import solver
from pmmw.physical_optics.octree import far_field_octree

FREQUENCY = 95e9
DIRECT_SAMPLE = 900


def _target(radius: float, subdivisions: int) -> solver.Target:
    from pmmw.scene.materials import MaterialDB

    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return solver.make_target(m.vertices, m.faces, np.zeros(len(m.faces), int), ["metal"], MaterialDB.load(), FREQUENCY)


def _grid(n: int):
    """About n directions on a theta x phi grid over the sphere."""
    nt = max(2, int(round(math.sqrt(n / 2.0))))
    th = np.linspace(0.0, math.pi, nt)
    ph = np.linspace(0.0, 2 * math.pi, 2 * nt, endpoint=False)
    tt, pp = np.meshgrid(th, ph, indexing="ij")
    return tt.ravel(), pp.ravel()


# (radius [wavelengths], icosphere subdivisions, directions)
CASES = [(20.0, sub, d) for sub in (3, 5, 7, 8) for d in (100, 1000, 10000, 100000)] + [(100.0, 8, 100000)]


def run(out_md: Path, cases=CASES, command: str = "pmmw bench --po") -> Path:
    k0 = 2 * math.pi * FREQUENCY / solver.C0
    lam = solver.C0 / FREQUENCY
    rows = []
    for (rw, sub), group in itertools.groupby(cases, key=lambda c: c[:2]):
        target = _target(rw * lam, sub)
        d_inc, e_inc = solver.incident(0.3, 0.2, "theta")
        t0 = time.perf_counter()
        lit, J, M = solver.currents(target, d_inc, e_inc, k0)
        t_cur = time.perf_counter() - t0
        for _, _, n in group:
            tt, pp = _grid(n)
            t0 = time.perf_counter()
            ot, op = far_field_octree(target, lit, J, M, -d_inc, k0, tt, pp)
            t_oct = time.perf_counter() - t0
            pick = np.linspace(0, tt.size - 1, min(tt.size, DIRECT_SAMPLE)).round().astype(int)
            t0 = time.perf_counter()
            dt, dp = solver.far_field(target, lit, J, M, -d_inc, k0, tt[pick], pp[pick])
            t_dir = (time.perf_counter() - t0) * tt.size / pick.size
            peak = max(np.abs(dt).max(), np.abs(dp).max())
            err = max(np.abs(ot[pick] - dt).max(), np.abs(op[pick] - dp).max()) / peak
            rows.append((len(target.faces), int(lit.sum()), rw, tt.size, t_cur, t_dir, pick.size < tt.size, t_oct, err))
            print(
                f"bench --po: {len(target.faces)} facets, {rw:g} wavelengths, {tt.size} directions: "
                f"currents {t_cur:.2f} s, direct {t_dir:.2f} s, octree {t_oct:.2f} s, error {err:.1e}",
                flush=True,
            )
    lines = [
        "# Physical optics: direct sum against octree",
        "",
        f"Machine: {platform.machine()}, {platform.processor() or platform.system()}, "
        f"{__import__('os').cpu_count()} cores; command: `{command}`.",
        "",
        f"Metal spheres at {FREQUENCY / 1e9:g} GHz, one plane wave; directions on a theta x phi grid over the "
        f"sphere. The direct sum is timed on at most {DIRECT_SAMPLE} directions and scaled (marked *): it is "
        "linear in them. Error: the octree's largest deviation from the direct sum, relative to the peak.",
        "",
        "Both sums run compiled (numba) on all cores; 'currents' is the shadow test (Embree) and the "
        "currents of the lit facets, shared by both methods.",
        "",
        "| facets (lit) | radius [wavelengths] | directions | currents [s] | direct [s] | octree [s] "
        "| direct / octree | error |",
        "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for f, lit, rw, d, t_cur, t_dir, scaled, t_oct, err in rows:
        lines.append(
            f"| {f} ({lit}) | {rw:g} | {d} | {t_cur:.2f} | {t_dir:.2f}{'*' if scaled else ''} "
            f"| {t_oct:.2f} | {t_dir / t_oct:.2f} | {err:.1e} |"
        )
    png = _plot(rows, out_md.with_suffix(".png"))
    lines += ["", f"![time against directions]({png.name})"]
    return write_text_atomic(out_md, "\n".join(lines) + "\n")


def _plot(rows, path: Path) -> Path:
    """Time against directions, both methods, one colour per target."""
    from pmmw.io.preview import save_figure, subplots

    fig, ax = subplots(figsize=(6.8, 4.4), dpi=110)
    targets = list(dict.fromkeys((f, rw) for f, _, rw, *_ in rows))
    for i, (f, rw) in enumerate(targets):
        sel = sorted((r for r in rows if (r[0], r[2]) == (f, rw)), key=lambda r: r[3])
        d = [r[3] for r in sel]
        label = f"{f:,} facets, {rw:g} wavelengths"
        ax.loglog(d, [r[5] for r in sel], "--", color=f"C{i}", marker="o", label=f"direct: {label}")
        ax.loglog(d, [r[7] for r in sel], "-", color=f"C{i}", marker="s", label=f"octree: {label}")
    ax.axhline(60.0, color="k", lw=0.8, ls=":", label="1 minute")
    ax.set_xlabel("observation directions")
    ax.set_ylabel("far-field time [s] (2 cores)")
    ax.set_title(f"Physical optics far field at {FREQUENCY / 1e9:g} GHz: direct sum against octree")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6)
    fig.tight_layout()
    save_figure(fig, path)
    return path
