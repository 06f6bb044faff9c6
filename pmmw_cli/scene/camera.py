"""Imager pose, pixel grid and primary rays.

The imager is a pinhole with a horizontal field of view ``fov`` and square pixels. Pixel (i, j)
has column i (0 = left) and row j (0 = top). Its basis is x = image right, y = image up,
k_view = viewing direction (see `pmmw_cli.physics.jones` for the polarization convention).

Sub-pixel positions come from the R2 low-discrepancy sequence (Roberts 2018) with a
Cranley-Patterson rotation drawn per pixel from a hash of (seed, pixel): every pixel's samples
depend only on the run seed and the pixel, never on tiling or worker count.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pmmw_cli.jit import njit

# R2 sequence: fractional parts of k / g and k / g^2, g the plastic number (root of x^3 = x + 1).
_G = 1.32471795724474602596
R2_ALPHA = np.array([1.0 / _G, 1.0 / (_G * _G)])
#: Independently rotated R2 sequences per pixel (`pixel_samples`); sample s belongs to s % 2.
REPLICATES = 2


@dataclass(frozen=True)
class Camera:
    """A pinhole imager.

    Attributes
    ----------
    position : ndarray, shape (3,) [m]
    x, y, k : ndarray, shape (3,)
        Unit vectors: image right, image up, viewing direction (x, y, -k right-handed).
    fov : float
        Horizontal field of view [rad].
    width, height : int
        Resolution [pixels].
    """

    position: np.ndarray
    x: np.ndarray
    y: np.ndarray
    k: np.ndarray
    fov: float
    width: int
    height: int
    aperture_radius: float = 0.0
    focus_distance: float | None = None

    @classmethod
    def look_at(cls, position, look_at, up, fov, resolution, aperture_radius=0.0, focus_distance=None):
        position = np.asarray(position, float)
        k = np.asarray(look_at, float) - position
        k /= np.linalg.norm(k)
        x = np.cross(k, np.asarray(up, float))
        x /= np.linalg.norm(x)
        y = np.cross(x, k)
        return cls(position, x, y, k, float(fov), int(resolution[0]), int(resolution[1]),
                   float(aperture_radius), focus_distance)

    def rays(self, u, v, keys, seed: int):
        """Primary rays through image-plane positions, with depth of field when focused.

        Without ``focus_distance`` every ray starts at the pinhole. With it (thin lens), a ray
        starts at a point of the aperture disk, drawn from the hash of (seed, key), and passes
        through the point that the pinhole ray meets on the plane of focus: objects at the focus
        distance are sharp, others are blurred by the geometric defocus of the aperture.

        Parameters
        ----------
        u, v : ndarray, shape (n,)
            Continuous pixel coordinates.
        keys : ndarray, shape (n,), int64
            A unique number per (pixel, sample), for the aperture position.
        seed : int

        Returns
        -------
        origins, directions : ndarray, shape (n, 3), float64
        """
        d = self.directions(u, v)
        o = np.repeat(self.position[None, :], d.shape[0], axis=0)
        if self.focus_distance is None or self.aperture_radius <= 0.0:
            return o, d
        focus = o + d * (self.focus_distance / (d @ self.k))[:, None]
        r = self.aperture_radius * np.sqrt(hash_uniform(seed, keys, stream=3))
        phi = 2.0 * np.pi * hash_uniform(seed, keys, stream=4)
        o = o + (r * np.cos(phi))[:, None] * self.x + (r * np.sin(phi))[:, None] * self.y
        d = focus - o
        return o, d / np.linalg.norm(d, axis=1, keepdims=True)

    @property
    def pixel_angle(self) -> float:
        """Angular width of a pixel at the image centre [rad]."""
        return 2.0 * np.arctan(np.tan(self.fov / 2.0) / self.width)

    def directions(self, u, v):
        """Unit viewing directions through image-plane positions.

        Parameters
        ----------
        u, v : ndarray, shape (n,), float64
            Continuous pixel coordinates: u in [0, width) from the left, v in [0, height) from the top.

        Returns
        -------
        ndarray, shape (n, 3), float64
        """
        half = np.tan(self.fov / 2.0)
        a = (2.0 * u / self.width - 1.0) * half
        b = (self.height - 2.0 * v) / self.width * half  # square pixels
        d = self.k[None, :] + a[:, None] * self.x[None, :] + b[:, None] * self.y[None, :]
        return d / np.linalg.norm(d, axis=1, keepdims=True)


_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_FNV = np.uint64(0x100000001B3)


@njit(inline="always")
def _splitmix64(x):
    """The splitmix64 finalizer of one uint64 (a good integer hash; arithmetic wraps)."""
    x = x + _GOLDEN
    x = (x ^ (x >> np.uint64(30))) * _MIX1
    x = (x ^ (x >> np.uint64(27))) * _MIX2
    return x ^ (x >> np.uint64(31))


@njit(inline="always")
def _hash_uniform1(seed, key, stream):
    """A uniform [0, 1) float from the hash of (seed, stream, key) (`hash_uniform` of one key)."""
    h = _splitmix64(np.uint64(key) ^ _splitmix64(np.uint64(seed) * _FNV + np.uint64(stream)))
    return float(h >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit()
def _hash_uniform_loop(seed, keys, stream, out):
    for i in range(keys.shape[0]):
        out[i] = _hash_uniform1(seed, keys[i], stream)


def hash_uniform(seed: int, keys, stream: int = 0):
    """Uniform [0, 1) floats from a hash of (seed, stream, key), shape of ``keys`` (compiled)."""
    k = np.asarray(keys, dtype=np.int64)
    out = np.empty(k.shape)
    _hash_uniform_loop(np.int64(seed), np.ascontiguousarray(k).reshape(-1), np.int64(stream), out.reshape(-1))
    return out


@njit()
def _pixel_samples(width, pixels, spp, seed, start, centre, alpha_u, alpha_v, u, v, pix):
    """`pixel_samples` per sample: pixel centres, or two R2 replicates with their rotations."""
    for a in range(pixels.shape[0]):
        px = pixels[a]
        col, row = float(px % width), float(px // width)
        for b in range(spp):
            i = a * spp + b
            pix[i] = px
            if centre:
                u[i], v[i] = col + 0.5, row + 0.5
                continue
            s = start + b
            key = px * REPLICATES + s % REPLICATES
            k = float(s // REPLICATES)
            u[i] = col + (_hash_uniform1(seed, key, 1) + (k + 0.5) * alpha_u) % 1.0
            v[i] = row + (_hash_uniform1(seed, key, 2) + (k + 0.5) * alpha_v) % 1.0


def pixel_samples(width: int, pixels, spp: int, seed: int, start: int = 0, total: int | None = None):
    """Sub-pixel sample positions for a set of pixels.

    Randomized quasi-Monte Carlo: even and odd sample numbers form two replicates, each the R2
    low-discrepancy sequence (Roberts 2018) shifted by its own random rotation per pixel
    (Cranley and Patterson 1976). Within a replicate the points fill the pixel evenly; the two
    replicates' means are independent, unbiased estimates of the pixel, so half their
    difference estimates the standard error of the pixel mean (the integrator's
    ``TileResult.replicate_diff``), where the spread of single samples would overstate it.

    Parameters
    ----------
    width : int
        Image width [pixels] (pixel index = row * width + column).
    pixels : ndarray, shape (p,), int64
        Flat pixel indices.
    spp : int
        Samples per pixel to make now: sample numbers ``start .. start + spp - 1`` of the
        pixel's sequence (adaptive sampling asks for more later without repeating any).
    seed : int
    start : int
        First sample number.
    total : int, optional
        Samples the pixel gets in all; when 1, the pixel centre is used.

    Returns
    -------
    u, v : ndarray, shape (p * spp,), float64
        Continuous pixel coordinates, sample-major within each pixel.
    pix : ndarray, shape (p * spp,), int64
        The pixel index of each sample.
    """
    pixels = np.ascontiguousarray(pixels, dtype=np.int64)
    n = pixels.size * spp
    u, v, pix = np.empty(n), np.empty(n), np.empty(n, np.int64)
    centre = (total if total is not None else start + spp) == 1
    _pixel_samples(int(width), pixels, int(spp), np.int64(seed), int(start), centre, float(R2_ALPHA[0]),
                   float(R2_ALPHA[1]), u, v, pix)
    return u, v, pix
