"""The figures of docs/guide/physical-optics.md: `python docs/po/make_plots.py` from the
repository root (needs the test extras: miepython for the Mie series)."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from pmmw.physical_optics import solver  # noqa: E402
from pmmw.physical_optics.command import load_target  # noqa: E402
from tests.physical_optics.po_refs import sphere_bistatic_rcs  # noqa: E402

HERE = Path(__file__).resolve().parent
C0 = 299_792_458.0


def plate():
    mesh = HERE / "plate_1m.ply"
    v = [[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]]
    trimesh.Trimesh(vertices=v, faces=[[0, 1, 2], [0, 2, 3]], process=False).export(mesh)
    for f in (35, 95):
        subprocess.run(
            [
                "pmmw",
                "po",
                str(mesh),
                "--material",
                "metal",
                "--frequency",
                f"{f} GHz",
                "--monostatic",
                "--theta",
                "0:5:0.005",
                "--format",
                "csv",
                "--plot",
                str(HERE / f"plate_1m_{f}ghz_monostatic.png"),
            ],
            check=True,
            stdout=subprocess.DEVNULL,
        )


def sphere():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = 95e9
    lam = C0 / f
    k0 = 2 * np.pi / lam
    radius = 50 / k0
    mesh = HERE / "sphere_ka50.ply"
    trimesh.creation.icosphere(subdivisions=5, radius=radius).export(mesh)
    target = load_target(mesh, "metal", None, f)
    theta = np.radians(np.linspace(0.0, 180.0, 721))
    s_t, s_p, _ = solver.bistatic(target, k0, 0.0, 0.0, "theta", theta, np.zeros_like(theta))
    m_t, m_p = sphere_bistatic_rcs(radius, lam, None, np.degrees(theta), 0.0)
    fig, ax = plt.subplots(figsize=(7.0, 4.4), dpi=110)
    ax.plot(np.degrees(theta), 10 * np.log10(m_t + m_p), "k-", lw=1.5, label="Mie series (exact)")
    ax.plot(np.degrees(theta), 10 * np.log10(s_t + s_p), "C1-", lw=1, label="pmmw po (20480 facets)")
    ax.set_xlabel("observation theta [deg] (0 = backscatter)")
    ax.set_ylabel("bistatic RCS [dBsm]")
    ax.set_title(f"PEC sphere, ka = 50 (radius {radius * 1e3:.1f} mm), 95 GHz, E-plane")
    ax.set_ylim(-45, 20)
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(HERE / "sphere_ka50_vs_mie.png")
    mesh.unlink()


if __name__ == "__main__":
    plate()
    sphere()
