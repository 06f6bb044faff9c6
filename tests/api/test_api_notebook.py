"""The Python API as notebooks use it: images that plot upright by default, Datasets that save to
netCDF and Zarr, and a loaded scene that renders many times."""

from __future__ import annotations

import math

import matplotlib
import numpy as np
import pytest
import xarray as xr
import yaml

import pmmw
from pmmw.api import _dataset
from tests.scenes import ground_and_block

matplotlib.use("Agg")  # the test draws; the library never selects a backend

SCENE = {
    "name": "tiny",
    "frequency": "35 GHz",
    "imager": {"position": [0, 0, 1.5], "look_at": [0, 4, 0.1], "fov": "20 deg", "resolution": [12, 8]},
    "scene": [{"mesh": "ground.obj", "material": "concrete"}, {"mesh": "block.obj", "material": "metal"}],
    "sky": {"model": "uniform", "temperature": "40 K"},
    "render": {"spp": 1, "max_depth": 3, "tile": 8, "workers": 1},
    "output": {"regions": {"block": {"center": [0, 4, 0.1], "radius": 2}, "ground": {"box": [0, 6, 4, 8]}}},
}


@pytest.fixture
def folder(tmp_path):
    ground_and_block(tmp_path)
    (tmp_path / "tiny.yaml").write_text(yaml.safe_dump(SCENE))
    return tmp_path


def test_the_image_plots_with_row_0_at_the_top():
    """An image bright in its top row only (row 0), drawn by xarray's default ``plot()``: the
    bright band must be at the top of the drawn axes. Before, y was the row index, increasing,
    and xarray drew row 0 at the bottom unless told ``yincrease=False``."""
    import matplotlib.pyplot as plt

    img = np.zeros((8, 12), np.float32)
    img[0] = 1.0
    ds = _dataset([(35e9, {"I": img}, {"pmmw:fov_deg": 20.0})], {})
    fig, ax = plt.subplots(figsize=(3, 2), dpi=100)
    ds["I"].isel(frequency=0).plot(ax=ax, cmap="gray", vmin=0, vmax=1, add_colorbar=False)
    ax.set_axis_off()
    fig.subplots_adjust(0, 0, 1, 1)
    fig.canvas.draw()
    drawn = np.asarray(fig.canvas.buffer_rgba())[..., 0].astype(float) / 255.0
    plt.close(fig)
    rows = drawn.mean(axis=1)
    top, bottom = rows[: len(rows) // 8].mean(), rows[-len(rows) // 8 :].mean()
    assert top > 0.9 and bottom < 0.1, (top, bottom)
    # the coordinates: angles from the viewing direction [deg], the pinhole's closed form
    half = math.tan(math.radians(10.0))
    assert float(ds.y[0]) == pytest.approx(math.degrees(math.atan((4 - 0.5) / 6 * half)), abs=1e-9)
    assert float(ds.x[-1]) == pytest.approx(math.degrees(math.atan((11.5 / 6 - 1) * half)), abs=1e-9)
    assert list(ds.row.values) == list(range(8)) and ds.y.dims == ("y",)


def _attrs_equal(back: dict, want: dict) -> None:
    """Attributes as written and read back: numbers and text equal, lists as arrays allowed."""
    assert set(back) == set(want), (sorted(back), sorted(want))
    for k, v in want.items():
        if isinstance(v, (list, tuple, np.ndarray)):
            np.testing.assert_array_equal(np.asarray(back[k]), np.asarray(v), err_msg=k)
        else:
            assert back[k] == v, (k, back[k], v)


def _same_dataset(back: xr.Dataset, ds: xr.Dataset, int64=np.int64) -> None:
    """Every variable and coordinate bit for bit (float32 and float64 are written as they are:
    exact) and of its type, with its attributes (units, long names), and the Dataset's attributes.
    ``int64``: the type a format stores 64-bit integers as (netCDF-3 has none: int32)."""
    assert set(back.data_vars) == set(ds.data_vars) and set(back.coords) == set(ds.coords)
    for name in [*ds.data_vars, *ds.coords]:
        assert back[name].dims == ds[name].dims, name
        assert back[name].dtype == (int64 if ds[name].dtype == np.int64 else ds[name].dtype), name
        np.testing.assert_array_equal(back[name].values, ds[name].values, err_msg=name)
        _attrs_equal(back[name].attrs, ds[name].attrs)
    _attrs_equal(back.attrs, ds.attrs)
    assert pmmw.regions(back) == pmmw.regions(ds)


@pytest.fixture
def rendered(folder):
    ds = pmmw.render(pmmw.Scenario.load(folder / "tiny.yaml"))
    assert pmmw.regions(ds)["35 GHz"]["contrasts"]["block - ground"]["I"]["K"] is not None
    # what the round trips must carry, so that they cannot pass on an empty Dataset
    assert ds["I"].attrs["units"] == "K" and ds.x.attrs["units"] == "deg" and "regions" in ds.attrs, ds
    return ds


def test_a_rendered_dataset_saves_to_netcdf_and_reads_back(rendered, tmp_path):
    """Before, ``to_netcdf`` raised: the regions were a nested dict in ``attrs``."""
    path = tmp_path / "tiny.nc"
    rendered.to_netcdf(path, engine="scipy")  # netCDF-3, the strictest about attributes
    _same_dataset(xr.load_dataset(path, engine="scipy"), rendered, int64=np.int32)


def test_a_rendered_dataset_saves_to_zarr_and_reads_back(rendered, tmp_path):
    """The Zarr store (the test extra installs zarr): data, coordinates, units and the regions' JSON."""
    pytest.importorskip("zarr", reason="zarr is in the test extra (pyproject.toml); install it with '.[test]'")
    rendered.to_zarr(tmp_path / "tiny.zarr")
    _same_dataset(xr.open_zarr(tmp_path / "tiny.zarr").load(), rendered)


def test_a_loaded_scene_renders_overrides_as_render_does_without_rebuilding(folder):
    """Each override of a loaded scene gives the image `render` gives with the same override, bit
    for bit (same seed), and rebuilds only what it changes."""
    base = pmmw.Scenario.load(folder / "tiny.yaml")
    scene = pmmw.load(base)
    cases = [
        (dict(pose={"position": [0.2, 0, 1.5]}), {"imager.position": [0.2, 0, 1.5]}),
        (dict(frequency="95 GHz"), {"frequency": "95 GHz"}),
        (dict(materials={"concrete": {"same_as": "brick"}}), {"materials.concrete": {"same_as": "brick"}}),
    ]
    builds = []
    for kw, values in cases:
        got = scene.render(**kw)
        want = pmmw.render(base.set(values))
        np.testing.assert_array_equal(got["I"].values, want["I"].values)
        assert float(got.frequency[0]) == float(want.frequency[0])
        builds.append(dict(scene.builds))
    assert builds == [{"geometry": 1, "materials": 1}, {"geometry": 1, "materials": 1}, {"geometry": 1, "materials": 2}]
    # the control: the overrides change the image (else the comparison above proves nothing)
    plain = scene.render()
    assert not np.array_equal(plain["I"].values, scene.render(pose={"position": [0.2, 0, 1.5]})["I"].values)
    # a changed scene entry rebuilds the geometry
    scene.render(values={"scene[1].material": "brick"})
    assert scene.builds["geometry"] == 2
    with pytest.raises(pmmw.UserError, match="unknown pose key 'pos'"):
        scene.render(pose={"pos": [0, 0, 1]})


@pytest.mark.parametrize(
    "maker, antenna",
    [("antenna_kernel", {"illumination": "parabolic", "edge_taper": "10 dB"}), ("psf_kernel", None)],
)
def test_a_loaded_scene_makes_its_psf_kernel_once_per_frequency(folder, monkeypatch, maker, antenna):
    """The imager's PSF kernel is made once for two renders at one frequency (other poses, same
    pixel pitch) and the image is the one `render` gives with a kernel of its own, bit for bit (same
    seed); the control: two frequencies make two kernels. Before, every render of a loaded scene
    made its kernel again (the antenna's had no cache at all)."""
    from pmmw import pipeline

    made = []
    real = getattr(pipeline, maker)

    def counted(*args, **kwargs):
        made.append(args[1])  # the wavenumber [1/m]
        return real(*args, **kwargs)

    monkeypatch.setattr(pipeline, maker, counted)
    imager = {"imager.aperture_diameter": "0.3 m", "imager.noise": "0.5 K"}
    if antenna is not None:
        imager["imager.antenna"] = antenna
    base = pmmw.Scenario.load(folder / "tiny.yaml").set(imager)
    scene = pmmw.load(base)
    moved = {"position": [0.2, 0, 1.5]}
    first, second = scene.render(pose=moved), scene.render()
    assert len(made) == 1, made
    made.clear()
    np.testing.assert_array_equal(second["I"].values, pmmw.render(base)["I"].values)
    np.testing.assert_array_equal(
        first["I"].values, pmmw.render(base.set({"imager.position": [0.2, 0, 1.5]}))["I"].values
    )
    assert len(made) == 2, made  # `render` resolves anew each time: a kernel of its own
    # the control: another frequency is another kernel, made once too
    made.clear()
    other = pmmw.load(base)
    for f in ("35 GHz", "95 GHz", "35 GHz", "95 GHz"):
        other.render(frequency=f)
    assert len(made) == 2 and made[0] != made[1], made
