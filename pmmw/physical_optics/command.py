"""`pmmw po`: bistatic and monostatic radar cross sections of a mesh (physical optics).

Options are parsed and checked here (every bad value is a `UserError` naming the option); the
physics is `pmmw.physical_optics.solver`.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pmmw.errors import UserError
from pmmw.io.atomic import write_text_atomic
from pmmw.io.preview import save_figure
from pmmw.memory import check_fits
from pmmw.physical_optics import solver

CSV_HEADER = "theta_deg,phi_deg,rcs_theta_m2,rcs_phi_m2"
MAX_DIRECTIONS = 1_000_000


def _floats(text: str, option: str, count: int | None = None, example: str = "30,0") -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        values = []
    if not values or (count is not None and len(values) != count) or not all(math.isfinite(v) for v in values):
        n = f"{count} " if count else ""
        raise UserError(f"expected {n}comma-separated angles in degrees like {example}, got {text!r}", option)
    return values


def parse_incidence(text: str) -> tuple[float, float]:
    """``"THETA,PHI"`` [deg] -> (theta, phi) [rad]; theta in [0, 180]."""
    th, ph = _floats(text, "--incidence", 2)
    if not 0.0 <= th <= 180.0:
        raise UserError(f"theta must be within 0..180 deg, got {th:g}", "--incidence")
    return math.radians(th), math.radians(ph)


def parse_theta(text: str, option: str = "--theta", lo: float = 0.0, hi: float = 180.0) -> np.ndarray:
    """``"START:STOP:STEP"`` [deg] (STOP included when the steps land on it), or one angle."""
    parts = text.split(":")
    try:
        nums = [float(p) for p in parts]
    except ValueError:
        nums = []
    if len(nums) not in (1, 3) or not all(math.isfinite(v) for v in nums):
        raise UserError(f"expected START:STOP:STEP in degrees like 0:180:1 (or one angle), got {text!r}", option)
    if len(nums) == 1:
        values = np.array(nums)
    else:
        start, stop, step = nums
        if step <= 0.0:
            raise UserError(f"the step must be > 0 deg, got {step:g}", option)
        count = int(math.floor((stop - start) / step + 1e-9)) + 1
        if count < 1:
            raise UserError(f"no angle from {start:g} to {stop:g} deg (STOP must be >= START)", option)
        if count > MAX_DIRECTIONS:
            raise UserError(f"{count} angles; at most {MAX_DIRECTIONS}", option)
        values = start + step * np.arange(count)
    if values.min() < lo or values.max() > hi:
        raise UserError(f"angles must lie within {lo:g}..{hi:g} deg", option)
    return np.radians(values)


def parse_phi(text: str, option: str = "--phi") -> np.ndarray:
    """``"P1,P2,..."`` or ``"START:STOP:STEP"`` [deg] -> [rad]."""
    if ":" in text:
        return parse_theta(text, option=option, lo=-360.0, hi=720.0)
    return np.radians(_floats(text, option, None, "0,90"))


@dataclass
class Result:
    theta: np.ndarray  # (D,) [rad], every direction of the grid
    phi: np.ndarray
    rcs_theta: np.ndarray  # [m^2]
    rcs_phi: np.ndarray
    summary: dict
    axes: tuple | None = None  # (thetas, phis) [rad] of the grid, when the run knows them


def load_target(mesh: Path, material: str | None, eps: str | None, f: float) -> solver.Target:
    """The mesh with one material: a database id or a permittivity."""
    from pmmw.reflectance import parse_complex
    from pmmw.scene.geometry import load_entry_mesh
    from pmmw.scene.materials import MaterialDB

    if (material is None) == (eps is None):
        raise UserError("give exactly one of --material ID or --eps EPS", "--material")
    db = MaterialDB.load()
    if eps is not None:
        value = parse_complex(eps, file="--eps")
        if not (np.isfinite(value.real) and np.isfinite(value.imag)) or value.imag < 0.0:
            raise UserError(f"expected a finite permittivity with eps'' >= 0 (lossy), got {eps!r}", "--eps")
        material = "po_eps"
        db = db.with_overrides({material: {"eps": [value.real, value.imag]}}, file="--eps")
    else:
        mat = db.get(material, file="--material")
        if mat.roughness is not None or mat.bump is not None:
            from pmmw.errors import warn

            warn(f"material {material!r} is rough; physical optics takes its surface as smooth")
    parts = load_entry_mesh(mesh)
    verts, faces, off = [], [], 0
    for _, m in parts:
        verts.append(np.asarray(m.vertices, float))
        faces.append(np.asarray(m.faces, np.int64) + off)
        off += len(m.vertices)
    faces_all = np.concatenate(faces)
    return solver.make_target(np.concatenate(verts), faces_all, np.zeros(len(faces_all), int), [material], db, f)


MAX_BOUNCES = 16
METHODS = ("auto", "direct", "octree")


def run_po(
    mesh,
    *,
    material=None,
    eps=None,
    frequency: float,
    incidence: str,
    polarization="theta",
    theta=None,
    phi=None,
    monostatic=False,
    bounces=1,
    method="auto",
    tube=None,
    force=False,
) -> Result:
    """The ``pmmw po`` job; see the command's help. ``tube``: ray-tube side [m] for bounces > 1
    (default a quarter wavelength); ``force``: solve past the memory check (`compute`)."""
    if polarization not in ("theta", "phi"):
        raise UserError(f"expected theta or phi, got {polarization!r}", "--polarization")
    if not 1 <= bounces <= MAX_BOUNCES:
        raise UserError(f"expected 1 to {MAX_BOUNCES} bounces, got {bounces}", "--bounces")
    if tube is not None and not (math.isfinite(tube) and tube > 0.0):
        raise UserError(f"the ray-tube side must be a length > 0, got {tube!r}", "--tube")
    if method not in METHODS:
        raise UserError(f"expected one of {', '.join(METHODS)}, got {method!r}", "--method")
    th_i, ph_i = parse_incidence(incidence)
    thetas = parse_theta(theta) if theta is not None else np.radians(np.arange(0.0, 180.5, 1.0))
    phis = parse_phi(phi) if phi is not None else np.array([ph_i])
    tt, pp = grid(thetas, phis)
    t0 = time.perf_counter()
    target = load_target(Path(mesh), material, eps, frequency)
    res = compute(
        target,
        frequency,
        th_i,
        ph_i,
        polarization,
        tt,
        pp,
        monostatic=monostatic,
        bounces=bounces,
        method=method,
        tube=tube,
        t0=t0,
        force=force,
        source=mesh,
    )
    res.axes = (thetas, phis)
    return res


def grid(thetas, phis):
    """Flat (theta, phi) [rad] of every phi cut in theta order; refused beyond MAX_DIRECTIONS."""
    if thetas.size * phis.size > MAX_DIRECTIONS:
        raise UserError(f"{thetas.size * phis.size} directions; at most {MAX_DIRECTIONS}", "--theta")
    pp, tt = np.meshgrid(phis, thetas, indexing="ij")
    return tt.ravel(), pp.ravel()


# Memory of a solve [bytes], beyond the mesh already read: measured peaks (1e6- and 2e5-facet
# plates at 10 GHz) with a margin.
SOLVE_BASE_BYTES = 150e6  # the kernels' threads and buffers, Embree's library (72 MB measured)
# Embree's scene and the intersector's arrays, lit facets, normals, the currents J, M and their
# temporaries (614 measured)
SOLVE_BYTES_PER_FACET = 1000
SOLVE_BYTES_PER_DIRECTION = 2500  # angles, far field, the rows written (1530 measured with JSON)
SOLVE_BYTES_PER_TUBE = 1500  # a ray tube's field, side vectors, hit and reflection (520 measured, a plate)


def memory_estimate(
    target,
    k0: float,
    directions: int,
    *,
    method: str = "auto",
    bounces: int = 1,
    tube: float | None = None,
    monostatic: bool = False,
) -> float:
    """Peak memory [bytes] of `compute` beyond the loaded ``target``, before it solves anything.

    The facets' terms (`SOLVE_BYTES_PER_FACET`, all facets counted lit), the directions'
    (`SOLVE_BYTES_PER_DIRECTION`), the octree's patterns when the method is or may be ``octree``
    (`octree.memory_bytes`: they grow with the target's size in wavelengths squared, so with the
    frequency), and for ``bounces`` > 1 the ray tubes of side ``tube`` [m] (default a quarter
    wavelength) over the target's disc (`SOLVE_BYTES_PER_TUBE`).
    """
    facets = len(target.faces)
    need = SOLVE_BASE_BYTES + SOLVE_BYTES_PER_FACET * facets + SOLVE_BYTES_PER_DIRECTION * directions
    if not monostatic:  # a monostatic solve is one direction at a time: the direct sum
        d = directions + 1  # the backscatter rides along
        octree = method == "octree" or (
            method == "auto" and d >= solver.OCTREE_DIRECTIONS and float(facets) * d >= solver.OCTREE_TERMS
        )
        if octree and facets:
            from pmmw.physical_optics.octree import memory_bytes

            need += memory_bytes(target.tri, k0, d)
    if bounces > 1 and facets:
        from pmmw.physical_optics.sbr import MAX_TUBES  # more are refused by `sbr.tube_grid`

        side = tube or np.pi / (2.0 * k0)  # a quarter wavelength
        lo, hi = target.vertices.min(axis=0), target.vertices.max(axis=0)
        n = math.ceil((float(np.linalg.norm(hi - lo)) / 2.0 + side) / side)
        need += SOLVE_BYTES_PER_TUBE * min((2 * n + 1) ** 2, MAX_TUBES)
    return need


def compute(
    target,
    frequency,
    th_i,
    ph_i,
    polarization,
    tt,
    pp,
    *,
    monostatic=False,
    bounces=1,
    method="auto",
    tube=None,
    t0=None,
    force=False,
    source=None,
) -> Result:
    """RCS of ``target`` at ``frequency`` [Hz] on the directions (tt, pp) [rad].

    Before solving, its memory (`memory_estimate`) is checked against the memory available: more
    is refused (a `UserError` located at ``source``, the mesh or job file) unless ``force``.
    """
    t0 = time.perf_counter() if t0 is None else t0
    k0 = 2.0 * np.pi * frequency / solver.C0
    need = memory_estimate(target, k0, tt.size, method=method, bounces=bounces, tube=tube, monostatic=monostatic)
    check_fits(
        need,
        f"physical optics of {len(target.faces)} facets toward {tt.size} directions at {frequency / 1e9:g} GHz",
        file=source,
        force=force,
        option="--force",
        remedy="fewer directions (--theta, --phi), a coarser mesh or a lower frequency"
        + (", or --method direct" if not monostatic and method != "direct" else ""),
    )
    if monostatic:
        s_t, s_p, n_lit = solver.monostatic(target, k0, polarization, tt, pp, bounces, tube)
        back = None
        lit = int(n_lit.max(initial=0))
        if lit == 0:
            raise UserError("no facet is lit from any of the directions", "--theta")
    else:
        # the backscatter direction rides along as one more observation direction
        s_t, s_p, lit = solver.bistatic(
            target, k0, th_i, ph_i, polarization, np.append(tt, th_i), np.append(pp, ph_i), bounces, tube, method
        )
        if lit == 0:
            raise UserError("no facet of the mesh is lit from this direction", "--incidence")
        back = float(s_t[-1] + s_p[-1])
        s_t, s_p = s_t[:-1], s_p[:-1]
    total = s_t + s_p
    peak = int(np.argmax(total))
    summary = {
        "frequency_hz": float(frequency),
        "wavelength_m": solver.C0 / frequency,
        "incidence_deg": [math.degrees(th_i), math.degrees(ph_i)],
        "polarization": polarization,
        "monostatic": bool(monostatic),
        "method": method,
        "bounces": bounces,
        "facets": int(len(target.faces)),
        "facets_lit": lit,
        "backscatter_rcs_m2": back if back is not None else None,
        "peak": {
            "theta_deg": math.degrees(tt[peak]),
            "phi_deg": math.degrees(pp[peak]),
            "rcs_m2": float(total[peak]),
            "rcs_dBsm": _dbsm(total[peak]),
        },
        "time_s": round(time.perf_counter() - t0, 3),
    }
    if monostatic:
        summary.pop("incidence_deg")
    return Result(tt, pp, s_t, s_p, summary)


def _dbsm(x):
    return float(10.0 * np.log10(max(float(x), 1e-30)))


def dbsm_text(x: float, width: int = 0, digits: int = 3) -> str:
    """An RCS [m^2] in dBsm for a table: ``-inf`` for an exact zero (a cross-polarized return of
    a flat plate, say), not the floor of `_dbsm`'s logarithm."""
    if not float(x) > 0.0:
        return f"{'-inf':>{width}}"
    return f"{10.0 * math.log10(float(x)):{width}.{digits}f}"


def format_rows(res: Result, fmt: str) -> str:
    rows = [
        (math.degrees(t), math.degrees(p), a, b) for t, p, a, b in zip(res.theta, res.phi, res.rcs_theta, res.rcs_phi)
    ]
    if fmt == "csv":
        return "\n".join([CSV_HEADER] + [f"{t:.6g},{p:.6g},{a:.9g},{b:.9g}" for t, p, a, b in rows])
    if fmt == "json":
        return json.dumps(
            {
                **res.summary,
                "rows": [{"theta_deg": t, "phi_deg": p, "rcs_theta_m2": a, "rcs_phi_m2": b} for t, p, a, b in rows],
            },
            indent=2,
        )
    if fmt == "table":
        s = res.summary
        head = [
            f"{s['frequency_hz'] / 1e9:g} GHz, {s['polarization']} polarization, "
            + (
                "monostatic"
                if s["monostatic"]
                else f"incidence theta {s['incidence_deg'][0]:g} deg, phi {s['incidence_deg'][1]:g} deg"
            )
            + f"; {s['facets_lit']} of {s['facets']} facets lit; {s['time_s']:.2f} s"
        ]
        if s["backscatter_rcs_m2"] is not None:
            head.append(
                f"backscatter {s['backscatter_rcs_m2']:.4g} m^2 ({dbsm_text(s['backscatter_rcs_m2'], 0, 2)} dBsm)"
            )
        p = s["peak"]
        head.append(
            f"peak {p['rcs_m2']:.4g} m^2 ({dbsm_text(p['rcs_m2'], 0, 2)} dBsm) at theta {p['theta_deg']:g}, "
            f"phi {p['phi_deg']:g} deg"
        )
        lines = [f"{'theta_deg':>9} {'phi_deg':>8} {'rcs_theta_dBsm':>15} {'rcs_phi_dBsm':>13}"]
        lines += [f"{t:9.3f} {p_:8.3f} {dbsm_text(a, 15)} {dbsm_text(b, 13)}" for t, p_, a, b in rows]
        return "\n".join(head + lines)
    raise UserError(f"expected csv, json or table, got {fmt!r}", "--format")


def write_outputs(res: Result, out: Path, stem: str = "po") -> list[Path]:
    """``<stem>.csv`` and ``<stem>.json`` in ``out``, atomically."""
    return [
        write_text_atomic(out / f"{stem}.csv", format_rows(res, "csv") + "\n"),
        write_text_atomic(out / f"{stem}.json", format_rows(res, "json") + "\n"),
    ]


def write_map(res: Result, thetas, phis, path: Path) -> Path:
    """An EXR of the RCS [m^2] over the grid: rows theta, columns phi (channels rcs_theta,
    rcs_phi), angles in the header."""
    from pmmw.io.exr import write_exr

    shape = (phis.size, thetas.size)
    attrs = {
        "pmmw:units": "m^2 (bistatic RCS)",
        "pmmw:frequency_hz": res.summary["frequency_hz"],
        "pmmw:theta_deg": f"{math.degrees(thetas[0]):g}:{math.degrees(thetas[-1]):g}:{thetas.size}",
        "pmmw:phi_deg": f"{math.degrees(phis[0]):g}:{math.degrees(phis[-1]):g}:{phis.size}",
        "pmmw:polarization": res.summary["polarization"],
    }
    write_exr(
        path,
        {
            "rcs_theta": res.rcs_theta.reshape(shape).T.astype(np.float32),
            "rcs_phi": res.rcs_phi.reshape(shape).T.astype(np.float32),
        },
        attrs,
    )
    return path


def write_plot(res: Result, path: Path, mesh_name: str) -> Path:
    """RCS in dBsm against theta, one line per phi cut and polarization."""
    from pmmw.io.preview import subplots

    s = res.summary
    fig, ax = subplots(figsize=(7.0, 4.4), dpi=110)
    thetas, phis = np.unique(res.theta), np.unique(res.phi)
    # x: theta, one line per phi cut; an azimuth cut (one theta) runs along phi instead
    along, across, x_name = (
        (res.phi, res.theta, "phi") if thetas.size == 1 and phis.size > 1 else (res.theta, res.phi, "theta")
    )
    cuts = np.unique(across)
    if cuts.size > 8:  # a full grid: the 8 cuts nearest evenly spread values
        cuts = cuts[np.linspace(0, cuts.size - 1, 8).round().astype(int)]
    for c in cuts:
        sel = across == c
        for comp, name, style in ((res.rcs_theta, "theta", "-"), (res.rcs_phi, "phi", "--")):
            if comp[sel].max() > 1e-12 * s["peak"]["rcs_m2"]:
                cut = f"{'phi' if x_name == 'theta' else 'theta'} {math.degrees(c):g} deg, " if cuts.size > 1 else ""
                ax.plot(
                    np.degrees(along[sel]),
                    10 * np.log10(np.maximum(comp[sel], 1e-30)),
                    style,
                    label=f"{cut}sigma_{name}",
                )
    ax.set_xlabel(f"{x_name} [deg]")
    mode = "monostatic" if s["monostatic"] else f"incidence ({s['incidence_deg'][0]:g}, {s['incidence_deg'][1]:g}) deg"
    ax.set_title(f"{mesh_name}: {s['frequency_hz'] / 1e9:g} GHz, {s['polarization']} polarization, {mode}")
    ax.set_ylabel("RCS [dBsm]")
    peak = s["peak"]["rcs_dBsm"]
    ax.set_ylim(peak - 60.0, peak + 5.0)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path)
    return path


def full_sphere(thetas, phis) -> bool:
    """Whether the grid axes [rad] cover the whole sphere (then an EXR map is written)."""
    return (
        thetas.size > 1
        and phis.size > 1
        and thetas.min() <= 1e-9
        and thetas.max() >= math.pi - 1e-9
        and phis.max() - phis.min() >= 2 * math.pi * (1 - 1.0 / phis.size) - 1e-9
    )


def write_run(res: Result, out: Path, stem: str, name: str, thetas, phis, plot: bool = True) -> list[Path]:
    """One run's files in ``out``: ``<stem>.csv``, ``.json``, the plot ``.png`` (when ``plot``)
    and, for a grid over the whole sphere, the ``.exr`` map."""
    written = write_outputs(res, out, stem)
    if plot:
        written.append(write_plot(res, out / f"{stem}.png", name))
    if full_sphere(thetas, phis):
        written.append(write_map(res, thetas, phis, out / f"{stem}.exr"))
    return written


def write_report(out: Path, name: str, source: str, runs, observation: str, plots: bool) -> Path:
    """``out/report.md`` of runs [(stem, Result)]: settings, then each run's backscatter and peak."""
    s0 = runs[0][1].summary
    mode = (
        "monostatic"
        if s0["monostatic"]
        else (f"incidence theta {s0['incidence_deg'][0]:g} deg, phi {s0['incidence_deg'][1]:g} deg")
    )
    lines = [
        f"# {name}: physical optics",
        "",
        f"- source: `{source}`",
        f"- {mode}; bounces {s0['bounces']}; method {s0['method']}",
        f"- observation: {observation}",
        "",
        "| run | frequency [GHz] | polarization | facets lit | backscatter [dBsm] | peak [dBsm] "
        "| peak at (theta, phi) [deg] | time [s] |",
        "| --- | ---: | --- | ---: | ---: | ---: | --- | ---: |",
    ]
    for stem, res in runs:
        s = res.summary
        back = "" if s["backscatter_rcs_m2"] is None else dbsm_text(s["backscatter_rcs_m2"], 0, 2)
        p = s["peak"]
        lines.append(
            f"| {stem} | {s['frequency_hz'] / 1e9:g} | {s['polarization']} | {s['facets_lit']} / "
            f"{s['facets']} | {back} | {p['rcs_dBsm']:.2f} | ({p['theta_deg']:g}, {p['phi_deg']:g}) "
            f"| {s['time_s']:.2f} |"
        )
    if plots:
        lines.append("")
        lines += [f"![{stem}]({stem}.png)" for stem, _ in runs]
    return write_text_atomic(out / "report.md", "\n".join(lines) + "\n")
