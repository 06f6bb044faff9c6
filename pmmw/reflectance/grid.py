"""Optics Express 2016's hemispherical collection grid and the sky (h, v) basis in which `pmmw brdf`
states Stokes vectors and Mueller matrices (`pmmw.reflectance` docstring, "Grid and bases";
the convention itself is `pmmw.physics.jones`'s).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from pmmw.arrays import FloatArray
from pmmw.physics.vec import cross

__all__ = ["N_PHI", "N_THETA", "grid_directions", "mueller_from_jones", "projected_solid_angle"]

#: Optics Express 2016's collection grid: zenith rows 0..90 degrees, azimuth columns 0..359 degrees.
N_THETA, N_PHI = 91, 360


def grid_directions() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cell-centre directions of the 91 x 360 grid.

    Returns
    -------
    theta, phi : ndarray, shape (91, 360), float64
        Zenith and azimuth [rad] (rows i degrees, columns j degrees).
    w : ndarray, shape (91, 360, 3), float64
        Unit directions.
    """
    th = np.radians(np.arange(N_THETA, dtype=np.float64))[:, None] * np.ones((1, N_PHI))
    ph = np.radians(np.arange(N_PHI, dtype=np.float64))[None, :] * np.ones((N_THETA, 1))
    w = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1)
    return th, ph, w


def projected_solid_angle() -> np.ndarray:
    """``int cos(theta) dw`` over each cell [sr], shape (91, 360); sums to pi."""
    lo = np.radians(np.clip(np.arange(N_THETA) - 0.5, 0.0, 90.0))
    hi = np.radians(np.clip(np.arange(N_THETA) + 0.5, 0.0, 90.0))
    band = 0.5 * (np.sin(hi) ** 2 - np.sin(lo) ** 2) * np.radians(1.0)
    return band[:, None] * np.ones((1, N_PHI))


def _cells(d: FloatArray) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Grid cell (row, column) of upward unit directions d, shape (N, 3)."""
    th = np.degrees(np.arccos(np.clip(d[:, 2], -1.0, 1.0)))
    ph = np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 360.0
    row = np.clip(np.floor(th + 0.5).astype(np.int64), 0, N_THETA - 1)
    col = np.floor(ph + 0.5).astype(np.int64) % N_PHI
    return row, col


def _hv(k: FloatArray, phi_fallback: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Sky basis (h, v) of propagation directions k (N, 3); at the poles h follows phi_fallback."""
    h = np.stack([-k[:, 1], k[:, 0], np.zeros(k.shape[0])], axis=1)  # Z x k
    norm = np.linalg.norm(h, axis=1)
    pole = norm < 1e-12
    h = h / np.where(pole, 1.0, norm)[:, None]
    if np.any(pole):
        # limit of Z x k / |Z x k| along the azimuth phi of k's horizontal part
        phi = phi_fallback[pole]
        h[pole] = np.stack([-np.sin(phi), np.cos(phi), np.zeros(phi.shape)], axis=1)
    v = cross(k, h)
    return h, v


def mueller_from_jones(j: np.ndarray) -> np.ndarray:
    """Mueller matrices of Jones matrices in `pmmw.reflectance`'s Stokes convention.

    Parameters
    ----------
    j : ndarray, shape (N, 2, 2), complex128
        ``[[a, b], [c, d]]`` mapping incident (E1, E2) to outgoing (E1, E2).

    Returns
    -------
    ndarray, shape (N, 4, 4), float64
        ``M = A (J kron J*) A^-1`` with ``S = A (E kron E*)``, ``S = (I, Q, U, V)`` as in
        `pmmw.physics.jones` (``U = 2 Re(E1 E2*)``, ``V = 2 Im(E1 E2*)``), written out.
    """
    a, b, c, d = j[:, 0, 0], j[:, 0, 1], j[:, 1, 0], j[:, 1, 1]
    aa, bb, cc, dd = (x.real**2 + x.imag**2 for x in (a, b, c, d))
    ab, cd = a * np.conj(b), c * np.conj(d)
    ac, bd = a * np.conj(c), b * np.conj(d)
    ad, bc = a * np.conj(d), b * np.conj(c)
    m = np.empty((j.shape[0], 4, 4))
    m[:, 0, 0] = 0.5 * (aa + bb + cc + dd)
    m[:, 0, 1] = 0.5 * (aa - bb + cc - dd)
    m[:, 0, 2] = (ab + cd).real
    m[:, 0, 3] = -(ab + cd).imag
    m[:, 1, 0] = 0.5 * (aa + bb - cc - dd)
    m[:, 1, 1] = 0.5 * (aa - bb - cc + dd)
    m[:, 1, 2] = (ab - cd).real
    m[:, 1, 3] = -(ab - cd).imag
    m[:, 2, 0] = (ac + bd).real
    m[:, 2, 1] = (ac - bd).real
    m[:, 2, 2] = (ad + bc).real
    m[:, 2, 3] = -(ad - bc).imag
    m[:, 3, 0] = (ac + bd).imag
    m[:, 3, 1] = (ac - bd).imag
    m[:, 3, 2] = (ad + bc).imag
    m[:, 3, 3] = (ad - bc).real
    return m
