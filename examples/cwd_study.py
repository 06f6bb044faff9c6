"""The concealed-weapon study with the Python API: does the gun under the shirt stand out?

Murakowski 2014 sec. 3.2: a man outdoors with a handgun under denim, seen at 35 and 95 GHz from
4 m and 8 m (the field of view narrowed with the distance so he fills the frame), at a quarter
of the shipped pixels so that it runs in seconds (the full study is `pmmw sweep
configs/cwd_trade.yaml`).

    python examples/cwd_study.py [OUT_DIR]     # prints the table, writes cwd_study.csv
"""

import sys
from pathlib import Path

import pmmw

ROOT = Path(__file__).resolve().parent.parent
out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "out" / "examples"

base = pmmw.Scenario.load(ROOT / "configs" / "cwd_outdoor_95ghz.yaml").set(
    {"imager.resolution": [220, 370], "output.regions.gun.radius": 2, "output.regions.torso.radius": 2})
views = {4: ([0, -4, 1.5], "18.1 deg"), 8: ([0, -8, 1.5], "9.1 deg")}  # distance [m]: position, fov

lines = ["distance_m,frequency_GHz,gun_minus_torso_I_K,gun_minus_torso_I_sigma"]
for dist, (position, fov) in views.items():
    ds = pmmw.render(base.set({"imager.position": position, "imager.fov": fov, "frequency": ["35 GHz", "95 GHz"]}))
    for f in ds.frequency.values:
        c = ds.attrs["regions"][f"{f / 1e9:g} GHz"]["contrasts"]["gun - torso"]["I"]
        lines.append(f"{dist},{f / 1e9:g},{c['K']:.3f},{c['sigma']:.2f}")
        print(f"{dist} m, {f / 1e9:g} GHz: gun - torso {c['K']:+.2f} K = {c['sigma']:+.1f} noise sigma"
              + ("  (visible)" if abs(c["sigma"]) >= 3 else ""))
out.mkdir(parents=True, exist_ok=True)
(out / "cwd_study.csv").write_text("\n".join(lines) + "\n")
print(f"wrote {out / 'cwd_study.csv'}")
