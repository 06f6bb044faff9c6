"""The wave of rays a bounce works on, as the compiled kernels take it (`pmmw.surface.kernels`)."""

from __future__ import annotations

import numpy as np

from pmmw.surface.records import WaveArrays

__all__ = ["Wave"]


class Wave:
    """Struct of arrays for the rays of one bounce: origins ``o``, directions ``d`` and polarization
    bases ``s``, ``p`` (n, 3) float64; Jones matrices ``m`` (n, 2, 2) complex128 (`pmmw.physics.jones`);
    the sample each ray adds to ``sid`` (n,) int64; interactions so far ``depth`` (n,) int32; the
    medium stack ``stack`` (n, stack_size) int16 with its top ``top`` (n,) int32; the temperature
    a path ended here takes ``last_t`` (n,) float64 [K]; the key of its random numbers ``key`` (n,)
    uint64 (`pmmw.rng`)."""

    __slots__ = ("o", "d", "s", "p", "m", "sid", "depth", "stack", "top", "last_t", "key")

    def __init__(self, **kw):
        for k, v in kw.items():
            setattr(self, k, v)

    def take(self, idx):
        if idx.dtype == bool:
            idx = np.flatnonzero(idx)  # once, not once per array: half the cost of a take
        return Wave(**{k: getattr(self, k)[idx] for k in self.__slots__})

    @staticmethod
    def concat(waves):
        waves = [w for w in waves if w is not None and w.o.shape[0] > 0]
        if not waves:
            return None
        if len(waves) == 1:
            return waves[0]
        return Wave(**{k: np.concatenate([getattr(w, k) for w in waves]) for k in Wave.__slots__})

    def __len__(self):
        return self.o.shape[0]

    def arrays(self) -> WaveArrays:
        """The fields as the record the compiled kernels take (`pmmw.surface.kernels`)."""
        return WaveArrays(*(getattr(self, k) for k in self.__slots__))

    @staticmethod
    def empty(n, stack_size):
        """Room for ``n`` rays (filled by `kernels.scatter`), the fields as `WaveArrays.ROOM` states."""
        return Wave(**WaveArrays.empty(n, stack=stack_size)._asdict())

    def head(self, n):
        """The first ``n`` rays (views)."""
        return Wave(**{k: getattr(self, k)[:n] for k in self.__slots__})
