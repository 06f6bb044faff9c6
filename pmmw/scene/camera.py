"""Imager pose, pixel grid and primary rays.

The imager is a pinhole with a horizontal field of view ``fov`` and square pixels. Pixel (i, j)
has column i (0 = left) and row j (0 = top). Its basis is x = image right, y = image up,
k_view = viewing direction (see `pmmw.physics.jones` for the polarization convention).

Sub-pixel positions come from the R2 low-discrepancy sequence (Roberts 2018) with a
Cranley-Patterson rotation drawn per pixel from a hash of (seed, pixel): every pixel's samples
depend only on the run seed and the pixel, never on tiling or worker count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pmmw.jit import njit
from pmmw.rng import Purpose
from pmmw.rng import hash_uniform1 as _hash_uniform1

# the camera's streams of `pmmw.rng` (compile-time constants in the kernels)
_PIXEL_U, _PIXEL_V, _LENS_R, _LENS_PHI = (
    int(p) for p in (Purpose.PIXEL_U, Purpose.PIXEL_V, Purpose.LENS_R, Purpose.LENS_PHI)
)

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
        return cls(
            position,
            x,
            y,
            k,
            float(fov),
            int(resolution[0]),
            int(resolution[1]),
            float(aperture_radius),
            focus_distance,
        )

    def rays(self, u, v, keys, seed: int):
        """Primary rays through image-plane positions, with depth of field when focused, and
        each ray's polarization basis (compiled, one pass).

        Without ``focus_distance`` every ray starts at the pinhole. With it (thin lens), a ray
        starts at a point of the aperture disk, drawn from the hash of (seed, key), and passes
        through the point that the pinhole ray meets on the plane of focus: objects at the focus
        distance are sharp, others are blurred by the geometric defocus of the aperture.

        The basis is the pixel's (s, p) of `pmmw.physics.jones`: s the imager's x projected
        perpendicular to the ray and normalized, p = k x s with k = -d the direction the wave
        travels, so that a path's Jones matrix starts as the identity (Murakowski 2014 eq. 2.11b).

        Parameters
        ----------
        u, v : ndarray, shape (n,)
            Continuous pixel coordinates: u in [0, width) from the left, v in [0, height) from
            the top.
        keys : ndarray, shape (n,), int64
            A unique number per (pixel, sample), for the aperture position.
        seed : int

        Returns
        -------
        origins, directions, s, p : ndarray, shape (n, 3), float64
        """
        n = np.shape(u)[0]
        o, d, s, p = (np.empty((n, 3)) for _ in range(4))
        lens = self.focus_distance is not None and self.aperture_radius > 0.0
        _rays_loop(
            np.ascontiguousarray(u, float),
            np.ascontiguousarray(v, float),
            np.ascontiguousarray(keys, np.int64),
            np.int64(seed),
            self.position,
            self.x,
            self.y,
            self.k,
            np.tan(self.fov / 2.0),
            float(self.width),
            float(self.height),
            self.aperture_radius if lens else 0.0,
            float(self.focus_distance) if lens else 0.0,
            o,
            d,
            s,
            p,
        )
        return o, d, s, p

    def image_coordinates(self, points):
        """Where world points appear on the image through the pinhole: the inverse of `rays`'
        direction through (u, v). Returns continuous pixel coordinates u, v (as `rays` takes
        them) and the depth along the viewing direction [m], each of shape (n,); u and v are
        meaningful only where the depth is positive (in front of the imager)."""
        rel = np.asarray(points, float) - self.position
        depth = rel @ self.k
        half = np.tan(self.fov / 2.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (rel @ self.x / depth / half + 1.0) * (self.width / 2.0)
            v = (self.height - rel @ self.y / depth / half * self.width) / 2.0
        return u, v, depth

    @property
    def pixel_angle(self) -> float:
        """Angular width of a pixel at the image centre [rad]."""
        return 2.0 * np.arctan(np.tan(self.fov / 2.0) / self.width)


@njit()
def _rays_loop(u, v, keys, seed, position, x, y, k, half, width, height, radius, focus, o, d, s, p):
    """`Camera.rays` per ray: the pinhole direction through (u, v) (square pixels, ``half`` =
    tan(fov / 2)); with ``radius`` > 0 the thin lens (origin on the aperture disk, through the
    pinhole ray's point at ``focus`` along k); then s and p."""
    for i in range(u.shape[0]):
        a = (2.0 * u[i] / width - 1.0) * half
        b = (height - 2.0 * v[i]) / width * half
        dx, dy, dz = k[0] + a * x[0] + b * y[0], k[1] + a * x[1] + b * y[1], k[2] + a * x[2] + b * y[2]
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        dx, dy, dz = dx / norm, dy / norm, dz / norm
        ox, oy, oz = position[0], position[1], position[2]
        if radius > 0.0:
            t = focus / (dx * k[0] + dy * k[1] + dz * k[2])
            fx, fy, fz = ox + t * dx, oy + t * dy, oz + t * dz
            r = radius * math.sqrt(_hash_uniform1(seed, keys[i], _LENS_R))
            phi = 2.0 * math.pi * _hash_uniform1(seed, keys[i], _LENS_PHI)
            ca, sa = r * math.cos(phi), r * math.sin(phi)
            ox, oy, oz = ox + ca * x[0] + sa * y[0], oy + ca * x[1] + sa * y[1], oz + ca * x[2] + sa * y[2]
            dx, dy, dz = fx - ox, fy - oy, fz - oz
            norm = math.sqrt(dx * dx + dy * dy + dz * dz)
            dx, dy, dz = dx / norm, dy / norm, dz / norm
        xd = x[0] * dx + x[1] * dy + x[2] * dz
        sx, sy, sz = x[0] - xd * dx, x[1] - xd * dy, x[2] - xd * dz
        norm = math.sqrt(sx * sx + sy * sy + sz * sz)
        sx, sy, sz = sx / norm, sy / norm, sz / norm
        o[i, 0], o[i, 1], o[i, 2] = ox, oy, oz
        d[i, 0], d[i, 1], d[i, 2] = dx, dy, dz
        s[i, 0], s[i, 1], s[i, 2] = sx, sy, sz
        # p = k x s with k = -d
        p[i, 0] = -(dy * sz - dz * sy)
        p[i, 1] = -(dz * sx - dx * sz)
        p[i, 2] = -(dx * sy - dy * sx)


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
            u[i] = col + (_hash_uniform1(seed, key, _PIXEL_U) + (k + 0.5) * alpha_u) % 1.0
            v[i] = row + (_hash_uniform1(seed, key, _PIXEL_V) + (k + 0.5) * alpha_v) % 1.0


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
    _pixel_samples(
        int(width),
        pixels,
        int(spp),
        np.int64(seed),
        int(start),
        centre,
        float(R2_ALPHA[0]),
        float(R2_ALPHA[1]),
        u,
        v,
        pix,
    )
    return u, v, pix
