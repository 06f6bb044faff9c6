"""Nearest-hit ray-triangle intersection: Embree (fast, float32) and a NumPy reference (float64).

Both intersectors take the scene as a triangle soup, ``vertices`` (V, 3) float64 [m] and
``faces`` (F, 3) int64, and answer ``intersect(origins, directions) -> (t, prim)`` for a wavefront
of rays: ``t`` (N,) float64 distance along the unit direction [m] (``np.inf`` on a miss) and
``prim`` (N,) int64 face index (-1 on a miss). Only hits with ``t > 0`` count; Embree has no
``tnear`` here, so a ray leaving a surface must start off it: `offset_origins`.

Precision. Embree works in `EMBREE_DTYPE` (float32). Its ``tfar`` is only as good as float32 at
the scene's coordinates, so `EmbreeIntersector` takes only the face id from Embree and computes
the distance in float64 from the plane of that face (Embree's ``tfar`` only at grazing incidence):
hit points ``o + t d`` lie on the float64 surface and the shading that follows is float64. What
stays float32 is Embree's hit/miss decision, a few float32 spacings wide at the face's
coordinates (``face_scale``); `offset_origins` steps over it.
"""

from __future__ import annotations

import numpy as np

from pmmw.constants import DEGENERATE_REL
from pmmw.jit import njit

EMBREE_DTYPE = np.float32  # precision at the Embree boundary; shading is float64

EMBREE_CHUNK = 1 << 20  # rays per Embree call: bounds the float32 copies and result arrays
NUMPY_PAIRS = 1 << 18  # ray-face pairs per NumPy chunk: about 6 MB per (pairs, 3) temporary

# Ray-origin offset (see `offset_origins`): float32 spacings at the coordinate magnitude, plus an
# absolute floor. Embree's float32 test places a point on the right side of a face to within a
# couple of spacings of the face's coordinate magnitude (`face_scale`); random km-sized slivers
# show no self-hit from 2 spacings up, and 8 keeps steps sub-micron near the origin
# (8 x 1.19e-7 m = 0.95 um at 1 m; 8 x 6.1e-5 m = 0.49 mm at 1 km).
RAY_EPS_ULPS = 8
RAY_EPS_FLOOR = 1e-9  # [m]


_embree_built = False  # whether this process has built an Embree scene (`embree_used`)


def embree_used() -> bool:
    """Whether this process has built an Embree scene. Embree's thread pool (TBB) then has threads
    of its own, and a process forked from this one copies the pool without them: its own scene
    build can wait for good on a lock one of them held at the fork (seen once), so
    `pmmw.trace.pool` spawns its workers instead of forking them."""
    return _embree_built


# Distances come from the face plane in float64 when |cos(ray, normal)| exceeds this; at more
# grazing incidence the plane equation amplifies rounding and Embree's float32 tfar is used.
_REFINE_MIN_COS = 1e-6


def _as_rays(origins, directions) -> tuple[np.ndarray, np.ndarray]:
    o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    if o.shape != d.shape:
        raise ValueError(f"origins {o.shape} and directions {d.shape} differ in shape")
    return o, d


class _TriangleSoup:
    """Validated vertices and faces plus per-face float64 data shared by both intersectors."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
        f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise ValueError(f"face indices out of range for {len(v)} vertices")
        self.vertices = v
        self.faces = f
        tri = v[f]  # (F, 3, 3)
        self._v0 = np.ascontiguousarray(tri[:, 0])  # the layout `kernels.warm` compiles for
        self._e1 = tri[:, 1] - tri[:, 0]
        self._e2 = tri[:, 2] - tri[:, 0]
        cross = np.cross(self._e1, self._e2)
        area2 = np.linalg.norm(cross, axis=1)
        e3 = tri[:, 2] - tri[:, 1]
        longest2 = np.max(np.stack([np.einsum("ij,ij->i", e, e) for e in (self._e1, self._e2, e3)]), axis=0)
        self._valid = area2 > DEGENERATE_REL * longest2
        self._normals = np.zeros_like(cross)
        self._normals[self._valid] = cross[self._valid] / area2[self._valid, None]
        #: ndarray, shape (F,), float64 [m]: the coordinate magnitude at which Embree's float32
        #: test places each face, for the ``scale`` argument of `offset_origins`: the largest
        #: |coordinate| of its vertices times its aspect ratio (longest edge / smallest height,
        #: >= 1), since float32 vertices tilt a sliver's plane by spacing x aspect ratio.
        aspect = np.ones(len(f))
        aspect[self._valid] = np.maximum(longest2[self._valid] / area2[self._valid], 1.0)
        self.face_scale = (np.abs(tri).max(axis=(1, 2)) if len(f) else np.zeros(0)) * aspect
        #: ndarray, shape (F,), float64 [m]: the `offset_origins` step for rays leaving each face
        #: (every point of a face has coordinates no larger than its vertices'), precomputed so
        #: the bounce loop need not recompute float32 spacings per ray.
        self.face_offset = _offset_length(np.maximum(self.face_scale, 1.0))

    @property
    def n_faces(self) -> int:
        return len(self.faces)


class EmbreeIntersector(_TriangleSoup):
    """Nearest-hit queries with Embree (embreex); the scene is built once, in the constructor.

    Parameters
    ----------
    vertices : ndarray, shape (V, 3), float64
        Vertex positions [m].
    faces : ndarray, shape (F, 3), int64
        Vertex indices of each triangle. Degenerate and duplicate triangles are allowed (a
        degenerate one is never reported; of exact duplicates either may be).
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        super().__init__(vertices, faces)
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        global _embree_built
        self._scene = None
        if self.n_faces:
            _embree_built = True  # before the build: a build interrupted midway has started the pool too
            self._scene = rtcore_scene.EmbreeScene()
            tri32 = np.ascontiguousarray(self.vertices[self.faces], dtype=EMBREE_DTYPE)
            TriangleMesh(self._scene, tri32)

    def intersect(self, origins, directions) -> tuple[np.ndarray, np.ndarray]:
        """Nearest hit with ``t > 0`` of each ray.

        Parameters
        ----------
        origins : ndarray, shape (N, 3), float64
            Ray origins [m].
        directions : ndarray, shape (N, 3), float64
            Unit ray directions.

        Returns
        -------
        t : ndarray, shape (N,), float64
            Distance to the hit [m]; ``np.inf`` on a miss.
        prim : ndarray, shape (N,), int64
            Index of the face hit; -1 on a miss.
        """
        o, d = _as_rays(origins, directions)
        n = len(o)
        t = np.full(n, np.inf)
        prim = np.full(n, -1, dtype=np.int64)
        if n == 0 or self._scene is None:
            return t, prim
        for start in range(0, n, EMBREE_CHUNK):
            sl = slice(start, start + EMBREE_CHUNK)
            prim[sl] = self._scene.run(
                np.ascontiguousarray(o[sl], dtype=EMBREE_DTYPE),
                np.ascontiguousarray(d[sl], dtype=EMBREE_DTYPE),
            )  # face ids only: the distance is recomputed in float64 below
        self._plane_distance(o, d, t, prim)
        return t, prim

    def _plane_distance(self, o, d, t, prim):
        """Distance of each hit in float64 from the plane of the face hit; at grazing incidence,
        where the plane equation amplifies rounding, Embree's own float32 distance."""
        grazing = np.flatnonzero(_plane_distance(o, d, self._v0, self._normals, prim, t))
        if grazing.size:
            res = self._scene.run(
                np.ascontiguousarray(o[grazing], dtype=EMBREE_DTYPE),
                np.ascontiguousarray(d[grazing], dtype=EMBREE_DTYPE),
                output=1,
            )
            hit = res["primID"] >= 0
            t[grazing] = np.where(hit, res["tfar"].astype(np.float64), np.inf)
            prim[grazing] = np.where(hit, res["primID"], -1)


@njit()
def _plane_distance(o, d, v0, normals, prim, t):
    """``t`` of each hit (``prim >= 0``) from the plane of its face, in float64 and at least 0;
    returns the rays at grazing incidence (left unchanged), where the plane equation amplifies
    rounding."""
    grazing = np.zeros(prim.shape[0], np.bool_)
    for i in range(prim.shape[0]):
        f = prim[i]
        if f < 0:
            continue
        cos = d[i, 0] * normals[f, 0] + d[i, 1] * normals[f, 1] + d[i, 2] * normals[f, 2]
        if abs(cos) > _REFINE_MIN_COS:
            num = (
                (v0[f, 0] - o[i, 0]) * normals[f, 0]
                + (v0[f, 1] - o[i, 1]) * normals[f, 1]
                + (v0[f, 2] - o[i, 2]) * normals[f, 2]
            )
            t[i] = max(num / cos, 0.0)
        else:
            grazing[i] = True
    return grazing


class NumpyIntersector(_TriangleSoup):
    """Reference nearest-hit queries: Moller-Trumbore over all faces in float64, chunked.

    Slow (O(N F)); for tests and tiny scenes. Same interface as `EmbreeIntersector`. Of faces hit
    at exactly the same distance (duplicates) the lowest index is reported.
    """

    def intersect(self, origins, directions) -> tuple[np.ndarray, np.ndarray]:
        """Nearest hit with ``t > 0``; arguments and results as `EmbreeIntersector.intersect`."""
        o, d = _as_rays(origins, directions)
        n = len(o)
        t = np.full(n, np.inf)
        prim = np.full(n, -1, dtype=np.int64)
        nf = self.n_faces
        if n == 0 or nf == 0:
            return t, prim
        f_chunk = min(nf, NUMPY_PAIRS)
        r_chunk = max(1, NUMPY_PAIRS // f_chunk)
        for r0 in range(0, n, r_chunk):
            rs = slice(r0, r0 + r_chunk)
            for f0 in range(0, nf, f_chunk):
                t_c, p_c = self._nearest(o[rs], d[rs], slice(f0, f0 + f_chunk))
                better = t_c < t[rs]  # strict: ties keep the lower face index
                t[rs] = np.where(better, t_c, t[rs])
                prim[rs] = np.where(better, p_c + f0, prim[rs])
        return t, prim

    def _nearest(self, o, d, fs):
        """Moller-Trumbore for rays (r, 3) against faces ``fs``: nearest t and local face index."""
        v0, e1, e2 = self._v0[fs][None], self._e1[fs][None], self._e2[fs][None]
        dd = d[:, None, :]
        pvec = np.cross(dd, e2)
        det = np.sum(e1 * pvec, axis=-1)
        valid = self._valid[fs][None] & (det != 0.0)
        inv = 1.0 / np.where(valid, det, 1.0)
        tvec = o[:, None, :] - v0
        u = np.sum(tvec * pvec, axis=-1) * inv
        qvec = np.cross(tvec, e1)
        v = np.sum(dd * qvec, axis=-1) * inv
        tt = np.sum(e2 * qvec, axis=-1) * inv
        ok = valid & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (tt > 0.0)
        tt = np.where(ok, tt, np.inf)
        j = np.argmin(tt, axis=1)
        return tt[np.arange(len(tt)), j], j


_INTERSECTORS = {"embree": EmbreeIntersector, "numpy": NumpyIntersector}


def make_intersector(vertices: np.ndarray, faces: np.ndarray, kind: str = "embree"):
    """Build the intersector named ``kind`` (``embree`` or ``numpy``) for a triangle soup."""
    try:
        cls = _INTERSECTORS[kind]
    except KeyError:
        raise ValueError(f"unknown intersector {kind!r}; known: {', '.join(_INTERSECTORS)}") from None
    return cls(vertices, faces)


def offset_origins(points, normals, directions, scale=None) -> np.ndarray:
    """Move surface points off the surface, to the side the new rays leave towards.

    The step is along the normal, with the sign of ``dot(direction, normal)``, of length
    ``RAY_EPS_ULPS`` float32 spacings at ``max(|largest coordinate|, scale, 1 m)`` plus
    ``RAY_EPS_FLOOR``: wide enough that Embree's float32 test does not find the surface just left
    (coordinates of kilometres included), small enough to keep sub-micron steps near the origin.
    Without ``scale`` the hit point's own coordinates set the step, which suffices for faces no
    larger and no further out than the point (always for axis-aligned faces); pass
    ``scale=intersector.face_scale[prim]`` to be safe with large or sliver faces as well.

    Parameters
    ----------
    points : ndarray, shape (N, 3), float64
        Points on the surface [m].
    normals : ndarray, shape (N, 3), float64
        Unit surface normals (either orientation).
    directions : ndarray, shape (N, 3), float64
        Directions of the rays that will start there.
    scale : float or ndarray of shape (N,), optional
        A larger coordinate magnitude to use for the step [m], e.g. ``face_scale[prim]`` of the
        intersector: Embree's decision about a face is made at the magnitude of that face's
        vertices, which exceeds the hit point's own for large tilted triangles far from it.

    Returns
    -------
    ndarray, shape (N, 3), float64
        The offset origins [m].
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    nrm = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    side = np.where(np.einsum("ij,ij->i", d, nrm) < 0.0, -1.0, 1.0)
    mag = np.maximum(np.abs(p).max(axis=1, initial=0.0), 1.0)
    if scale is not None:
        mag = np.maximum(mag, np.asarray(scale, dtype=np.float64))
    eps = _offset_length(mag)
    return p + (side * eps)[:, None] * nrm


def _offset_length(mag):
    """``RAY_EPS_ULPS`` float32 spacings at coordinate magnitude ``mag`` [m], plus the floor."""
    return RAY_EPS_ULPS * np.spacing(np.asarray(mag).astype(EMBREE_DTYPE)).astype(np.float64) + RAY_EPS_FLOOR
