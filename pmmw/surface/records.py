"""The records the compiled kernels take (`pmmw.surface.kernels`, `pmmw.trace.kernels`), named as the equations name them.

numba passes a named tuple as cheaply as a plain one (a heterogeneous tuple type whose fields are
read by name), so the kernels read ``wave.m`` or ``hit.cos1`` instead of ``wave[4]`` or
``hit[2]``. A record's ``ROOM`` states each field's type once: an array's shape (``"n"``: one
entry per row; another name: a size given to ``empty``) and dtype, a scalar's Python type, or a
record of its own. `empty` builds a record from it; the callers that fill records of their own
make them with the same types (`Wave.arrays`, the tables of `surface.tables.kernel_tables`), and
`pmmw.trace.kernels.warm` compiles every kernel from ``empty`` records, so that adding a field
to a record cannot leave the warm-up out of step with the renderer
(tests/trace/test_warm.py checks that a render compiles nothing warm did not).
`HitCode` names what `kernels.arrive` decided for each ray.
"""

from __future__ import annotations

from enum import IntEnum
from typing import NamedTuple

import numpy as np

__all__ = [
    "BackSide",
    "ChainEnd",
    "Choice",
    "Facets",
    "Faces",
    "Fate",
    "Films",
    "Hit",
    "HitCode",
    "LeaveSide",
    "Limits",
    "MediaTable",
    "RoughTable",
    "Settle",
    "WaveArrays",
    "empty",
]


class HitCode(IntEnum):
    """What happened to a ray at the end of its segment (`kernels.arrive`, ``Hit.code``)."""

    MISSED = 0  # no face: the sky's or the atmosphere's
    PASSED = 1  # crossed the face without interacting (moved across it)
    INTERACTS = 2  # reflects and/or refracts at the face (`kernels.scatter`)
    ENDED = 3  # ended by Russian roulette after the segment's absorption


def empty(record, n: int = 0, zero: bool = False, **sizes):
    """A ``record`` (a class of this module) with room for ``n`` rows, each field as its ``ROOM``
    states: arrays uninitialized (zeros with ``zero``), scalars 0 / False, records of their own
    built the same way; ``sizes`` gives the other named dimensions (``stack``)."""
    make = np.zeros if zero else np.empty
    fields = []
    for kind in record.ROOM:
        if isinstance(kind, tuple):
            shape, dtype = kind
            fields.append(make(tuple(n if a == "n" else sizes[a] if isinstance(a, str) else a for a in shape), dtype))
        elif isinstance(kind, type) and issubclass(kind, tuple):
            fields.append(empty(kind, n, zero, **sizes))
        else:
            fields.append(kind())
    return record(*fields)


def _room(cls, n: int = 0, zero: bool = False, **sizes):
    """Room for ``n`` rows (`records.empty`)."""
    return empty(cls, n, zero, **sizes)


_F8, _C16, _I8, _I4, _I2, _I1, _B = np.float64, np.complex128, np.int64, np.int32, np.int16, np.int8, np.bool_
_U8 = np.uint64
_ROW = ("n",)
_ROW3 = ("n", 3)


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
    key: np.ndarray

    ROOM = (
        (_ROW3, _F8),
        (_ROW3, _F8),
        (_ROW3, _F8),
        (_ROW3, _F8),
        (("n", 2, 2), _C16),
        (_ROW, _I8),
        (_ROW, _I4),
        (("n", "stack"), _I2),
        (_ROW, _I4),
        (_ROW, _F8),
        (_ROW, _U8),
    )
    empty = classmethod(_room)


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

    ROOM = ((_ROW3, _F8), (_ROW3, _F8), (_ROW, _F8), (_ROW, _I8), (_ROW, _I8), (_ROW, _I8), (_ROW, _B), (_ROW, _I1))
    empty = classmethod(_room)


class Faces(NamedTuple):
    """Per triangle: its medium ``medium`` (int32), unit normal ``normal`` (F, 3) and the offset
    ``offset`` [m] a ray crossing it is moved by (its scale's rounding, `TraceJob.face_offset`)."""

    medium: np.ndarray
    normal: np.ndarray
    offset: np.ndarray

    ROOM = ((_ROW, _I4), (_ROW3, _F8), (_ROW, _F8))
    empty = classmethod(_room)


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

    ROOM = ((_ROW, _I1), (_ROW, _F8), (_ROW, _F8), (_ROW, _F8), (_ROW, _B), (_ROW, _C16))
    empty = classmethod(_room)


class Films(NamedTuple):
    """The media's coherent films (`job.Coating`, outermost first), flattened
    (`surface.tables.kernel_tables`): medium k's are ``eps[start[k]:start[k] + count[k]]`` with
    thicknesses ``thickness[...]`` [m]; their absorption emits at ``temperature[k]`` [K]; the
    free-space wavenumber ``k0`` [1/m]."""

    start: np.ndarray
    count: np.ndarray
    eps: np.ndarray
    thickness: np.ndarray
    temperature: np.ndarray
    k0: float

    ROOM = ((_ROW, _I8), (_ROW, _I8), (_ROW, _C16), (_ROW, _F8), (_ROW, _F8), float)
    empty = classmethod(_room)


class RoughTable(NamedTuple):
    """Per medium, its roughness model for the masking test: ``code`` (int8, `roughness.smith_g1`'s
    codes; `roughness.NOT_ROUGH` smooth, `roughness.OTHER_CODE` masked by its array code), the
    widths ``alpha_x``, ``alpha_y`` and the ``orientation`` [rad] of its anisotropy."""

    code: np.ndarray
    alpha_x: np.ndarray
    alpha_y: np.ndarray
    orientation: np.ndarray

    ROOM = ((_ROW, _I1), (_ROW, _F8), (_ROW, _F8), (_ROW, _F8))
    empty = classmethod(_room)


class Limits(NamedTuple):
    """How paths end (`kernels.survive`): at ``max_depth`` interactions, below the weight
    ``threshold`` (with ``roulette``, Russian roulette), and the bounds ``t_lo``, ``t_hi`` [K] of
    any brightness a path could still have seen (the truncation bound, `TileResult.truncated`)."""

    max_depth: int
    threshold: float
    roulette: bool
    t_lo: float
    t_hi: float

    ROOM = (int, float, bool, float, float)
    empty = classmethod(_room)


class Choice(NamedTuple):
    """The branch choice at an interface (``render.strategy``): ``strategy`` (`kernels.STRATEGIES`:
    split, stochastic, hybrid) and, for hybrid, the depth ``split_depth`` from which one branch is
    drawn."""

    strategy: int
    split_depth: int

    ROOM = (int, int)
    empty = classmethod(_room)


class BackSide(NamedTuple):
    """Filled for each child that comes back for a re-hit: its row ``src`` in the interaction's
    arrays, the media of its side seen from there (``cur``, ``other``, ``leaving``) and its branch
    ``sign`` (+1 reflected, -1 transmitted)."""

    src: np.ndarray
    cur: np.ndarray
    other: np.ndarray
    leaving: np.ndarray
    sign: np.ndarray

    ROOM = ((_ROW, _I8), (_ROW, _I8), (_ROW, _I8), (_ROW, _B), (_ROW, _F8))
    empty = classmethod(_room)


class LeaveSide(NamedTuple):
    """Filled for each child that leaves: its row ``src`` and branch ``sign``."""

    src: np.ndarray
    sign: np.ndarray

    ROOM = ((_ROW, _I8), (_ROW, _F8))
    empty = classmethod(_room)


class ChainEnd(NamedTuple):
    """Per row: the re-hit chain is at its end (``over``), and a masked child's power is then
    emitted at ``t_end`` (rows, 2) [K] (column 0 for reflected children, 1 for transmitted)."""

    over: np.ndarray
    t_end: np.ndarray

    ROOM = ((_ROW, _B), (("n", 2), _F8))
    empty = classmethod(_room)


class Fate(NamedTuple):
    """What terminates the children that leave (`kernels.survive`): Russian roulette's uniforms
    ``u_roul`` (two per row, the reflected child's first; empty without roulette), the
    ``limits`` and the truncation sums ``cut`` (samples, 2)."""

    u_roul: np.ndarray
    limits: Limits
    cut: np.ndarray

    ROOM = ((_ROW, _F8), Limits, (("n", 2), _F8))
    empty = classmethod(_room)


class Facets(NamedTuple):
    """A rough face's interaction in `kernels.scatter` (``MASKED``): per row, whether the GGX
    facet is drawn there (``draw``, per medium) from uniforms ``u1``, ``u2``; the face normal
    ``n_geo`` and macro normal ``n_mac`` facing the incident side; the masking uniforms
    ``u_leave`` (two per row: its reflected and transmitted child, `pmmw.rng.Purpose`); the media's ``rough`` table; the chain's
    end ``over``; the way a masked child crosses to the next facet, one ``wavelength`` [m]; the
    depth change of a re-hit ``rehit_depth``; ``back`` filled for the children that come back;
    ``counts`` (3,) receives (draws of weight other than 1, unused (0),
    children that came back)."""

    draw: np.ndarray
    u1: np.ndarray
    u2: np.ndarray
    n_geo: np.ndarray
    n_mac: np.ndarray
    u_leave: np.ndarray
    rough: RoughTable
    over: bool
    wavelength: float
    rehit_depth: int
    back: BackSide
    counts: np.ndarray

    ROOM = (
        (_ROW, _B),
        (_ROW, _F8),
        (_ROW, _F8),
        (_ROW3, _F8),
        (_ROW3, _F8),
        (_ROW, _F8),
        RoughTable,
        bool,
        float,
        int,
        BackSide,
        ((3,), _I8),
    )
    empty = classmethod(_room)


class Settle(NamedTuple):
    """What `kernels.scatter` does with the children (``mode``: `kernels.FINISH`, ``AT_POINT``,
    ``MASKED``); with ``AT_POINT`` each child's row in the wave to ``src`` and +1 (reflected) or
    -1 (transmitted) to ``branch``; with ``MASKED`` the rough face's ``facets`` (None otherwise:
    the smooth kernels are compiled without the rough faces' steps)."""

    mode: int
    src: np.ndarray
    branch: np.ndarray
    facets: Facets | None

    ROOM = (int, (_ROW, _I8), (_ROW, _I1), Facets)
    empty = classmethod(_room)
