"""Small vector helpers for arrays of 3-vectors, shape (n, 3) (or broadcastable, e.g. (3,)).

`numpy.cross` moves axes and checks shapes on every call, which costs tens of microseconds per
call on the renderer's wavefronts; these write the components out. `dot` and `unit` are the
row-wise dot product and normalization that the microfacet models and `pmmw brdf` share.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from pmmw.arrays import FloatArray

__all__ = ["cross", "dot", "unit"]


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
    """``v / |v|`` over the last axis; zero vectors are returned unchanged (no NaN).

    Parameters
    ----------
    v : ndarray, shape (..., 3), float64

    Returns
    -------
    ndarray, shape (..., 3), float64
    """
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0.0, n, 1.0)
