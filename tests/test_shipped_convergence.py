"""The shipped scenarios are converged where their reports look: no truncation bias, no seed luck.

For every shipped config with `output.regions` (and the hardest sweep variant, the 1.5 m x 2 m
blanket seen from 3 km), at full resolution:

* truncation: the regions of the shipped render are within a tenth of the imager's noise sigma
  (0.5 K without noise) of a render at `render.max_depth: 64` (the schema's largest), and the
  report's truncation bound says so too;
* sampling: every region contrast of three seeds lies within a tenth of the noise sigma of their
  mean (the noise itself is switched off, `imager.noise=0`, so that only the Monte Carlo error
  moves; the tolerance is the config's own sigma).

Renders take 5-20 s each on two cores: marked slow.
"""

import json

import math

import pytest

from pmmw_cli.config import load_scenario
from pmmw_cli.pipeline import region_limit, render

pytestmark = pytest.mark.slow

BLANKET = [
    "scene[0].mesh=../scenes/sar/sar_blanket.glb",
    "scene[0].materials={dry_ground: sar_dry_ground, wet_ground: sar_wet_ground, rocks: sar_rocks, "
    "shrubs: oak_leaves, blanket: metal}",
]
CASES = {
    "landing": ("configs/landing_95ghz.yaml", []),
    "cinderblocks": ("configs/cinderblocks_35ghz.yaml", []),
    "cwd_outdoor": ("configs/cwd_outdoor_95ghz.yaml", []),
    "cwd_outdoor_35ghz": ("configs/cwd_outdoor_95ghz.yaml", ["frequency=35 GHz"]),
    "cwd_indoor": ("configs/cwd_indoor_95ghz.yaml", []),
    "sar_cessna": ("configs/sar_cessna_95ghz.yaml", []),
    "sar_blanket": ("configs/sar_cessna_95ghz.yaml", BLANKET),
}


def _report(tmp_path, tag, config, overrides):
    out = tmp_path / tag
    render(config, overrides, out=str(out), quiet=True, workers=2)
    return json.loads((out / "report.json").read_text())


def _noise(config, extra):
    return load_scenario(config, extra).imager.noise


@pytest.mark.parametrize("case", sorted(CASES))
def test_regions_are_converged_in_depth_and_samples(tmp_path, case):
    config, extra = CASES[case]
    limit = region_limit(_noise(config, extra))
    runs = [_report(tmp_path, f"seed{s}", config, extra + [f"render.seed={s}", "imager.noise=0"]) for s in (1, 2, 3)]
    deep = _report(tmp_path, "deep", config, extra + ["render.seed=1", "imager.noise=0", "render.max_depth=64"])
    assert runs[0]["regions"]["means"], f"{config} declares no output.regions"

    shipped, reference = runs[0]["regions"], deep["regions"]
    for name, means in shipped["means"].items():
        assert shipped["truncation"][name]["bound_K"] <= limit
        for c, v in means.items():
            scale = math.sqrt(2.0) if c == "I" else 1.0  # I carries sqrt(2) sigma of noise
            assert abs(v - reference["means"][name][c]) <= limit * scale, (name, c, v, reference["means"][name][c])

    for pair in shipped["contrasts"]:
        for c in shipped["contrasts"][pair]:
            values = [r["regions"]["contrasts"][pair][c]["K"] for r in runs]
            mean = sum(values) / 3.0
            scale = math.sqrt(2.0) if c == "I" else 1.0
            assert max(abs(v - mean) for v in values) <= limit * scale, (pair, c, values)
