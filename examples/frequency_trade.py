"""Which frequency? The frequency trade studies of the concealed-weapon scenes and the landing.

Six sweeps (configs/*_frequency.yaml, *_frequency_scaled.yaml), each at 35, 94, 140, 220 and 300
GHz, of scenes whose materials are meant for that band (docs/materials.md): the concealed weapon
outdoors and indoors (the gun's grip against the torso) and the landing in extreme fog (the row of
beacons against the runway). Each scene twice: the aperture fixed (the beam narrows as the
wavelength shortens) and scaled with the wavelength (the same beam at every frequency, so only the
materials and the atmosphere change). The SNR is the reports' one detection criterion (docs/physics/accuracy.md,
"Detection": matched-filter SNR >= 5) in the channel the reports lead with.

The clothing (denim, leather) is tabulated only to 95 GHz. Above it the concealed-weapon studies are
rendered twice: with its loss held at the 95 GHz value (the default, `extrapolate: hold`) and
continuing its 35 -> 95 GHz rise (`extrapolate: trend`); the band between the two is shaded. It is
the spread of two extrapolations, not a measured uncertainty.

    python examples/frequency_trade.py [OUT_DIR]   # 42 renders, about 2 minutes on 2 cores;
                                                   # writes frequency_trade.csv and .png in OUT_DIR

PMMW_EXAMPLE_SCALE=0.1 renders a tenth of the pixels per side (the documentation's gallery runs the
examples so; the regions scale with the pixels, and the SNRs are then only indicative).

Sweeps already rendered (``pmmw sweep configs/cwd_outdoor_frequency.yaml`` into out/...) are
reused: each variant whose inputs are unchanged is skipped.
"""

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import yaml  # noqa: E402

import pmmw  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "out" / "examples"
out.mkdir(parents=True, exist_ok=True)

SCALE = float(os.environ.get("PMMW_EXAMPLE_SCALE", "1"))  # of the pixels per side


def scaled(grid: dict, scenario: Path) -> dict:
    """The sweep's grid with the scenario's pixels, and its regions' pixel sizes, times SCALE (one
    value each: every variant renders at that size)."""
    if SCALE == 1:
        return grid
    scn = yaml.safe_load(scenario.read_text())
    w, h = scn["imager"]["resolution"]
    out = dict(grid, **{"imager.resolution": [[max(16, round(w * SCALE)), max(16, round(h * SCALE))]]})
    for name, region in scn.get("output", {}).get("regions", {}).items():
        if "radius" in region:
            out[f"output.regions.{name}.radius"] = [max(1.0, region["radius"] * SCALE)]
        if "box" in region:
            x0, y0, x1, y1 = (round(v * SCALE) for v in region["box"])
            out[f"output.regions.{name}.box"] = [[x0, y0, max(x1, x0 + 1), max(y1, y0 + 1)]]
    return out


STUDIES = {  # title -> (sweep file stem, the pair whose SNR is plotted, ids tabulated only to 95 GHz)
    "concealed weapon, outdoors": ("cwd_outdoor_frequency", "gun - torso", ("denim", "leather")),
    "concealed weapon, indoors": ("cwd_indoor_frequency", "gun - torso", ("denim", "leather")),
    "landing, extreme fog, 1000 m": ("landing_frequency", "beacons - runway", ()),
}
TABLE_TOP_GHZ = 95.0  # denim's and leather's highest row (Murakowski 2014 Table 3.3)


def ghz(value) -> float:
    return float(str(value).split()[0])


def beyond_table(grid: dict, zipped) -> dict:
    """The grid's variants above TABLE_TOP_GHZ (the frequencies and the lists zipped with them)."""
    keep = [i for i, f in enumerate(grid["frequency"]) if ghz(f) > TABLE_TOP_GHZ]
    side = list(grid) if zipped is True else list(zipped or [])
    return {
        k: ([v[i] for i in keep] if k == "frequency" or ("frequency" in side and k in side) else v)
        for k, v in grid.items()
    }


def render(stem: str, suffix: str, extra: dict | None = None):
    """One sweep (resumed where rendered already): the sweep file's grid, or with ``extra`` the
    variants above the clothing's table with those keys added."""
    spec = yaml.safe_load((ROOT / "configs" / f"{stem}{suffix}.yaml").read_text())
    scenario = ROOT / "configs" / spec["scenario"]
    grid, name = spec["grid"], f"{stem}{suffix}"
    if extra:
        grid, name = {**beyond_table(grid, spec.get("zip")), **extra}, f"{stem}{suffix}_trend"
    return pmmw.sweep(scenario, scaled(grid, scenario), out=out / name, zip=spec.get("zip", False), resume=True)


rows = ["study,aperture,clothing,frequency_GHz,aperture_m,channel,contrast_K,snr,detectable,inside_stated_ranges"]
fig, axes = plt.subplots(1, len(STUDIES), figsize=(13.0, 3.8), dpi=110)
for ax, (title, (stem, pair, tabulated)) in zip(axes, STUDIES.items()):
    any_outside = False
    for suffix, how, style, colour in (
        ("", "fixed", "o-", "C0"),
        ("_scaled", "scaled with the wavelength", "s--", "C1"),
    ):
        runs = [("hold", render(stem, suffix))]
        if tabulated:  # the same variants with the clothing's loss continuing its 35 -> 95 GHz rise
            runs.append(("trend", render(stem, suffix, {f"materials.{m}.extrapolate": ["trend"] for m in tabulated})))
        snr = {}
        for law, table in runs:
            snr_col = next(c for c in table.columns if c.startswith(f"snr {pair} "))
            channel = snr_col.rsplit(" ", 1)[1]
            freqs = [ghz(f) for f in table["frequency"]]
            apertures = (
                table["imager.aperture_diameter"] if "imager.aperture_diameter" in table else [None] * len(freqs)
            )
            for f, a, k, s, det, ok in zip(
                freqs,
                apertures,
                table[f"contrast {pair} {channel} [K]"],
                table[snr_col],
                table[f"detectable {pair} {channel}"],
                table["inside stated ranges"],
            ):
                rows.append(
                    f"{stem},{how},{law},{f:g},{a if a is not None else ''},{channel},{k:.3f},{s:.2f},{det},{bool(ok)}"
                )
            snr[law] = dict(zip(freqs, table[snr_col]))
            if law == "hold":
                outside = [f for f, ok in zip(freqs, table["inside stated ranges"]) if not ok]
        ax.plot(list(snr["hold"]), list(snr["hold"].values()), style, color=colour, label=f"aperture {how}")
        # hollow: a point that rests on a material outside its stated range (extrapolated, warned)
        ax.plot(outside, [snr["hold"][f] for f in outside], style[0], color=colour, mfc="white", zorder=3)
        any_outside |= bool(outside)
        if "trend" in snr:  # from the table's last row (where the two laws agree) to 300 GHz
            fs = [f for f in snr["hold"] if f >= max(g for g in snr["hold"] if g <= TABLE_TOP_GHZ)]
            lo = [snr["hold"][f] if f not in snr["trend"] else snr["trend"][f] for f in fs]
            ax.fill_between(fs, lo, [snr["hold"][f] for f in fs], color=colour, alpha=0.18, lw=0)
            ax.plot(fs, lo, ":", color=colour, lw=1)
    if tabulated:
        ax.fill_between([], [], [], color="0.6", alpha=0.3, label="clothing's loss held / trend (shaded)")
    if any_outside:
        ax.plot([], [], "o", color="0.4", mfc="white", label="hollow: a material extrapolated")
    ax.axhline(5.0, color="k", lw=0.8, ls=":", label="detection threshold (SNR 5)")
    ax.set_xscale("log")
    ax.set_yscale("log" if stem.startswith("landing") else "linear")  # the landing spans 3 decades
    ax.set_xticks([35, 94, 140, 220, 300], ["35", "94", "140", "220", "300"])
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("frequency [GHz]")
    ax.set_ylabel(f"SNR of {pair} ({channel})")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
axes[0].legend(fontsize=7)
fig.tight_layout()
fig.savefig(out / "frequency_trade.png")
(out / "frequency_trade.csv").write_text("\n".join(rows) + "\n")
print("\n".join(rows))
print(f"wrote {out / 'frequency_trade.csv'} and {out / 'frequency_trade.png'}")
