"""A user's polarized sky map: an equirectangular EXR with channels ``Tv`` and ``Th`` [K].

``Tv`` and ``Th`` are the Rayleigh-Jeans brightness temperatures [K] of the vertical and
horizontal polarizations, in the sky basis of `pmmw.physics.jones` (h = Z x k / |Z x k|,
v = k x h).

Mapping convention
------------------
World frame Z up. For a map of H rows and W columns, pixel (v, u) (row v, column u) is centred on

* azimuth ``phi = 2 pi (u + 0.5) / W`` [rad], measured from +X toward +Y;
* elevation ``el = pi/2 - pi (v + 0.5) / H`` [rad]: the top row is next to the zenith, the
  bottom row next to the nadir.

A direction d = (cos el cos phi, cos el sin phi, sin el) is sampled bilinearly between the four
nearest pixel centres, wrapping around in azimuth (column W - 1 neighbours column 0). In
elevation the map is clamped to its first and last rows, except within half a row of a pole:
there the value blends linearly in elevation toward the mean of the top (bottom) row, which is the
value at the zenith (nadir) itself. So a near-vertical ray's arbitrary azimuth does not matter and
the map is continuous over the whole sphere.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from pmmw.errors import UserError
from pmmw.io.exr import read_exr, write_exr
from pmmw.units import TEMPERATURE_MAX

#: Channel names of a sky texture: vertical and horizontal polarization [K].
SKY_CHANNELS = ("Tv", "Th")

_TWO_PI = 2.0 * np.pi

#: [bytes] per pixel a sky texture takes beyond reading its two float32 channels: the float64
#: maps Tv and Th (16, kept by the render) and the temperature check's masks (~4).
LOAD_BYTES_PER_PIXEL = 24
#: [bytes] per pixel a loaded sky texture holds (the float64 maps Tv and Th).
BYTES_PER_PIXEL = 16


def _check_temperatures(name: str, t: np.ndarray) -> str | None:
    """A description of the first bad pixel of a temperature map, or None if all are valid."""
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(t) | (t < 0.0) | (t > TEMPERATURE_MAX)
    if not bad.any():
        return None
    v, u = np.argwhere(bad)[0]
    return (
        f"channel {name!r} has {int(bad.sum())} negative, too hot or non-finite pixel(s), the first at "
        f"row {v}, column {u}: {t[v, u]} (temperatures must be finite, 0 K to {TEMPERATURE_MAX:g} K)"
    )


class SkyTexture:
    """Equirectangular polarized sky map (convention in the module docstring).

    Parameters
    ----------
    tv, th : array_like, shape (H, W), float64
        Vertical and horizontal brightness temperatures [K], finite and >= 0.
    """

    def __init__(self, tv, th):
        tv = np.array(tv, dtype=np.float64)
        th = np.array(th, dtype=np.float64)
        if tv.ndim != 2 or tv.shape != th.shape or tv.size == 0:
            raise ValueError(f"Tv and Th must be non-empty (H, W) maps of one shape; got {tv.shape}, {th.shape}")
        for name, t in zip(SKY_CHANNELS, (tv, th)):
            problem = _check_temperatures(name, t)
            if problem:
                raise ValueError(problem)
        self.tv = tv
        self.th = th
        self.height, self.width = tv.shape
        # Values at the poles: the mean of the row next to each pole.
        self._pole_tv = (tv[0].mean(), tv[-1].mean())
        self._pole_th = (th[0].mean(), th[-1].mean())

    @classmethod
    def load(cls, path: str | os.PathLike, *, key: str = "sky.file") -> "SkyTexture":
        """Read a sky texture file (an image with channels ``Tv`` and ``Th`` [K]).

        Raises
        ------
        UserError
            The file is missing or unreadable, lacks a channel, or holds a negative or non-finite
            temperature; located by ``path`` and the scenario ``key`` that named it.
        """
        path = Path(path)
        channels, _ = read_exr(path, key=key, channels=SKY_CHANNELS, bytes_per_pixel=LOAD_BYTES_PER_PIXEL)
        missing = [c for c in SKY_CHANNELS if c not in channels]
        if missing:
            from pmmw.io.exr import image_size

            have = image_size(path, key=key)[2]
            raise UserError(
                f"sky texture lacks channel(s) {', '.join(missing)}: a sky texture needs channels "
                f"'Tv' and 'Th' (vertical and horizontal brightness temperature [K]); "
                f"this file has: {', '.join(have) or 'none'}",
                file=path,
                key=key,
            )
        try:  # the float64 maps made and checked once, from the float32 channels
            return cls(*(channels.pop(c) for c in SKY_CHANNELS))
        except ValueError as e:
            raise UserError(f"sky texture: {e}", file=path, key=key) from None

    def pixel_directions(self) -> np.ndarray:
        """Unit directions of the pixel centres, shape (H, W, 3), float64 (module convention)."""
        u = np.arange(self.width)
        v = np.arange(self.height)
        phi = _TWO_PI * (u + 0.5) / self.width
        el = 0.5 * np.pi - np.pi * (v + 0.5) / self.height
        phi, el = np.meshgrid(phi, el)
        return np.stack([np.cos(el) * np.cos(phi), np.cos(el) * np.sin(phi), np.sin(el)], axis=-1)

    def sample(self, directions) -> tuple[np.ndarray, np.ndarray]:
        """Brightness temperatures seen along directions.

        Parameters
        ----------
        directions : ndarray, shape (N, 3), float64
            Directions in the world frame (unit length; only the direction matters).

        Returns
        -------
        tv, th : ndarray, shape (N,), float64
            Vertical and horizontal brightness temperatures [K].
        """
        d = np.asarray(directions, dtype=np.float64)
        x, y, z = d[:, 0], d[:, 1], d[:, 2]
        h, w = self.height, self.width
        phi = np.mod(np.arctan2(y, x), _TWO_PI)
        el = np.arctan2(z, np.hypot(x, y))  # accurate near the poles, unlike arcsin(z)

        # Continuous pixel coordinates: pixel centres sit at integers.
        uc = phi * (w / _TWO_PI) - 0.5
        vc = (0.5 * np.pi - el) * (h / np.pi) - 0.5  # in [-0.5, h - 0.5]

        u0f = np.floor(uc)
        fu = uc - u0f
        u0 = np.mod(u0f.astype(np.int64), w)
        u1 = np.mod(u0 + 1, w)

        vcl = np.clip(vc, 0.0, h - 1.0)
        v0 = np.minimum(np.floor(vcl).astype(np.int64), h - 1)
        fv = vcl - v0
        v1 = np.minimum(v0 + 1, h - 1)

        # Weight of the pole value within half a row of the zenith (vc < 0) or nadir (vc > h - 1).
        w_zenith = np.clip(-2.0 * vc, 0.0, 1.0)
        w_nadir = np.clip(2.0 * (vc - (h - 1.0)), 0.0, 1.0)

        out = []
        for t, (pole_zenith, pole_nadir) in ((self.tv, self._pole_tv), (self.th, self._pole_th)):
            top = (1.0 - fu) * t[v0, u0] + fu * t[v0, u1]
            bottom = (1.0 - fu) * t[v1, u0] + fu * t[v1, u1]
            val = (1.0 - fv) * top + fv * bottom
            val = val + w_zenith * (pole_zenith - val) + w_nadir * (pole_nadir - val)
            out.append(val)
        return out[0], out[1]


def write_sky_texture(path: str | os.PathLike, tv, th) -> None:
    """Write a sky texture EXR (channels ``Tv``, ``Th`` [K], module convention), atomically.

    Parameters
    ----------
    tv, th : array_like, shape (H, W), float
        Vertical and horizontal brightness temperatures [K]; stored as float32.
    """
    tv = np.asarray(tv)
    th = np.asarray(th)
    if tv.ndim != 2 or tv.shape != th.shape:
        raise ValueError(f"Tv and Th must be (H, W) maps of one shape; got {tv.shape}, {th.shape}")
    write_exr(
        path,
        {"Tv": tv, "Th": th},
        {
            "pmmw:units": "K",
            "pmmw:content": "sky texture: Tv, Th brightness temperatures",
            "pmmw:mapping": "equirectangular; column u: azimuth 2pi(u+0.5)/W from +X toward +Y; "
            "row v: elevation pi/2 - pi(v+0.5)/H (top row at the zenith); Z up",
        },
    )
