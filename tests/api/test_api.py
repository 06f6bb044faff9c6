"""The Python API (`import pmmw`): scenarios from YAML or dicts, overrides, renders to arrays that
equal the files the command writes, and the other commands' data."""

import numpy as np
import pytest
import trimesh
import yaml

import pmmw
from pmmw.io.exr import read_exr
from tests.scenes import ground_and_block

SCENE = {
    "name": "tiny",
    "frequency": "35 GHz",
    "imager": {
        "position": [0, 0, 1.5],
        "look_at": [0, 4, 0.1],
        "fov": "20 deg",
        "resolution": [24, 16],
        "noise": "1 K",
    },
    "scene": [{"mesh": "ground.obj", "material": "concrete"}, {"mesh": "block.obj", "material": "metal"}],
    "sky": {"model": "uniform", "temperature": "40 K"},
    "render": {"spp": 2, "max_depth": 4, "tile": 8, "workers": 1},
    "output": {"regions": {"block": {"center": [0, 4, 0.1], "radius": 2}, "ground": {"box": [0, 12, 6, 16]}}},
}


@pytest.fixture
def folder(tmp_path):
    ground_and_block(tmp_path)
    (tmp_path / "tiny.yaml").write_text(yaml.safe_dump(SCENE))
    return tmp_path


def test_a_dict_renders_what_the_yaml_file_renders(folder):
    """The same scenario as a dict and as a file, in memory and with files written: the arrays
    are the EXR's channels bit for bit, with frequency, pixel coordinates and units."""
    mem = pmmw.render(pmmw.Scenario.from_dict(SCENE, base_dir=folder))
    disk = pmmw.render(pmmw.Scenario.load(folder / "tiny.yaml"), out=folder / "out")
    chans, attrs = read_exr(folder / "out" / "tiny.exr")
    assert set(mem.data_vars) == set(chans)
    for c in chans:
        assert mem[c].dims == ("frequency", "y", "x") and mem[c].shape == (1, 16, 24)
        np.testing.assert_array_equal(mem[c].values[0], chans[c])
        np.testing.assert_array_equal(disk[c].values[0], chans[c])
    assert mem["I"].attrs["units"] == "K" and float(mem.frequency[0]) == pytest.approx(35e9)
    assert mem.attrs["spp"] == 2 and "x right, y up" in mem.attrs["convention"]
    # the report's regions ride along: contrasts in K and in noise sigmas
    c = pmmw.regions(mem)["35 GHz"]["contrasts"]["block - ground"]["I"]
    assert c == pytest.approx(pmmw.regions(disk)["35 GHz"]["contrasts"]["block - ground"]["I"])


def test_overrides_by_key_and_errors_name_the_key(folder):
    scn = pmmw.Scenario.load(folder / "tiny.yaml")
    two = scn.set({"frequency": ["35 GHz", "95 GHz"], "imager.noise": "0 K"})
    ds = pmmw.render(two)
    assert list(ds.frequency.values) == [35e9, 95e9] and ds["I"].shape == (2, 16, 24)
    assert scn.resolved().imager.noise == pytest.approx(1.0)  # the original is unchanged
    with pytest.raises(pmmw.UserError, match=r"tiny\.yaml: imager\.fov: '20 kg' is not an angle"):
        pmmw.render(scn.set({"imager.fov": "20 kg"}))
    with pytest.raises(pmmw.UserError, match="scenario file not found"):
        pmmw.validate(folder / "missing.yaml")


def test_validate_sky_po_and_sweep_return_data(folder, tmp_path):
    v = pmmw.validate(folder / "tiny.yaml")
    assert v["geometry"]["triangles"] == 24 and "35 GHz" in v["media"]
    sky = pmmw.sky("95 GHz", {"profile": "standard"}, elevations_deg=[10, 90])
    assert sky["Tv"].sel(elevation=90).item() < sky["Tv"].sel(elevation=10).item() < 290
    plate = trimesh.Trimesh(
        [[-0.05, -0.05, 0], [0.05, -0.05, 0], [0.05, 0.05, 0], [-0.05, 0.05, 0]], [[0, 1, 2], [0, 2, 3]]
    )
    plate.export(tmp_path / "plate.ply")
    rcs = pmmw.po(tmp_path / "plate.ply", material="metal", frequency="95 GHz", theta="0:10:5", phi="0,90")
    lam = 299_792_458.0 / 95e9
    assert rcs["rcs_theta"].sel(theta=0.0, phi=0.0).item() == pytest.approx(4 * np.pi * 0.01**2 / lam**2, rel=1e-6)
    table = pmmw.sweep(folder / "tiny.yaml", {"render.seed": [1, 2]}, out=tmp_path / "sw")
    assert list(table["status"]) == ["done", "done"] and "contrast block - ground I [sigma]" in table.columns


def test_brdf_returns_mueller_maps():
    """A smooth-ish copper-like surface by the analytic model: the Mueller maps on the 1-degree
    grid, with the total reflectance of the summary."""
    res = pmmw.brdf(
        method="analytic", eps="1+1e4j", frequency="95 GHz", incidence=30.0, model="beckmann", alpha=0.2, double=False
    )
    ds = res["analytic"]
    assert ds["mueller"].shape == (91, 360, 4, 4) and ds["stokes"].sel(component="I").shape == (91, 360)
    assert 0.9 < ds.attrs["total_reflectance"] <= 1.0 + 1e-9
