"""Where a scene's materials are all inside their stated ranges (`stated_band`): the intersection of
each material's table, model or fit range (and its coating layers', at their own temperatures),
stated by `pmmw validate`, the render's report and every shipped scenario's header."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pmmw.config.schema import FREQUENCY_RANGE as F_RANGE  # pmmw's accepted frequencies
from pmmw.scene.materials import MaterialDB, band_text, stated_band

ROOT = Path(__file__).resolve().parents[2]
GHZ = 1e9
SCN = "scenario.yaml"


@pytest.fixture(scope="module")
def db() -> MaterialDB:
    return MaterialDB.load()


def _band(db, ids, t=290.0):
    band, limits = stated_band(db, ids, t, F_RANGE)
    return band_text(band), {k: band_text(v) for k, v in limits.items()}


def test_the_band_is_the_intersection_of_the_tables(db):
    """Exact edges (the rows themselves, not a grid's neighbours). Control: the metal and the
    frequency-independent value limit nothing."""
    d2 = db.with_overrides(
        {
            "a": {"eps": {"30 GHz": [2, 0.1], "140 GHz": [2, 0.2]}},
            "b": {"eps": {"94 GHz": [3, 0.1], "300 GHz": [3, 0.2]}},
            "c": {"eps": [1.5, 0.01]},
        },
        file=SCN,
    )
    band, limits = stated_band(d2, ["a", "b", "c", "metal"], 290.0, F_RANGE)
    assert band == [(94 * GHZ, 140 * GHZ)]
    assert set(limits) == {"a", "b"} and limits["a"] == [(30 * GHZ, 140 * GHZ)]
    assert _band(d2, ["c", "metal"]) == ("1-1000 GHz", {})


def test_single_frequencies_gaps_and_nowhere(db):
    d2 = db.with_overrides(
        {
            "p": {"eps": {"35 GHz": [2, 0.1]}},
            "q": {"eps": {"95 GHz": [2, 0.1]}},
            "wall": {"model": {"name": "p2040", "material": "brick"}},
        },
        file=SCN,
    )
    assert _band(d2, ["p"])[0] == "35 GHz"
    assert _band(d2, ["p", "q"])[0] == "nowhere"
    # ITU-R P.2040-4's brick: rows 1-40 and 110-330 GHz (docs/materials.md), the gap between them outside
    assert _band(d2, ["wall"])[0] == "1-40, 110-330 GHz"


def test_a_model_s_range_and_temperature_count(db):
    """Gabriel et al.'s skin is stated to 100 GHz at 298-313 K: inside to 100 GHz at 310 K, nowhere
    at 290 K (the material's temperature decides, as in the render); a coating layer at its own
    temperature limits its surface, named 'surface: layer'."""
    d2 = db.with_overrides(
        {
            "warm": {"same_as": "human_skin", "temperature": "310 K"},
            "cold": {"same_as": "human_skin", "temperature": "290 K"},
            "clad": {
                "same_as": "human_skin",
                "temperature": "310 K",
                "coating": [{"material": "denim", "thickness": "1 mm"}],
            },
        },
        file=SCN,
    )
    assert _band(d2, ["warm"])[0] == "1-100 GHz"
    assert _band(d2, ["cold"])[0] == "nowhere"
    text, limits = _band(d2, ["clad"])
    assert text == "35-95 GHz" and limits == {"clad": "1-100 GHz", "clad: denim": "35-95 GHz"}


def test_a_fit_s_own_valid_range_is_an_edge(db):
    d2 = db.with_overrides(
        {"fit": {"model": {"name": "debye", "eps_inf": 3.5, "terms": [[70, "9 ps"]], "valid": ["20 GHz", "400 GHz"]}}},
        file=SCN,
    )
    assert _band(d2, ["fit"])[0] == "20-400 GHz"


def test_validate_and_the_report_state_it(tmp_path):
    from pmmw.io.report import render_markdown
    from pmmw.pipeline import validate

    out = validate(ROOT / "configs" / "cwd_outdoor_band.yaml")
    band = out["materials_band"]
    assert band["within_stated_ranges"] == "35-95 GHz" and band["accepted"] == "1-1000 GHz"
    assert band["limited_by"]["clothed_person: denim"] == "35-95 GHz"
    assert "pavement" in band["limited_by"] and "gun" not in str(band["limited_by"])
    assert band["intervals_hz"] == [[35e9, 95e9]] and band["limited_by_hz"]["holster"] == [[35e9, 95e9]]
    import yaml

    yaml.safe_dump(band)  # plain floats: `pmmw validate` prints its result as YAML (numpy's failed there)
    text = render_markdown({"materials_band": band}, {})
    assert "inside its stated range (its table, model or fit) at 35-95 GHz (of the 1-1000 GHz" in text
    assert "clothed_person: denim 35-95 GHz" in text
    assert "stated range" not in render_markdown({}, {})  # control: no band, no section


SCENARIOS = sorted(p for p in (ROOT / "configs").glob("*.yaml") if re.search(r"^scene:", p.read_text(), re.M))


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_every_shipped_scenario_states_its_band(path):
    """Each shipped scenario's header says where its materials are inside their stated ranges, and
    says what `pmmw validate` computes (a header left behind by a changed material fails here)."""
    from pmmw.pipeline import materials_band, resolve

    stated = re.search(r"^# Materials inside their stated ranges: (.+?) \(", path.read_text(), re.M)
    assert stated, f"{path.name} does not state its band"
    assert stated.group(1) == materials_band(resolve(path))["within_stated_ranges"]


def test_a_sweep_row_says_whether_its_frequency_is_inside(tmp_path):
    """`pmmw sweep`'s table: per variant, whether every material is inside its stated range at the
    variant's frequency, and which are not, from the variant's report (`materials_band`). A real
    two-variant sweep of the concealed-weapon band scene (44 x 74 pixels): inside at 94 GHz,
    outside at 140 GHz by the skin, the denim and the leather, as the warnings say."""
    import pandas as pd

    import pmmw

    table = pmmw.sweep(
        ROOT / "configs" / "cwd_outdoor_band.yaml",
        {
            "frequency": ["94 GHz", "140 GHz"],
            "imager.resolution": [[44, 74]],
            "output.regions.gun.radius": [1],
            "output.regions.torso.radius": [1],
        },
        out=tmp_path / "sweep",
    )
    inside = dict(zip(table["frequency"], table["inside stated ranges"]))
    outside = dict(zip(table["frequency"], table["outside stated range"]))
    assert inside == {"94 GHz": True, "140 GHz": False}
    assert pd.isna(outside["94 GHz"])  # an empty cell of sweep.csv, as pandas reads it
    assert set(outside["140 GHz"].split("; ")) == {"clothed_person", "clothed_person: denim", "holster", "shoes"}
