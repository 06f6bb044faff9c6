"""The records the compiled kernels take (`pmmw.surface.kernels`, `pmmw.trace.kernels`), named as the equations name them.

numba passes a named tuple as cheaply as a plain one (a heterogeneous tuple type whose fields are
read by name), so the kernels read ``wave.m`` or ``hit.cos1`` instead of ``wave[4]`` or
``hit[2]``. Every caller builds them with the same field types (`Hit.empty`, `Wave.arrays`, the tables of
`surface.tables.kernel_tables`), so that nothing is compiled twice.
`HitCode` names what `kernels.arrive` decided for each ray.
"""

from __future__ import annotations

from enum import IntEnum
from typing import NamedTuple

import numpy as np

__all__ = ["Faces", "Hit", "HitCode", "Limits", "MediaTable", "WaveArrays"]


class HitCode(IntEnum):
    """What happened to a ray at the end of its segment (`kernels.arrive`, ``Hit.code``)."""

    MISSED = 0  # no face: the sky's or the atmosphere's
    PASSED = 1  # crossed the face without interacting (moved across it)
    INTERACTS = 2  # reflects and/or refracts at the face (`kernels.scatter`)
    ENDED = 3  # ended by Russian roulette after the segment's absorption


class WaveArrays(NamedTuple):
    """The fields of `pmmw.surface.Wave` (units and shapes there)."""

    o: np.ndarray
    d: np.ndarray
    s: np.ndarray
    p: np.ndarray
    m: np.ndarray
    sid: np.ndarray
    depth: np.ndarray
    stack: np.ndarray
    top: np.ndarray
    last_t: np.ndarray


class Hit(NamedTuple):
    """Where and how each ray of a wave meets a face, one entry per ray: the hit point ``pos``
    (n, 3) [m]; the face normal facing the incident side ``n_in`` (n, 3); the cosine of incidence
    ``cos1``; the media: the ray's current one ``cur``, the face's ``face_med``, the far side's
    ``other`` (int64); whether the ray leaves the face's medium ``leaving`` (bool); ``code``
    (int8, `HitCode`; empty where the caller decided already)."""

    pos: np.ndarray
    n_in: np.ndarray
    cos1: np.ndarray
    cur: np.ndarray
    face_med: np.ndarray
    other: np.ndarray
    leaving: np.ndarray
    code: np.ndarray

    @staticmethod
    def empty(n: int) -> Hit:
        """Room for ``n`` rays (filled by `kernels.arrive`)."""
        return Hit(
            np.empty((n, 3)),
            np.empty((n, 3)),
            np.empty(n),
            np.empty(n, np.int64),
            np.empty(n, np.int64),
            np.empty(n, np.int64),
            np.empty(n, bool),
            np.empty(n, np.int8),
        )


class Faces(NamedTuple):
    """Per triangle: its medium ``medium`` (int32), unit normal ``normal`` (F, 3) and the offset
    ``offset`` [m] a ray crossing it is moved by (its scale's rounding, `TraceJob.face_offset`)."""

    medium: np.ndarray
    normal: np.ndarray
    offset: np.ndarray


class MediaTable(NamedTuple):
    """Per medium (`pmmw.trace.job.Media` as the kernels take it, `surface.tables.kernel_tables`):
    ``kind`` (int8: DIELECTRIC, METAL, ...), power absorption ``alpha`` [1/m], ``temperature``
    [K], the real index of the incident side's first layer ``n1_real``, whether it has coherent
    films ``has_coat`` (bool), its permittivity ``eps`` (complex)."""

    kind: np.ndarray
    alpha: np.ndarray
    temperature: np.ndarray
    n1_real: np.ndarray
    has_coat: np.ndarray
    eps: np.ndarray


class Limits(NamedTuple):
    """How paths end (`kernels.survive`): at ``max_depth`` interactions, below the weight
    ``threshold`` (with ``roulette``, Russian roulette), and the bounds ``t_lo``, ``t_hi`` [K] of
    any brightness a path could still have seen (the truncation bound, `TileResult.truncated`)."""

    max_depth: int
    threshold: float
    roulette: bool
    t_lo: float
    t_hi: float
