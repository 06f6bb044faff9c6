"""Equirectangular sky textures: the pixel convention, bilinear sampling, wrap-around, poles."""

from __future__ import annotations

import numpy as np
import pytest

from pmmw.errors import UserError
from pmmw.scene.sky_texture import SkyTexture, write_sky_texture

# Directions pass through atan2 on the way back to pixel coordinates, so a pixel centre is found
# again only to float64 roundoff (a few ulp of the coordinate), not bit for bit.
RTOL_ROUNDOFF = 1e-12

H, W = 6, 12


def _dirs(phi, el):
    """Unit directions (N, 3) for azimuth phi and elevation el [rad] (module convention)."""
    phi, el = np.broadcast_arrays(np.asarray(phi, float), np.asarray(el, float))
    return np.stack([np.cos(el) * np.cos(phi), np.cos(el) * np.sin(phi), np.sin(el)], axis=-1).reshape(-1, 3)


def _centres(h=H, w=W):
    """Azimuth and elevation [rad] of the pixel centres, each shape (h, w)."""
    phi = 2 * np.pi * (np.arange(w) + 0.5) / w
    el = np.pi / 2 - np.pi * (np.arange(h) + 0.5) / h
    return np.meshgrid(phi, el)


def _smooth(phi, el):
    """A known brightness map [K] of azimuth and elevation."""
    return 150.0 + 40.0 * np.cos(phi) + 25.0 * np.sin(2 * phi) + 60.0 * el


def test_pixel_centres_return_pixel_values():
    phi, el = _centres()
    tv, th = _smooth(phi, el), 2.0 * _smooth(phi, el) + 3.0
    sky = SkyTexture(tv, th)
    got_v, got_h = sky.sample(_dirs(phi, el))
    np.testing.assert_allclose(got_v, tv.ravel(), rtol=RTOL_ROUNDOFF)
    np.testing.assert_allclose(got_h, th.ravel(), rtol=RTOL_ROUNDOFF)
    np.testing.assert_allclose(sky.pixel_directions().reshape(-1, 3), _dirs(phi, el), atol=1e-15)


def test_bilinear_between_centres():
    # Linear in the column and row indices: bilinear interpolation reproduces it exactly.
    v_idx, u_idx = np.mgrid[0:H, 0:W].astype(float)
    sky = SkyTexture(100.0 + 3.0 * u_idx + 7.0 * v_idx, 50.0 + 0.5 * u_idx * v_idx)
    rng = np.random.default_rng(7)
    uc = rng.uniform(0.0, W - 1.0, 500)  # inside the columns (no wrap) ...
    vc = rng.uniform(0.0, H - 1.0, 500)  # ... and inside the rows (no pole blend)
    phi = 2 * np.pi * (uc + 0.5) / W
    el = np.pi / 2 - np.pi * (vc + 0.5) / H
    tv, th = sky.sample(_dirs(phi, el))
    np.testing.assert_allclose(tv, 100.0 + 3.0 * uc + 7.0 * vc, rtol=RTOL_ROUNDOFF)
    np.testing.assert_allclose(th, 50.0 + 0.5 * uc * vc, rtol=RTOL_ROUNDOFF)  # bilinear term too


def test_azimuth_wraps_around_at_phi_zero():
    phi, el = _centres()
    tv = _smooth(phi, el)
    sky = SkyTexture(tv, tv)
    row = 2
    e = el[row, 0]
    # phi = 0 lies halfway between the centres of the last and the first column
    at_zero, _ = sky.sample(_dirs(0.0, e))
    np.testing.assert_allclose(at_zero, 0.5 * (tv[row, -1] + tv[row, 0]), rtol=RTOL_ROUNDOFF)
    # continuous across phi = 0: approached from either side (phi = 2 pi - eps and + eps)
    eps = 1e-9
    below, _ = sky.sample(_dirs(-eps, e))
    above, _ = sky.sample(_dirs(eps, e))
    slope = np.abs(tv[row, 0] - tv[row, -1]) * W / (2 * np.pi)  # [K/rad]
    assert abs(below[0] - above[0]) <= 2 * eps * slope + 1e-9
    # a quarter of the way from the last column's centre to the first
    quarter, _ = sky.sample(_dirs(2 * np.pi - 0.25 * 2 * np.pi / W, e))
    np.testing.assert_allclose(quarter, 0.75 * tv[row, -1] + 0.25 * tv[row, 0], rtol=RTOL_ROUNDOFF)


def test_zenith_and_nadir():
    phi, el = _centres()
    tv = _smooth(phi, el)
    th = tv + 10.0 * np.sin(phi)
    sky = SkyTexture(tv, th)
    zenith = np.array([[0.0, 0.0, 1.0], [1e-14, -3e-15, 1.0], [0.0, 0.0, 5.0]])
    nadir = -zenith
    zv, zh = sky.sample(zenith)
    nv, nh = sky.sample(nadir)
    # at a pole the value is the mean of the row next to it, whatever the ray's azimuth
    np.testing.assert_allclose(zv, tv[0].mean(), rtol=RTOL_ROUNDOFF)
    np.testing.assert_allclose(zh, th[0].mean(), rtol=RTOL_ROUNDOFF)
    np.testing.assert_allclose(nv, tv[-1].mean(), rtol=RTOL_ROUNDOFF)
    np.testing.assert_allclose(nh, th[-1].mean(), rtol=RTOL_ROUNDOFF)
    # between the top row's centres and the pole: linear blend toward the pole value
    u = 3
    top_el = el[0, u]
    mid = 0.5 * (top_el + np.pi / 2)
    got, _ = sky.sample(_dirs(phi[0, u], mid))
    np.testing.assert_allclose(got, 0.5 * (tv[0, u] + tv[0].mean()), rtol=RTOL_ROUNDOFF)
    # on the top row's centres the value is the pixel's own (clamped: no blend yet)
    got, _ = sky.sample(_dirs(phi[0, u], top_el))
    np.testing.assert_allclose(got, tv[0, u], rtol=RTOL_ROUNDOFF)


def test_uniform_texture_everywhere():
    sky = SkyTexture(np.full((3, 5), 42.0), np.full((3, 5), 7.0))
    d = np.random.default_rng(1).normal(size=(1000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    tv, th = sky.sample(d)
    assert tv.shape == th.shape == (1000,)
    np.testing.assert_allclose(tv, 42.0, rtol=RTOL_ROUNDOFF)
    np.testing.assert_allclose(th, 7.0, rtol=RTOL_ROUNDOFF)


def test_file_round_trip(tmp_path):
    phi, el = _centres()
    tv = _smooth(phi, el)
    th = tv + 5.0
    path = tmp_path / "skies" / "sky.exr"
    write_sky_texture(path, tv, th)
    sky = SkyTexture.load(path)
    # stored as float32
    np.testing.assert_array_equal(sky.tv, tv.astype(np.float32).astype(np.float64))
    np.testing.assert_array_equal(sky.th, th.astype(np.float32).astype(np.float64))


def test_missing_channel_names_file_key_and_channels(tmp_path):
    from pmmw.io.exr import write_exr

    path = tmp_path / "rgb_sky.exr"
    write_exr(path, {"R": np.ones((2, 4)), "G": np.ones((2, 4)), "Tv": np.ones((2, 4))})
    with pytest.raises(UserError) as e:
        SkyTexture.load(path, key="sky.file")
    err = e.value
    assert err.file == str(path) and err.key == "sky.file"
    text = str(err)
    assert str(path) in text and "sky.file" in text
    assert "Th" in err.message and "R, G, Tv" in err.message


def test_missing_file_is_user_error(tmp_path):
    with pytest.raises(UserError) as e:
        SkyTexture.load(tmp_path / "nowhere.exr", key="sky.file")
    assert e.value.file == str(tmp_path / "nowhere.exr") and e.value.key == "sky.file"


@pytest.mark.parametrize("bad", [-1.0, np.nan, np.inf])
def test_invalid_temperatures_are_user_errors(tmp_path, bad):
    tv = np.full((2, 4), 100.0)
    tv[1, 2] = bad
    path = tmp_path / "bad_sky.exr"
    write_sky_texture(path, tv, np.full((2, 4), 100.0))
    with pytest.raises(UserError, match=r"'Tv'.*row 1, column 2") as e:
        SkyTexture.load(path, key="sky.file")
    assert e.value.file == str(path)
    with pytest.raises(ValueError):
        SkyTexture(tv, tv)
