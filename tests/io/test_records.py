"""One path from YAML to records (`pmmw.io.records`): every file kind names a misspelt key the same
way, with the nearest allowed key and the file and key path; a file without the misspelling loads
(the control of each)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pmmw.errors import UserError, UserErrors
from pmmw.io.records import check_keys, key_path
from tests.scenes import tiny_scenario

ROOT = Path(__file__).resolve().parents[2]


def _one(exc) -> UserError:
    errors = exc.errors if isinstance(exc, UserErrors) else [exc]
    assert len(errors) == 1, [str(e) for e in errors]
    return errors[0]


def _scenario(tmp_path, text):
    from pmmw.config import load_scenario

    return load_scenario(tiny_scenario(tmp_path, text))


def _po(tmp_path, text):
    from pmmw.physical_optics.job import load_job

    p = tmp_path / "po.yaml"
    mesh = ROOT / "scenes/po/sphere_ka50.ply"
    p.write_text(
        f"targets:\n  - {{mesh: {mesh}, material: metal}}\nfrequency: 95 GHz\nincidence: [0 deg, 0 deg]\n{text}\n"
    )
    return load_job(p)


def _sweep(tmp_path, text):
    from pmmw.sweeps.spec import load_sweep_file

    p = tmp_path / "sweep.yaml"
    p.write_text(f"scenario: {tiny_scenario(tmp_path)}\ngrid:\n  render.seed: [1, 2]\n{text}\n")
    return load_sweep_file(p)


def _stack(tmp_path, text):
    from pmmw.reflectance.stack import load_stack

    p = tmp_path / "stack.yaml"
    p.write_text("frequency: 95 GHz\nlayers:\n  - {n: 1.5, thickness: 1 mm}\n  - {material: metal}\n" + text)
    return load_stack(p)


def _atmosphere(tmp_path, text):
    from pmmw.sky_table import load_atmosphere

    p = tmp_path / "atm.yaml"
    p.write_text("model: layered\nprofile: mid_latitude_summer\n" + text)
    return load_atmosphere(p, None, [], None, None)


# (loader, a line with a misspelt top-level key, the key, the nearest allowed key)
KINDS = {
    "scenario": (_scenario, "imagr: {}", "imagr", "imager"),
    "physical-optics job": (_po, "bouncs: 2", "bouncs", "bounces"),
    "sweep file": (_sweep, "executr: local", "executr", "executor"),
    "reflectance stack": (_stack, "ambiant: {n: 1}", "ambiant", "ambient"),
    "atmosphere file": (_atmosphere, "humidty: 7.5 g/m3", "humidty", "humidity"),
}


@pytest.mark.parametrize("kind", list(KINDS))
def test_a_misspelt_key_is_named_the_same_way_in_every_file_kind(kind, tmp_path):
    load, line, key, near = KINDS[kind]
    load(tmp_path, "")  # the control: the file without the misspelling loads
    with pytest.raises((UserError, UserErrors)) as ei:
        load(tmp_path, line)
    e = _one(ei.value)
    assert e.key is not None and e.key.split(".")[-1] == key, (e.file, e.key)
    assert e.file is not None and Path(str(e.file)).suffix == ".yaml"
    assert e.message.startswith(f"unknown key {key!r} (did you mean {near!r}?); allowed: "), e.message


def test_a_material_entry_names_what_the_key_belongs_to(tmp_path):
    from pmmw.scene.materials import MaterialDB

    with pytest.raises((UserError, UserErrors)) as ei:
        MaterialDB.load().with_overrides({"tile": {"eps": [4, 0.1], "temprature": "300 K"}}, file="s.yaml")
    e = _one(ei.value)
    assert e.key == "materials.tile.temprature"
    assert e.message.startswith("unknown key 'temprature' for a material (did you mean 'temperature'?); allowed: ")


def test_check_keys_and_key_paths():
    errors = check_keys({"layers": [], "frequncy": 1}, ("frequency", "layers"), "f.yaml", required=("layers", "x"))
    assert [(e.key, e.message) for e in errors] == [
        ("frequncy", "unknown key 'frequncy' (did you mean 'frequency'?); allowed: frequency, layers"),
        ("x", "required key missing"),
    ]
    assert check_keys({"layers": []}, ("layers",), "f.yaml") == []  # the control
    assert key_path(["imager", "pixels", 1]) == "imager.pixels[1]"
    assert key_path(["eps", "95 GHz", 0], "materials.runway") == 'materials.runway.eps."95 GHz"[0]'
