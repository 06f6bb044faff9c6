"""Small vector helpers for arrays of 3-vectors, shape (n, 3) (or broadcastable, e.g. (3,)).

`numpy.cross` moves axes and checks shapes on every call, which costs tens of microseconds per
call on the renderer's wavefronts; these write the components out. `dot` and `unit` are the
row-wise dot product and normalization that the microfacet models and `pmmw brdf` share.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from pmmw.arrays import FloatArray

__all__ = ["cross", "dot", "unit", "NORM_UNDERFLOW"]

# [-] below this a vector's length is taken after scaling it by its largest component: squares of
# components under 1e-154 underflow (a facet normal 1e-162 long came out 0.94 long)
NORM_UNDERFLOW = 1e-150


def cross(a: npt.ArrayLike, b: npt.ArrayLike) -> FloatArray:
    """``a x b`` for arrays of 3-vectors (last axis), broadcasting like `numpy.cross`.

    Parameters
    ----------
    a, b : ndarray, shape (..., 3), float64

    Returns
    -------
    ndarray, shape (broadcast of a and b), float64
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def dot(a: FloatArray, b: FloatArray) -> FloatArray:
    """Row-wise dot product ``a . b`` over the last axis.

    Parameters
    ----------
    a, b : ndarray, shape (..., 3), float64
        Vectors; the leading axes broadcast.

    Returns
    -------
    ndarray, shape (...), float64
    """
    return np.einsum("...i,...i->...", a, b)


def unit(v: FloatArray) -> FloatArray:
    """``v / |v|`` over the last axis; zero vectors are returned unchanged (no NaN), and vectors
    shorter than `NORM_UNDERFLOW` are still made unit.

    Parameters
    ----------
    v : ndarray, shape (..., 3), float64

    Returns
    -------
    ndarray, shape (..., 3), float64
    """
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    tiny = n < NORM_UNDERFLOW
    if np.any(tiny):  # scaled by the largest component first (`NORM_UNDERFLOW`); others untouched
        big = np.max(np.abs(v), axis=-1, keepdims=True)
        v = np.where(tiny & (big > 0.0), v / np.where(big > 0.0, big, 1.0), v)
        n = np.where(tiny, np.linalg.norm(v, axis=-1, keepdims=True), n)
    return v / np.where(n > 0.0, n, 1.0)
