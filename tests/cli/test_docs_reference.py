"""The reference pages generated for the site (docs/gen_ref.py) hold every command option, scenario
key, material and model: the generator walks the code, and these checks compare its pages with facts
stated elsewhere (the guides' key table, the command line's own --help, the database's ids)."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def gen():
    spec = importlib.util.spec_from_file_location("pmmw_docs_gen_ref", ROOT / "docs" / "gen_ref.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)  # defines the page functions; writes nothing when imported
    return mod


def _row(page: str, key: str) -> str:
    rows = [line for line in page.splitlines() if line.startswith(f"| `{key}` |")]
    assert len(rows) == 1, key
    return rows[0]


def test_every_command_option_is_on_the_commands_page(gen):
    """Every option ``pmmw COMMAND --help`` lists (typer's own help text) has its row."""
    from typer.testing import CliRunner

    from pmmw_cli.cli import app

    page = gen.cli_page()
    runner = CliRunner()
    commands = re.findall(r"^#+ `pmmw ([a-z ]+)`$", page, flags=re.M)
    assert {"render", "validate", "sweep", "po", "brdf", "sky", "materials show", "materials list"} <= set(commands)
    for cmd in commands:
        text = runner.invoke(app, [*cmd.split(), "--help"], terminal_width=200).output
        options = set(re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", text)) - {"--help"}
        section = page.split(f"`pmmw {cmd}`", 1)[1].split("\n#", 1)[0]
        missing = sorted(o for o in options if f"{o}" not in section)
        assert missing == [], cmd


def test_scenario_keys_with_their_units_and_defaults(gen):
    """Keys the scenario guide's table names, with the defaults and units it states there."""
    page = gen.scenario_page()
    assert "`16`" in _row(page, "render.spp") and "`32`" in _row(page, "render.max_depth")
    assert "mm/h" in _row(page, "atmosphere.layers[i].rain_rate")
    assert "[deg]" in _row(page, "scene[i].transform.rotate_deg")
    assert "required" in _row(page, "imager.fov") and "a bare number in deg" in _row(page, "imager.fov")
    assert "give the unit" in _row(page, "frequency")
    assert "`5`" in _row(page, "imager.band_samples")
    for key in (
        "imager.focus_distance",
        "sky.zenith_opacity",
        "output.regions.NAME.box",
        "atmosphere.layers[i].attenuation.model",
        "atmosphere.layers[i].scattering",
    ):
        _row(page, key)
    # control: a key the schema lacks has no row
    with pytest.raises(AssertionError):
        _row(page, "render.sppp")


def test_every_material_and_model_has_its_row(gen):
    from pmmw.physics.roughness import REGISTRY
    from pmmw.scene.dielectric import MODELS
    from pmmw.scene.materials import MaterialDB
    from pmmw.scene.sky import SKY_MODELS

    materials, models = gen.materials_page(), gen.models_page()
    for mid in MaterialDB.load().ids():
        _row(materials, mid)
    # water is ITU-R P.527-6's pure water, stated for -4 to 40 C (269.15-313.15 K) to 1000 GHz
    water = _row(materials, "water")
    assert "model `pure_water`" in water and "1-1000 GHz, 269.15-313.15 K" in water
    for name in [*REGISTRY, *SKY_MODELS, *MODELS]:
        _row(models, name)


def _model_rows(page: str, names) -> list[str]:
    """The table rows of ``page`` that start with one of ``names`` in backticks."""
    return [line for line in page.splitlines() if any(line.startswith(f"| `{n}` |") for n in names)]


def test_the_roughness_models_are_tabled_once_from_the_registry(gen):
    """The roughness table exists once, generated from `pmmw.physics.roughness.REGISTRY`: the BRDF
    notes and the guides link to it and hold no table of their own (the BRDF notes' own table had
    drifted from the code). The control: the generated page has a row per model."""
    from pmmw.physics.roughness import REGISTRY

    assert len(_model_rows(gen.models_page(), REGISTRY)) == len(REGISTRY)
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        assert _model_rows(page.read_text(), REGISTRY) == [], page
    assert "reference/models.md#roughness-models" in (ROOT / "docs" / "brdf.md").read_text()
