"""Optics Express 2016's Monte Carlo over a rough layered surface (`pmmw.reflectance` docstring, ``mc``),
traced by the renderer's own surface layer (`pmmw.surface.Surfaces`): the stack becomes one
medium of a scene's tables (its rough layers, films, roughness and substrate as the renderer
reads a material), a wavefront of rays arrives from the source direction, and the children that
leave the surface upward are binned on the grid with their Jones matrices.

The renderer's Jones matrix M of a ray is built by right-multiplication (eq. 2.35:
``M <- M B diag(a)``); read along the direction of propagation it is the transpose of the forward
Jones matrix (incident components -> current ones), with the same Fresnel and film coefficients,
bases and branch rules. Every absorber emits at 1 K, so the brightness each path deposits is the
power it loses (interfaces, films, layers, a lossy substrate, ended re-hit chains).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pmmw import rng
from pmmw.arrays import FloatArray
from pmmw.physics.jones import basis_change
from pmmw.reflectance.grid import N_PHI, N_THETA, _cells, _hv, mueller_from_jones
from pmmw.reflectance.stack import Stack
from pmmw.surface import Surfaces, Wave, kernels
from pmmw.surface.media import stack_media
from pmmw.surface.records import Choice, Faces, Hit, HitCode, Limits

__all__ = ["monte_carlo"]

# Paths are followed in chunks of this many rays (memory, not results: each sample has its own key,
# `pmmw.rng`; only the sums' last bits change with it, their terms added in another order).
_CHUNK = 1 << 17
# Facet interactions after which a path is ended and counted as lost (never reached in practice:
# reported in the summary as ``lost``).
_MAX_EVENTS = 1000
# The temperature [K] every absorber emits at: deposited brightness = absorbed power.
_T_ABSORBER = 1.0
# Offset of the children off the plane [m] (they are binned, never traced further).
_STEP = 1e-9
# Media stack of a ray: the ambient medium and the substrate.
_STACK = 4


@dataclass
class _Tally:
    by_order: np.ndarray  # (3, 91, 360, 4, 4) summed path Mueller, orders 1, 2, >= 3
    i_sum: float = 0.0  # sum over paths of reflected I (for S_in)
    i_sq: float = 0.0  # sum of squares (standard error)
    transmitted: float = 0.0  # unpolarized power into a lossless substrate
    absorbed: float = 0.0  # at interfaces, in sinks, in layers, ended re-hit chains
    lost: float = 0.0  # paths ended at _MAX_EVENTS
    events: int = 0
    fallback_weights: int = 0  # rejection fallbacks (roughness module)


def monte_carlo(
    stack: Stack,
    wi: np.ndarray,
    stokes_in: np.ndarray,
    *,
    samples: int = 1_000_000,
    seed: int = 0,
    threshold: float = 1e-3,
) -> _Tally:
    """Optics Express 2016's Monte Carlo over a rough layered surface (`pmmw.reflectance` docstring).

    Parameters
    ----------
    stack : Stack
    wi : ndarray, shape (3,), float64
        Unit direction toward the source (wi.z > 0).
    stokes_in : ndarray, shape (4,), float64
        Incident Stokes vector in the incident (h, v) basis (only for ``i_sum``/standard error;
        the Mueller matrix is independent of it).
    samples : int
        Incident rays.
    seed : int
        Run seed; sample i draws its numbers from the key of (seed, i) (`pmmw.rng.ray_keys`).
    threshold : float
        Russian roulette below this path power (the larger of the two incident polarizations'
        powers, as the renderer's ``render.threshold``; survivors scaled up: unbiased).

    Returns
    -------
    _Tally
        Sums over paths (divide by ``samples`` for fractions of the incident power).
    """
    media = stack_media(stack, _T_ABSORBER)
    faces = Faces(np.ones(1, np.int32), np.array([[0.0, 0.0, 1.0]]), np.full(1, _STEP))
    # the branch drawn by power (``stochastic``); depth counts facet events, ending at _MAX_EVENTS
    surfaces = Surfaces(
        media,
        stack.frequency or 1.0,
        faces,
        Limits(_MAX_EVENTS, float(threshold), True, 0.0, 0.0),
        Choice(kernels.STRATEGIES["stochastic"], 0),
        count_facets=True,
    )
    tally = _Tally(by_order=np.zeros((3, N_THETA, N_PHI, 4, 4)))
    phi_i = math.atan2(wi[1], wi[0])
    k_in = -np.asarray(wi, dtype=np.float64)
    h_in, v_in = _hv(k_in[None, :], np.array([phi_i + math.pi]))
    for start in range(0, samples, _CHUNK):
        n = min(_CHUNK, samples - start)
        acc, cut = np.zeros((n, 4)), np.zeros((n, 2))
        surfaces.start(acc, cut)
        m = np.zeros((n, 2, 2), complex)
        m[:, 0, 0] = m[:, 1, 1] = 1.0
        wave = Wave(
            o=np.zeros((n, 3)),
            d=np.tile(k_in, (n, 1)),
            s=np.tile(h_in[0], (n, 1)),
            p=np.tile(v_in[0], (n, 1)),
            m=m,
            sid=np.arange(n),
            depth=np.zeros(n, np.int32),
            stack=np.zeros((n, _STACK), np.int16),
            top=np.zeros(n, np.int32),
            last_t=np.full(n, _T_ABSORBER),
            key=rng.ray_keys(int(seed), np.arange(start, start + n)),  # the samples' random numbers
        )
        # every ray meets the substrate's face (medium 1) from the ambient side, as `kernels.arrive` leaves it
        hit = Hit(
            np.zeros((n, 3)),
            np.tile(faces.normal[0], (n, 1)),
            np.full(n, float(wi[2])),
            np.zeros(n, np.int64),
            np.ones(n, np.int64),
            np.ones(n, np.int64),
            np.zeros(n, bool),
            np.full(n, HitCode.INTERACTS, np.int8),
        )
        out = Wave.concat(surfaces.interact(wave, hit, np.zeros(n, np.int64), np.arange(n)))
        # the ended paths' power (`kernels.survive` at _MAX_EVENTS); the rest of what was deposited was absorbed
        lost = float(cut[:, 0].sum())
        tally.lost += lost
        tally.absorbed += 0.5 * float(acc[:, 0].sum() + acc[:, 1].sum()) / _T_ABSORBER - lost
        if out is None:
            continue
        up = out.d[:, 2] > 0.0
        if up.any():
            _collect(out.take(up), tally, stokes_in)
        if not up.all():  # into a lossless substrate (any other keeps no transmitted child)
            tally.transmitted += 0.5 * float(np.sum(np.abs(out.m[~up]) ** 2))
    tally.events, tally.fallback_weights = surfaces.events, surfaces.fallbacks
    return tally


def _collect(g: Wave, tally: _Tally, stokes_in: FloatArray) -> None:
    """Rays leaving the top surface: their forward Jones matrices (the transpose of the
    renderer's M) rotated to the outgoing (h, v) basis, their Mueller matrices binned."""
    phi = np.arctan2(g.d[:, 1], g.d[:, 0])
    h, v = _hv(g.d, phi)
    j_out = basis_change(h, v, g.s, g.p) @ np.swapaxes(g.m, 1, 2)
    mm = mueller_from_jones(j_out)
    row, col = _cells(g.d)
    flat = row * N_PHI + col
    size = N_THETA * N_PHI
    order = np.clip(g.depth, 1, 3) - 1
    for o in range(3):
        sel = order == o
        if np.any(sel):
            tally.by_order[o] += np.stack(
                [np.bincount(flat[sel], weights=mm[sel, a, b], minlength=size) for a in range(4) for b in range(4)],
                axis=-1,
            ).reshape(N_THETA, N_PHI, 4, 4)
    i_out = mm[:, 0, :] @ stokes_in
    tally.i_sum += float(i_out.sum())
    tally.i_sq += float((i_out**2).sum())
