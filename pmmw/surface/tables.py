"""A scene's layered surfaces as the compiled kernels take them: every medium with its coherent
films, roughness model and rough coating layers (`job.Media`) flattened into arrays once per
frequency (`kernel_tables`), each rough coating layer a medium of its own; the interfaces of one
surface with rough layers (`Pile`); and the coefficients of interfaces over arrays of rays
(`surface_coefficients`, the tracer's own `kernels.coefficients`, for `pmmw po` and the tests).
"""

from __future__ import annotations

import numpy as np

from pmmw.physics import fresnel
from pmmw.physics.roughness import NOT_ROUGH, OTHER_CODE
from pmmw.surface import kernels
from pmmw.surface.media import DIELECTRIC, Media
from pmmw.surface.records import Films, MediaTable, RoughTable

__all__ = ["Pile", "kernel_tables", "surface_coefficients", "surface_response"]


def kernel_tables(media: Media, k0: float):
    """The media as the kernels take them (`kernels.scatter`, `kernels.settle`), with each rough
    coating layer (`job.RoughLayer`) a dielectric medium of its own after the scene's media.

    Returns
    -------
    media : MediaTable
        One entry per medium.
    films : Films
        The coherent films of each medium (outermost first), flattened.
    rough : RoughTable
        Each medium's roughness model for the masking test (`roughness.smith_g1` codes).
    models : list
        Each medium's roughness model (None: smooth).
    layer_media : list of list of int
        ``layer_media[k][j]``: the medium index of rough layer j of medium k.
    """
    m = media
    n = len(m.ids)
    kind, alpha, temp, eps = list(m.kind), list(m.alpha), list(m.temperature), list(m.eps)
    coats, models = list(m.coating), [m.rough(k) for k in range(n)]
    layer_media = []
    for k in range(n):
        idx = []
        for layer in m.rough_layers(k):
            idx.append(len(kind))
            kind.append(DIELECTRIC)
            alpha.append(layer.alpha)
            temp.append(layer.temperature)
            eps.append(layer.eps)
            coats.append(layer.films)
            models.append(layer.roughness)
        layer_media.append(idx)
    eps = np.array(eps, complex)
    media = MediaTable(
        np.array(kind, np.int8),
        np.array(alpha, float),
        np.array(temp, float),
        np.sqrt(eps).real.copy(),
        np.array([c is not None for c in coats]),
        eps,
    )
    sizes = [0 if c is None else c.eps.size for c in coats]
    present = [c for c in coats if c is not None]
    films = Films(
        np.cumsum([0] + sizes[:-1]).astype(np.int64),
        np.array(sizes, np.int64),
        np.concatenate([c.eps for c in present] + [np.ones(1)]).astype(complex),
        np.concatenate([c.thickness for c in present] + [np.zeros(1)]).astype(float),
        np.array([0.0 if c is None else c.temperature for c in coats], float),
        float(k0),
    )
    # GGX and Beckmann are masked in the kernel; others (``OTHER_CODE``) by their array code
    rough = RoughTable(
        np.array([NOT_ROUGH if r is None else getattr(r, "code", OTHER_CODE) for r in models], np.int8),
        np.array([getattr(r, "ax", 1.0) for r in models], float),
        np.array([getattr(r, "ay", 1.0) for r in models], float),
        np.array([getattr(r, "orientation", 0.0) for r in models], float),
    )
    return media, films, rough, models, layer_media


class Pile:
    """The interfaces of one surface with rough coating layers, seen by one group of rays.

    Interface j < n is the rough top of ``layers[j]`` (with that layer's coherent films);
    interface n is the body's own surface (its ``coating`` films and ``roughness``). Above
    interface 0 is the outside medium, below interface n the body (index k).
    """

    def __init__(self, media, k, outside, layer_media):
        self.layers = media.rough_layers(k)
        # medium indices in the kernels' tables (`kernel_tables`): above interface 0 the outside,
        # then the layers, below interface n the body
        self._index = [int(outside)] + list(layer_media) + [int(k)]
        self.n = len(self.layers)
        self.t_body = float(media.temperature[k])
        self._media, self._k = media, k
        # where a walk that ends early emits: the layer it is in, the body on either outer side
        self._end_above = np.array([self.t_body] + [x.temperature for x in self.layers])
        self._end_below = np.array([x.temperature for x in self.layers] + [self.t_body])

    def index(self, j, above):
        """Medium index (kernels' tables) on one side of interface j."""
        return self._index[j] if above else self._index[j + 1]

    def roughness(self, j):
        return self.layers[j].roughness if j < self.n else self._media.rough(self._k)

    def end_temperature(self, j, above):
        return float(self._end_above[j] if above else self._end_below[j])

    def end_temperatures(self, lvl, above):
        return np.where(above, self._end_above[lvl], self._end_below[lvl])


def surface_response(job, cur, face_med, other, leaving, cos1):
    """`surface_coefficients` for a group of rays with the same media and orientation (scalars
    ``cur``, ``face_med``, ``other``, ``leaving``); ``t_coat`` is then one temperature."""
    n = cos1.shape[0]
    c, t_coat, q2 = surface_coefficients(
        job, np.full(n, cur), np.full(n, face_med), np.full(n, other), np.full(n, bool(leaving)), cos1
    )
    return c, (float(t_coat[0]) if n else 0.0), (q2 if n and not np.isnan(q2[0]) else None)


def surface_coefficients(job, cur, face_med, other, leaving, cos1):
    """Interface coefficients of rays meeting faces, each with its own media and orientation:
    `kernels.coefficients`, the tracer's own, over arrays (for `pmmw po` and the tests).

    Parameters
    ----------
    job : TraceJob
        Or any record with its ``media`` (`job.Media`) and ``k0`` [1/m].
    cur, face_med, other : ndarray, shape (n,), int
        Medium of the incident side, medium of the face's object, medium on the far side.
    leaving : ndarray, shape (n,), bool
        The ray leaves ``face_med`` (coating layers are then met innermost first).
    cos1 : ndarray, shape (n,), float64
        Cosine of the incidence angle in the incident medium.

    Returns
    -------
    coeffs : fresnel.Fresnel
        Amplitudes and powers, arrays of shape (n,).
    t_coat : ndarray, shape (n,), float64
        Temperature at which the absorbed part emits [K]: the films'; the body's for a bare
        perfect conductor; for a bare interface the absorbed remainder only exists when the
        incident medium is lossy (homogeneous-wave approximation, PHYSICS.md) and is emitted at
        the incident medium's temperature.
    q2 : ndarray, shape (n,), complex128
        The far medium's normal component (outgoing root) that refraction uses; NaN for a
        perfect conductor.
    """
    media, films = kernel_tables(job.media, job.k0)[:2]
    n = cos1.shape[0]
    amp, power, q2, t_coat = np.empty((n, 4), complex), np.empty((n, 6)), np.empty(n, complex), np.empty(n)
    kernels.coefficients(
        np.ascontiguousarray(cur, np.int64),
        np.ascontiguousarray(face_med, np.int64),
        np.ascontiguousarray(other, np.int64),
        np.ascontiguousarray(leaving, bool),
        np.ascontiguousarray(cos1, float),
        media,
        films,
        amp,
        power,
        q2,
        t_coat,
    )
    return fresnel.Fresnel(*(amp[:, k] for k in range(4)), *(power[:, k] for k in range(6))), t_coat, q2
