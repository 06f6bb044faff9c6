"""Sub-pixel samples and the hash they are drawn from (`pmmw.scene.camera`, compiled): the
hash against splitmix64 written with numpy's wrapping uint64 arrays, and the sample pattern
against its definition (two R2 replicates per pixel, each rotated by its own hash)."""

from __future__ import annotations

import numpy as np

from pmmw.scene.camera import R2_ALPHA, REPLICATES, hash_uniform, pixel_samples


def _splitmix64(x):
    with np.errstate(over="ignore"):
        x = x + np.uint64(0x9E3779B97F4A7C15)
        x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return x ^ (x >> np.uint64(31))


def _reference_uniform(seed, keys, stream):
    with np.errstate(over="ignore"):
        salt = _splitmix64(np.uint64(seed) * np.uint64(0x100000001B3) + np.uint64(stream))
    h = _splitmix64(np.asarray(keys, dtype=np.uint64) ^ salt)
    return (h >> np.uint64(11)).astype(np.float64) / 2.0**53


def test_hash_uniform_is_splitmix64_bit_for_bit():
    """Equal to the last bit (integer arithmetic, then an exact scaling), for seeds up to 2^40."""
    rng = np.random.default_rng(0)
    keys = rng.integers(0, 2**62, 5000)
    for seed in (0, 1, 12345, 2**40):
        for stream in (0, 1, 2, 3, 4):
            u = hash_uniform(seed, keys, stream)
            np.testing.assert_array_equal(u, _reference_uniform(seed, keys, stream))
            assert u.min() >= 0.0 and u.max() < 1.0
    assert hash_uniform(3, keys.reshape(50, 100), 1).shape == (50, 100)


def test_pixel_samples_follow_their_definition():
    """Each sample lies in its pixel; sample s of a pixel is replicate s mod 2, point s // 2 of
    the R2 sequence shifted by that replicate's hash (to rounding of the mod 1); one sample in all
    takes the pixel centre; a later batch (adaptive sampling) continues the sequence."""
    width, seed = 37, 9
    pixels = np.array([0, 5, 36, 37, 400, 1000])
    u, v, pix = pixel_samples(width, pixels, 8, seed)
    np.testing.assert_array_equal(pix, np.repeat(pixels, 8))
    col, row = pix % width, pix // width
    assert np.all((u >= col) & (u < col + 1) & (v >= row) & (v < row + 1))
    s = np.tile(np.arange(8), pixels.size)
    key = pix * REPLICATES + s % REPLICATES
    k = s // REPLICATES
    ju = (_reference_uniform(seed, key, 1) + (k + 0.5) * R2_ALPHA[0]) % 1.0
    jv = (_reference_uniform(seed, key, 2) + (k + 0.5) * R2_ALPHA[1]) % 1.0
    np.testing.assert_allclose(u - col, ju, rtol=0, atol=1e-12)
    np.testing.assert_allclose(v - row, jv, rtol=0, atol=1e-12)
    later = pixel_samples(width, pixels, 4, seed, start=4, total=8)
    np.testing.assert_array_equal(later[0], u.reshape(-1, 8)[:, 4:].ravel())
    one = pixel_samples(width, pixels, 1, seed, total=1)
    np.testing.assert_array_equal(one[0], pixels % width + 0.5)
    np.testing.assert_array_equal(one[1], pixels // width + 0.5)


def test_image_coordinates_invert_the_pinhole_rays():
    """`Camera.image_coordinates` of points along the rays through (u, v) gives back (u, v) (to
    1e-9 pixel: rounding of a 10-degree tangent over 37 pixels) and their distance along the
    viewing direction; a point behind the imager has a negative depth."""
    from pmmw.scene.camera import Camera

    cam = Camera.look_at([1.0, -2.0, 3.0], [0.5, 8.0, 0.0], [0, 0, 1], np.radians(10.0), (37, 23))
    rng = np.random.default_rng(4)
    u, v = rng.uniform(0, 37, 200), rng.uniform(0, 23, 200)
    o, d, _, _ = cam.rays(u, v, np.arange(200), 1)
    dist = rng.uniform(0.1, 5e3, 200)
    pu, pv, depth = cam.image_coordinates(o + dist[:, None] * d)
    np.testing.assert_allclose(pu, u, rtol=0, atol=1e-9)
    np.testing.assert_allclose(pv, v, rtol=0, atol=1e-9)
    np.testing.assert_allclose(depth, dist * (d @ cam.k), rtol=1e-12)
    assert cam.image_coordinates(cam.position - cam.k[None])[2][0] < 0.0
