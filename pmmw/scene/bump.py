"""Bump maps: a height field that tilts a surface's macro normal (Murakowski 2014 sec. 2.2.6, 3.2).

Murakowski 2014's cinderblock and truck scenes put a bump map on the ground plane: a height texture
that changes the normal used for shading without changing the geometry. Here a material's
``bump:`` entry is a periodic height field ``h(u, v)`` [m] over planar coordinates: at a hit
point, ``(u, v)`` are the two world coordinates other than the dominant axis of the face's normal
(so a ground plane uses (x, y), a wall (y, z) or (x, z)), and the shading normal is::

    n' = unit(n - dh/du t_u - dh/dv t_v)

with ``t_u``, ``t_v`` the world u and v axes projected onto the face's plane: the normal of the
surface ``z = h(x, y)`` for a horizontal face, to first order in the slope for tilted ones.

The renderer then uses ``n'`` wherever it would use the face normal: Fresnel angle, reflection
and refraction, the local polarization basis, and as the macro normal of a ``roughness:`` model.
A child that leaves on the wrong side of the *geometric* face (possible where the bump tilts
the normal by more than the grazing angle) is mirrored back through the face's plane, which
keeps its power: nothing is lost or created, only its direction changes (the usual shading-
normal compromise; a microfacet ``roughness:`` without bump needs none of it).

Records
-------
``{model: gaussian, rms: 3 mm, correlation: 3 cm, size: 1 m, seed: 0}``
    A Gaussian random surface of RMS height ``rms`` and Gaussian autocorrelation
    ``exp(-r^2 / correlation^2)`` (RMS slope ``sqrt(2) rms / correlation``), periodic over a
    ``size`` square, synthesized by filtering white noise in the Fourier domain.
``{texture: FILE, height: 5 mm, size: 1 m}``
    An image (its first channel, as OpenImageIO reads it: 8-bit PNG 0..255 -> 0..1, EXR as
    stored) scaled by ``height``, tiled every ``size``; FILE is relative to the file that names it.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from pmmw.errors import UserError, UserErrors
from pmmw.jit import inline, njit

__all__ = ["BumpMap", "make_bump"]

_MAX_GRID = 2048  # grid points per side of a synthesized surface
_POINTS_PER_CORRELATION = 8


class BumpMap:
    """A periodic height field and its gradient on a square grid.

    Parameters
    ----------
    heights : ndarray, shape (N, M), float64
        Heights [m]; row index along v, column index along u.
    size : float
        Period of the field in u and v [m] (one grid covers size x size).
    description : str
        What it is, for ``pmmw materials show`` and error messages.
    """

    def __init__(self, heights, size: float, description: str = ""):
        h = np.asarray(heights, dtype=np.float64)
        self.digest = hashlib.sha256(np.ascontiguousarray(h).tobytes() + repr(size).encode()).hexdigest()[:12]
        self.size = float(size)
        self.description = description
        nv, nu = h.shape
        self.du, self.dv = self.size / nu, self.size / nv
        # central differences on the periodic grid [m/m]
        self.gu = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / (2.0 * self.du)
        self.gv = (np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0)) / (2.0 * self.dv)
        # RMS slope along one direction (sqrt(2) rms / correlation for a Gaussian surface)
        self.rms_slope = float(np.sqrt(np.mean(self.gu**2 + self.gv**2) / 2.0))

    def __repr__(self):
        return f"BumpMap({self.description}, RMS slope {self.rms_slope:.3g}, heights {self.digest})"

    def perturb(self, pos, normals):
        """Shading normals at hit points.

        Parameters
        ----------
        pos : ndarray, shape (n, 3), float64
            Hit points [m].
        normals : ndarray, shape (n, 3), float64
            Unit geometric normals (either orientation; the result keeps it).

        Returns
        -------
        ndarray, shape (n, 3), float64
            Unit shading normals, on the same side of the face as ``normals``.
        """
        normals = np.ascontiguousarray(normals, dtype=np.float64)
        out = np.empty_like(normals)
        _perturb_rows(np.ascontiguousarray(pos, dtype=np.float64), normals, self.gu, self.gv, self.du, self.dv, out)
        return out

    def shade(self, pos, normals, d):
        """The shading normals the renderer uses: `perturb`'s where the ray ``d`` (shape (n, 3),
        toward the surface) meets the tilted normal's front (``d . n' < 0``), the geometric
        normal where the tilt exceeds the incidence (the ray would meet the back of the bump:
        shading normals cannot model that shadowing)."""
        normals = np.ascontiguousarray(normals, dtype=np.float64)
        out = np.empty_like(normals)
        _shade_rows(
            np.ascontiguousarray(pos, dtype=np.float64),
            normals,
            np.ascontiguousarray(d, dtype=np.float64),
            self.gu,
            self.gv,
            self.du,
            self.dv,
            out,
        )
        return out


@inline()
def _bilinear(grid, x, y):
    """Bilinear, periodic interpolation of a grid at (x, y) in grid steps."""
    nv, nu = grid.shape
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0
    i0, j0 = int(x0 % nu), int(y0 % nv)
    i1, j1 = (i0 + 1) % nu, (j0 + 1) % nv
    return (
        (1 - fx) * (1 - fy) * grid[j0, i0]
        + fx * (1 - fy) * grid[j0, i1]
        + (1 - fx) * fy * grid[j1, i0]
        + fx * fy * grid[j1, i1]
    )


@inline()
def _perturb1(pos, normals, i, grad_u, grad_v, du, dv):
    """`BumpMap.perturb` of hit point i: the unit shading normal as three floats.

    ``(u, v)`` are the two world coordinates after the dominant axis of the normal; the slopes
    are flipped with the normal so that both orientations of a face see the same bumps; the
    shading normal is ``unit(n - dh/du t_u - dh/dv t_v)`` with ``t_u``, ``t_v`` the world u and v
    axes projected onto the face's plane (module docstring).
    """
    n = normals[i]
    axis = 0
    if abs(n[1]) > abs(n[axis]):
        axis = 1
    if abs(n[2]) > abs(n[axis]):
        axis = 2
    iu, iv = (axis + 1) % 3, (axis + 2) % 3
    x, y = pos[i, iu] / du, pos[i, iv] / dv
    sign = 1.0 if n[axis] > 0.0 else (-1.0 if n[axis] < 0.0 else 0.0)
    gu = _bilinear(grad_u, x, y) * sign
    gv = _bilinear(grad_v, x, y) * sign
    o0 = n[0] - gu * ((1.0 if iu == 0 else 0.0) - n[iu] * n[0]) - gv * ((1.0 if iv == 0 else 0.0) - n[iv] * n[0])
    o1 = n[1] - gu * ((1.0 if iu == 1 else 0.0) - n[iu] * n[1]) - gv * ((1.0 if iv == 1 else 0.0) - n[iv] * n[1])
    o2 = n[2] - gu * ((1.0 if iu == 2 else 0.0) - n[iu] * n[2]) - gv * ((1.0 if iv == 2 else 0.0) - n[iv] * n[2])
    norm = math.sqrt(o0 * o0 + o1 * o1 + o2 * o2)
    return o0 / norm, o1 / norm, o2 / norm


@njit()
def _perturb_rows(pos, normals, grad_u, grad_v, du, dv, out):
    """`_perturb1` of every hit point (compiled: it runs at every bumped interaction)."""
    for i in range(pos.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = _perturb1(pos, normals, i, grad_u, grad_v, du, dv)


@njit()
def _shade_rows(pos, normals, d, grad_u, grad_v, du, dv, out):
    """`BumpMap.shade` per hit point."""
    for i in range(pos.shape[0]):
        o0, o1, o2 = _perturb1(pos, normals, i, grad_u, grad_v, du, dv)
        if d[i, 0] * o0 + d[i, 1] * o1 + d[i, 2] * o2 < 0.0:
            out[i, 0], out[i, 1], out[i, 2] = o0, o1, o2
        else:
            out[i, 0], out[i, 1], out[i, 2] = normals[i, 0], normals[i, 1], normals[i, 2]


def gaussian_surface(rms: float, correlation: float, size: float, seed: int = 0) -> np.ndarray:
    """Periodic Gaussian random heights [m] with autocorrelation ``rms^2 exp(-r^2/correlation^2)``.

    White noise filtered by the square root of the Gaussian power spectrum
    ``exp(-k^2 correlation^2 / 4)``, rescaled to the exact RMS. Grid spacing correlation / 8.
    """
    n = int(min(_MAX_GRID, max(16, math.ceil(size / correlation * _POINTS_PER_CORRELATION))))
    n += n % 2
    rng = np.random.default_rng(seed)
    k = 2.0 * np.pi * np.fft.fftfreq(n, d=size / n)
    k2 = k[:, None] ** 2 + k[None, :] ** 2
    spectrum = np.fft.fft2(rng.standard_normal((n, n))) * np.exp(-k2 * correlation**2 / 8.0)
    h = np.fft.ifft2(spectrum).real
    h -= h.mean()
    return h * (rms / max(float(np.sqrt(np.mean(h * h))), 1e-300))


def _length(spec, name, file, key, errors, required=True):
    from pmmw.units import parse_quantity

    if name not in spec:
        if required:
            errors.append(UserError(f"missing {name} (a length, e.g. 5 mm)", file, f"{key}.{name}"))
        return None
    try:
        value = parse_quantity(spec[name], "length", file=file, key=f"{key}.{name}")
    except UserError as ex:
        errors.append(ex)
        return None
    if not (math.isfinite(value) and value > 0.0):
        errors.append(UserError(f"{name} must be a positive length, got {spec[name]!r}", file, f"{key}.{name}"))
        return None
    return value


def make_bump(spec, *, file=None, key=None) -> BumpMap:
    """Build a bump map from its YAML record (module docstring).

    Raises
    ------
    UserError or UserErrors
        Not a mapping, unknown keys, missing or bad lengths, an unreadable texture, or a
        correlation length too small for the surface size (more than 2048 grid points a side).
    """
    key = key or "bump"
    if not isinstance(spec, Mapping):
        raise UserError(
            "a bump entry is {model: gaussian, rms: 3 mm, correlation: 3 cm, size: 1 m} "
            f"or {{texture: FILE, height: 5 mm, size: 1 m}}, got {spec!r}",
            file,
            key,
        )
    errors: list[UserError] = []
    if "texture" in spec:
        allowed = ("texture", "height", "size")
    else:
        model = spec.get("model")
        if model != "gaussian":
            raise UserError(
                f"unknown bump model {model!r}: use `model: gaussian` or `texture: FILE`", file, f"{key}.model"
            )
        allowed = ("model", "rms", "correlation", "size", "seed")
    for k in spec:
        if k not in allowed:
            errors.append(
                UserError(f"unknown key {k!r} for this bump map (allowed: {', '.join(allowed)})", file, f"{key}.{k}")
            )
    size = _length(spec, "size", file, key, errors)
    if "texture" in spec:
        height = _length(spec, "height", file, key, errors)
        if errors:
            raise errors[0] if len(errors) == 1 else UserErrors(errors)
        from pmmw.io.exr import read_exr

        path = Path(spec["texture"])
        if file is not None and not path.is_absolute():
            path = Path(file).parent / path
        channels, _ = read_exr(path, key=f"{key}.texture")
        first = np.asarray(next(iter(channels.values())), dtype=np.float64)
        if not np.all(np.isfinite(first)):
            raise UserError("the height texture holds non-finite values", path, f"{key}.texture")
        return BumpMap(first * height, size, f"texture {path.name}, height {height:g} m, size {size:g} m")
    rms = _length(spec, "rms", file, key, errors)
    corr = _length(spec, "correlation", file, key, errors)
    seed = spec.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int):
        errors.append(UserError(f"seed must be an integer, got {seed!r}", file, f"{key}.seed"))
    if size is not None and corr is not None and size / corr * _POINTS_PER_CORRELATION > _MAX_GRID:
        errors.append(
            UserError(
                f"size / correlation = {size / corr:.0f} is too large (at most {_MAX_GRID // _POINTS_PER_CORRELATION}): "
                "the surface repeats every `size`, so a smaller size tiles the same statistics",
                file,
                f"{key}.size",
            )
        )
    if errors:
        raise errors[0] if len(errors) == 1 else UserErrors(errors)
    return BumpMap(
        gaussian_surface(rms, corr, size, seed),
        size,
        f"gaussian, rms {rms:g} m, correlation {corr:g} m, size {size:g} m",
    )
