"""The concealed-weapon study with the Python API: is the gun under the shirt detectable?

Murakowski 2014 sec. 3.2: a man outdoors with a handgun under denim, seen at 35 and 95 GHz from
4 m and 8 m (the field of view narrowed with the distance so he fills the frame), at a quarter
of the shipped pixels so that it runs in seconds (the full study is `pmmw sweep
configs/cwd_trade.yaml`). The gun's grip against the torso is judged by the reports' one
detection criterion (docs/physics/accuracy.md, "Detection": matched-filter SNR over the grip's blurred footprint
>= 5, Rose 1948) in the channel the reports lead with (Ey2).

The metal grip mirrors its surroundings, so its contrast depends on the viewing angle (as the
thesis finds, Fig. 3.9): from 8 m at the same 1.5 m height the grip is seen 1.8 degrees lower
than from 4 m and reads warmer. A third view, "8 m high", looks at the grip from 8 m along the
4 m view's line of sight (the imager raised to 1.75 m), where only the blur differs from 4 m.

    python examples/cwd_study.py [OUT_DIR]     # prints the table, writes cwd_study.csv and .png

PMMW_EXAMPLE_SCALE=0.25 renders a quarter of these pixels per side (the documentation's gallery runs
the examples so; the SNRs are then only indicative).
"""

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import pmmw  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "out" / "examples"

SCALE = float(os.environ.get("PMMW_EXAMPLE_SCALE", "1"))  # of the pixels per side
base = pmmw.Scenario.load(ROOT / "configs" / "cwd_outdoor_95ghz.yaml").set(
    {
        "imager.resolution": [max(16, round(220 * SCALE)), max(16, round(370 * SCALE))],
        "output.regions.gun.radius": max(1.0, 2 * SCALE),
        "output.regions.torso.radius": max(1.0, 2 * SCALE),
    }
)
# view: distance to the man [m], imager position, look-at point [m], field of view
views = {
    "4 m": (4, [0, -4, 1.5], [0, 0, 0.9], "18.1 deg"),
    "8 m": (8, [0, -8, 1.5], [0, 0, 0.9], "9.1 deg"),
    # the grip, at [0.165, -0.2, 1.25], seen from 8 m along the 4 m view's line of sight
    "8 m high": (8, [-0.165, -7.8, 1.75], [-0.165, -3.8, 1.15], "9.1 deg"),
}

PAIR = "gun - torso"
images = {}  # (view, frequency [GHz]) -> (channel, image [K], SNR)
lines = ["view,distance_m,frequency_GHz,channel,gun_minus_torso_K,snr,snr_stderr,detectable"]
for view, (dist, position, look_at, fov) in views.items():
    ds = pmmw.render(
        base.set(
            {
                "imager.position": position,
                "imager.look_at": look_at,
                "imager.fov": fov,
                "frequency": ["35 GHz", "95 GHz"],
            }
        )
    )
    for f in ds.frequency.values:
        report = pmmw.regions(ds)[f"{f / 1e9:g} GHz"]
        chan = report["channel"]  # the channel the reports lead with (Ey2)
        c = report["contrasts"][PAIR][chan]
        lines.append(
            f"{view},{dist},{f / 1e9:g},{chan},{c['K']:.3f},{c['snr']:.3f},{c['snr_stderr']:.3f},{c['detectable']}"
        )
        images[(view, f / 1e9)] = (chan, ds[chan].sel(frequency=f), c["snr"])
        print(f"{view}, {f / 1e9:g} GHz: {PAIR} {c['K']:+.2f} K in {chan}; {report['verdicts'][PAIR]}")
out.mkdir(parents=True, exist_ok=True)
(out / "cwd_study.csv").write_text("\n".join(lines) + "\n")
fig, axes = plt.subplots(2, len(views), figsize=(3.2 * len(views), 8), dpi=80)
for ax, ((view, f), (chan, img, snr)) in zip(axes.T.ravel(), images.items()):
    shown = ax.imshow(img, cmap="gray", interpolation="nearest")  # row 0 at the top, as the imager sees
    ax.set_title(f"{view}, {f:g} GHz: SNR {snr:.1f}", fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])
    fig.colorbar(shown, ax=ax, fraction=0.046).set_label(f"{chan} [K]", fontsize=8)
fig.suptitle(f"Concealed weapon outdoors: {PAIR}")
fig.savefig(out / "cwd_study.png")
print(f"wrote {out / 'cwd_study.csv'} and {out / 'cwd_study.png'}")
