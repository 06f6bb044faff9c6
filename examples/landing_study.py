"""The landing approach with the Python API: at what slant range does the runway beacon stand out?

Murakowski 2014 sec. 3.1: a passive imager on the 4-degree glide slope looks at the threshold,
where 1 m metal plates tilted toward the approach mirror the cold sky. Here: 2000 m and 500 m,
35 and 95 GHz, in Table 3.2's "cloudy" weather (no fog layer); the full study, with fog, is
`pmmw sweep configs/landing_trade.yaml`, whose table these numbers match.

    python examples/landing_study.py [OUT_DIR]     # prints the table, writes landing_study.png
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import pmmw

ROOT = Path(__file__).resolve().parent.parent
out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "out" / "examples"

base = pmmw.Scenario.load(ROOT / "configs" / "landing_95ghz.yaml").set({"atmosphere.layers": []})
ranges = {2000: ([0, -1995.13, 139.52], 1), 500: ([0, -498.78, 34.88], 3)}  # position [m], beacon radius [px]

rows, images = [], {}
for rng, (position, radius) in ranges.items():
    scn = base.set({"imager.position": position, "output.regions.beacon.radius": radius,
                    "frequency": ["35 GHz", "95 GHz"]})
    ds = pmmw.render(scn)  # one Dataset, both frequencies
    for f in ds.frequency.values:
        c = ds.attrs["regions"][f"{f / 1e9:g} GHz"]["contrasts"]["beacon - runway"]["I"]
        rows.append((rng, f / 1e9, c["K"], c["sigma"]))
        images[(rng, f / 1e9)] = ds["I"].sel(frequency=f)

print(f"{'range [m]':>9} {'f [GHz]':>7} {'beacon - runway I [K]':>22} {'[noise sigma]':>14}")
for rng, f, k, sigma in rows:
    print(f"{rng:9d} {f:7g} {k:22.2f} {sigma:14.1f}" + ("  <- visible (3 sigma)" if abs(sigma) >= 3 else ""))

fig, axes = plt.subplots(2, 2, figsize=(8, 8), dpi=80)
for ax, ((rng, f), img) in zip(axes.ravel(), images.items()):
    shown = ax.imshow(img, cmap="gray", interpolation="nearest")
    ax.set_title(f"{rng} m, {f:g} GHz", fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])
    fig.colorbar(shown, ax=ax, fraction=0.046).set_label("Stokes I [K]", fontsize=8)
fig.suptitle("Landing approach: Stokes I (Ex2 + Ey2) after the imager")
out.mkdir(parents=True, exist_ok=True)
fig.savefig(out / "landing_study.png")
print(f"wrote {out / 'landing_study.png'}")
