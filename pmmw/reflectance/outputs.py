"""The files of a ``pmmw brdf`` run besides ``brdf.json``: ``brdf_<method>.exr`` (Stokes, DoP, AoP and
optionally Mueller maps), the polar maps ``brdf_<method>.png`` and the in-plane cut
``brdf_inplane.png`` (`pmmw.reflectance` docstring, "Outputs").
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pmmw.arrays import FloatArray
from pmmw.reflectance.grid import N_PHI, N_THETA, projected_solid_angle

if TYPE_CHECKING:
    from collections.abc import Mapping

    from pmmw.reflectance.command import MethodResult

__all__ = ["write_outputs"]


def _dop_aop(stokes: FloatArray) -> tuple[FloatArray, FloatArray]:
    i, q, u, v = stokes
    with np.errstate(divide="ignore", invalid="ignore"):
        dop = np.where(i > 0.0, np.sqrt(q * q + u * u + v * v) / np.where(i > 0.0, i, 1.0), 0.0)
    aop = 0.5 * np.degrees(np.arctan2(u, q))
    return dop, aop


def write_outputs(
    out: Path, results: dict[str, MethodResult], summary: dict, wi: np.ndarray, mueller: bool, plots: bool
) -> list[Path]:
    from pmmw.io.exr import write_exr

    files = []
    for meth, res in results.items():
        dop, aop = _dop_aop(res.stokes)
        channels = {
            "I": res.stokes[0],
            "Q": res.stokes[1],
            "U": res.stokes[2],
            "V": res.stokes[3],
            "DoP": dop,
            "AoP": aop,
        }
        if mueller:
            for a in range(4):
                for b in range(4):
                    channels[f"M{a}{b}"] = res.mueller[:, :, a, b]
        attrs = {
            "pmmw:brdf:method": meth,
            "pmmw:brdf:incidence_deg": summary["incidence_deg"],
            "pmmw:brdf:azimuth_deg": summary["azimuth_deg"],
            "pmmw:brdf:stokes_in": summary["stokes_in"],
            "pmmw:brdf:total_reflectance": res.summary["total_reflectance"],
            "pmmw:brdf:grid": "rows zenith 0..90 deg, columns azimuth 0..359 deg, 1 deg cells (Optics Express 2016)",
            "pmmw:brdf:units": "I Q U V M: BRDF [1/sr] for incident I = 1; DoP [-]; AoP [deg]",
        }
        path = out / f"brdf_{meth}.exr"
        write_exr(path, channels, attrs)
        files.append(path)
        if plots:
            path = out / f"brdf_{meth}.png"
            _plot_maps(path, res, f"{meth}: total reflectance {res.summary['total_reflectance']:.4f}")
            files.append(path)
    if plots:
        path = out / "brdf_inplane.png"
        _plot_inplane(path, results, wi)
        files.append(path)
    return files


def _plot_maps(path: Path, res: MethodResult, title: str) -> None:
    from pmmw.io.atomic import atomic_path
    from pmmw.io.preview import subplots

    dop, aop = _dop_aop(res.stokes)
    maps = [
        ("I [1/sr]", res.stokes[0], "viridis"),
        ("Q [1/sr]", res.stokes[1], "RdBu_r"),
        ("U [1/sr]", res.stokes[2], "RdBu_r"),
        ("V [1/sr]", res.stokes[3], "RdBu_r"),
        ("DoP", dop, "magma"),
        ("AoP [deg]", aop, "twilight"),
    ]
    th_edges = np.concatenate([[0.0], np.arange(N_THETA - 1) + 0.5, [90.0]])
    ph_edges = np.radians(np.arange(N_PHI + 1) - 0.5)
    fig, axes = subplots(2, 3, figsize=(12, 8), subplot_kw={"projection": "polar"})
    for ax, (name, data, cmap) in zip(axes.ravel(), maps):
        # colour limits from the 99.5th percentile: Monte Carlo cells near the pole and the
        # horizon have tiny projected solid angles and carry the largest noise
        lim = float(np.nanpercentile(np.abs(data[1:90]), 99.5)) or 1.0
        if cmap == "RdBu_r":
            kw = {"vmin": -lim, "vmax": lim}
        elif name.startswith("AoP"):
            kw = {"vmin": -90.0, "vmax": 90.0}
        else:
            kw = {"vmin": 0.0, "vmax": lim}
        pc = ax.pcolormesh(ph_edges, th_edges, data, cmap=cmap, shading="flat", **kw)
        ax.set_title(name)
        ax.set_ylim(0, 90)
        ax.set_yticks([30, 60, 90])
        ax.set_yticklabels([])
        fig.colorbar(pc, ax=ax, shrink=0.7)
    fig.suptitle(title)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=80, format="png")


def _plot_inplane(path: Path, results: Mapping[str, MethodResult], wi: FloatArray) -> None:
    from pmmw.io.atomic import atomic_path
    from pmmw.io.preview import subplots

    phi_s = round(math.degrees(math.atan2(-wi[1], -wi[0]))) % 360
    phi_b = (phi_s + 180) % 360
    fig, ax = subplots(figsize=(7, 4.5))
    proj = projected_solid_angle()
    theta = np.arange(N_THETA - 1)  # the horizon row holds the singular cos -> 0 cells

    def profile(i_map: FloatArray, col: int, smooth: bool) -> FloatArray:
        """Zenith profile at azimuth ``col``; Monte Carlo maps are averaged (projected solid
        angle weights) over +-2 degrees of azimuth, +-20 near the pole, all of row 0."""
        out = np.empty(theta.size)
        for r in theta:
            half: int = 0 if not smooth else (180 if r == 0 else max(2, 20 // int(r)))
            cols = np.arange(col - half, col + half + 1) % N_PHI
            w = proj[r, cols]
            out[r] = np.sum(i_map[r, cols] * w) / np.sum(w)
        return out

    x = np.concatenate([-theta[::-1], theta[1:]])
    for meth, res in results.items():
        i_map = res.stokes[0]
        smooth = meth == "mc"
        y = np.concatenate([profile(i_map, phi_b, smooth)[::-1], profile(i_map, phi_s, smooth)[1:]])
        ax.plot(x, y, label=f"{meth} I" + (" (azimuth-averaged cells)" if smooth else " (cell centres)"), lw=1.2)
    ax.set_xlabel(f"zenith angle in the plane of incidence [deg] (positive: azimuth {phi_s} deg, specular side)")
    ax.set_ylabel("BRDF I [1/sr]")
    ax.set_yscale("log")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90, format="png")
