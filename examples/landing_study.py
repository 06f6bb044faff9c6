"""The landing approach with the Python API: at what slant range is one runway beacon detectable?

Murakowski 2014 sec. 3.1: a passive imager on the 4-degree glide slope looks at the threshold,
where 1 m metal plates tilted toward the approach mirror the cold sky. Here: the middle beacon
across the threshold against the runway, from 2000 m and 500 m, at 35 and 95 GHz, in Table 3.2's
"cloudy" weather (no fog layer), judged by the reports' one detection criterion (docs/physics/accuracy.md,
"Detection": matched-filter SNR over the target's blurred footprint >= 5, Rose 1948) in the
channel the reports lead with (Ey2). The full study, the row of five beacons in three weathers,
is `pmmw sweep configs/landing_trade.yaml`.

    python examples/landing_study.py [OUT_DIR]     # prints the table, writes landing_study.png

PMMW_EXAMPLE_SCALE=0.2 renders a fifth of the pixels per side (the documentation's gallery runs the
examples so; the regions' radii in pixels scale too, so the SNRs are only indicative).
"""

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import pmmw

ROOT = Path(__file__).resolve().parent.parent
out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "out" / "examples"

SCALE = float(os.environ.get("PMMW_EXAMPLE_SCALE", "1"))  # of the pixels per side
side = max(16, round(500 * SCALE))
base = pmmw.Scenario.load(ROOT / "configs" / "landing_95ghz.yaml").set(
    {"atmosphere.layers": [], "imager.resolution": [side, side]}
)
ranges = {2000: ([0, -1995.13, 139.52], 1), 500: ([0, -498.78, 34.88], 3)}  # position [m], beacon radius [px]
PAIR = "beacon - runway"

rows, verdicts, images = [], [], {}
for rng, (position, radius) in ranges.items():
    # the regions set here, not taken from the config (whose beacon box fits its own 1000 m view):
    # the middle beacon across the threshold, a circle of `radius` pixels around it, and the runway
    regions = {
        "beacon": {"center": [0, -2.36, 0.41], "radius": max(1.0, radius * SCALE)},
        "runway": {"center": [0, 40, 0.02], "radius": max(1.0, 3 * SCALE)},
    }
    scn = base.set({"imager.position": position, "output.regions": regions, "frequency": ["35 GHz", "95 GHz"]})
    ds = pmmw.render(scn)  # one Dataset, both frequencies
    for f in ds.frequency.values:
        report = pmmw.regions(ds)[f"{f / 1e9:g} GHz"]
        chan = report["channel"]  # the channel the reports lead with (Ey2, as the thesis shows)
        c = report["contrasts"][PAIR][chan]
        rows.append((rng, f / 1e9, chan, c["K"], c["snr"], c["snr_stderr"], c["detectable"]))
        verdicts.append(f"{rng} m, {f / 1e9:g} GHz: {report['verdicts'][PAIR]}")
        images[(rng, f / 1e9)] = (chan, ds[chan].sel(frequency=f))

print(f"{'range [m]':>9} {'f [GHz]':>7} {'chan':>4} {PAIR + ' [K]':>20} {'SNR':>6} {'± s.e.':>6} {'detectable':>10}")
for rng, f, chan, k, snr, err, det in rows:
    print(f"{rng:9d} {f:7g} {chan:>4} {k:20.2f} {snr:6.2f} {err:6.2f} {'yes' if det else 'no':>10}")
print("verdicts (detectable: SNR >= 5 over the beacon's blurred footprint):")
for line in verdicts:
    print("  " + line)

fig, axes = plt.subplots(2, 2, figsize=(8, 8), dpi=80)
for ax, ((rng, f), (chan, img)), row in zip(axes.ravel(), images.items(), rows):
    shown = ax.imshow(img, cmap="gray", interpolation="nearest")
    ax.set_title(f"{rng} m, {f:g} GHz: SNR {row[4]:.1f} ({'detectable' if row[6] else 'not detectable'})", fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])
    fig.colorbar(shown, ax=ax, fraction=0.046).set_label(f"{chan} [K]", fontsize=8)
fig.suptitle(f"Landing approach: {chan} after the imager, {PAIR}")
out.mkdir(parents=True, exist_ok=True)
fig.savefig(out / "landing_study.png")
print(f"wrote {out / 'landing_study.png'}")
