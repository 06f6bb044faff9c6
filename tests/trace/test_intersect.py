"""Embree against the float64 NumPy reference, ray-origin offsets, and km-scale robustness."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from pmmw.trace.intersect import (
    EmbreeIntersector,
    NumpyIntersector,
    make_intersector,
    offset_origins,
)

# A ray passing within this distance [m] of a triangle edge (in a scene of unit size) may be
# called a hit by one intersector and a miss by the other: Embree decides in float32, where the
# coordinates are rounded by ~6e-8 m, and its edge test has a few spacings of slack.
EDGE_TOL = 1e-5
# Embree's float32 tfar is recomputed in float64 against the plane of the face hit, so the
# distances agree to float64 rounding amplified by 1/cos(incidence), not to float32.
T_RTOL = 1e-9
# Two faces hit within this relative distance of each other are a tie (crossing soup triangles):
# either face may be reported.
TIE_RTOL = 1e-4


def _random_unit(rng, n):
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _soup_and_sphere(rng):
    """A random triangle soup (crossing triangles) plus a closed sphere, as one mesh."""
    soup_v = rng.uniform(-1.0, 1.0, size=(3 * 150, 3))
    soup_f = np.arange(len(soup_v)).reshape(-1, 3)
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.6)
    sph_v = sphere.vertices + np.array([0.3, -0.2, 0.1])
    v = np.vstack([soup_v, sph_v])
    f = np.vstack([soup_f, sphere.faces + len(soup_v)])
    return v, f


def _plane_table(v, f, o, d):
    """Per (ray, face): distance along the ray to the face plane (inf when parallel or behind)
    and the distance from that plane point to the nearest edge segment of the face [m]."""
    tri = v[f]  # (F, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    cos = d @ n.T  # (N, F)
    num = np.einsum("fj,fj->f", tri[:, 0], n)[None, :] - o @ n.T
    with np.errstate(divide="ignore", invalid="ignore"):
        t = num / cos
    t = np.where(np.isfinite(t) & (t > 0), t, np.inf)
    p = o[:, None, :] + np.where(np.isfinite(t), t, 0.0)[..., None] * d[:, None, :]  # (N, F, 3)
    edge = np.full(t.shape, np.inf)
    for a, b in ((0, 1), (1, 2), (2, 0)):
        pa, pb = tri[:, a][None], tri[:, b][None]
        ab = pb - pa
        s = np.clip(np.sum((p - pa) * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
        edge = np.minimum(edge, np.linalg.norm(p - (pa + s[..., None] * ab), axis=-1))
    return t, edge


def test_embree_agrees_with_numpy_reference():
    rng = np.random.default_rng(20240611)
    v, f = _soup_and_sphere(rng)
    n = 3000
    o = rng.uniform(-2.0, 2.0, size=(n, 3))
    aim = rng.uniform(-0.8, 0.8, size=(n, 3))  # most rays head into the scene
    d = aim - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[: n // 4] = _random_unit(rng, n // 4)  # and some go anywhere

    t_e, p_e = EmbreeIntersector(v, f).intersect(o, d)
    t_n, p_n = NumpyIntersector(v, f).intersect(o, d)
    assert t_e.dtype == np.float64 and p_e.dtype == np.int64

    t_plane, edge = _plane_table(v, f, o, d)
    near_edge = np.any(np.isfinite(t_plane) & (edge < EDGE_TOL), axis=1)
    assert near_edge.mean() < 0.01  # the exclusion is rare, so the comparison means something

    ok = ~near_edge
    np.testing.assert_array_equal(p_e[ok] >= 0, p_n[ok] >= 0)
    both = ok & (p_e >= 0) & (p_n >= 0)
    assert both.sum() > n // 2
    np.testing.assert_allclose(t_e[both], t_n[both], rtol=T_RTOL)

    # A tie: another face's plane is crossed at nearly the same distance (conservatively,
    # whether or not inside that face), as where two soup triangles cross.
    others = t_plane.copy()
    others[np.arange(n)[both], p_n[both]] = np.inf
    with np.errstate(invalid="ignore"):  # inf - inf where neither is crossed
        tie = np.any(np.abs(others - t_n[:, None]) <= TIE_RTOL * t_n[:, None], axis=1)
    cmp = both & ~tie
    assert cmp.sum() > 0.9 * both.sum()
    np.testing.assert_array_equal(p_e[cmp], p_n[cmp])

    miss = ok & (p_n < 0)
    assert miss.any()
    assert np.all(np.isinf(t_e[miss])) and np.all(p_e[miss] == -1)
    assert np.all(np.isinf(t_n[miss]))


@pytest.mark.parametrize("kind", ["embree", "numpy"])
def test_known_hit_and_miss(kind):
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    isect = make_intersector(v, np.array([[0, 1, 2]]), kind=kind)
    o = np.array([[0.25, 0.25, 2.0], [0.25, 0.25, 2.0], [2.0, 2.0, 2.0], [0.25, 0.25, -1.0]])
    d = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])
    t, prim = isect.intersect(o, d)
    np.testing.assert_allclose(t[[0, 3]], [2.0, 1.0], rtol=1e-15)
    assert list(prim) == [0, -1, -1, 0]
    assert np.isinf(t[1]) and np.isinf(t[2])


@pytest.mark.parametrize("kind", ["embree", "numpy"])
def test_empty_ray_batch_and_empty_scene(kind):
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    t, prim = make_intersector(v, np.array([[0, 1, 2]]), kind=kind).intersect(np.zeros((0, 3)), np.zeros((0, 3)))
    assert t.shape == (0,) and prim.shape == (0,) and prim.dtype == np.int64
    empty = make_intersector(np.zeros((0, 3)), np.zeros((0, 3), np.int64), kind=kind)
    t, prim = empty.intersect(np.zeros((2, 3)), np.array([[0.0, 0.0, 1.0]] * 2))
    assert np.all(np.isinf(t)) and np.all(prim == -1)


@pytest.mark.parametrize("kind", ["embree", "numpy"])
def test_degenerate_and_duplicate_triangles(kind):
    v = np.array(
        [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],  # a good triangle
            [2.0, 0.0, 0.0],  # collinear with 0 and 1
        ]
    )
    f = np.array(
        [
            [0, 1, 3],  # zero area: collinear
            [0, 1, 2],  # good
            [0, 1, 2],  # exact duplicate
            [2, 2, 2],  # zero area: one point
            [0, 0, 1],  # zero area: repeated vertex
        ]
    )
    isect = make_intersector(v, f, kind=kind)
    o = np.array([[0.25, 0.25, 1.0], [0.5, 0.0, 1.0], [0.0, 1.0, 1.0], [1.5, 0.0, 1.0]])
    d = np.tile([0.0, 0.0, -1.0], (4, 1))
    t, prim = isect.intersect(o, d)
    assert prim[0] in (1, 2)
    assert t[0] == pytest.approx(1.0, rel=1e-12)
    assert not np.isin(prim, [0, 3, 4]).any()  # a degenerate face is never reported
    assert prim[3] == -1  # only degenerate faces there


def _km_ground():
    """A 2 km x 2 km ground plane (two triangles at z = 0) centred on x = 1000 m."""
    v = np.array([[0.0, -1000.0, 0.0], [2000.0, -1000.0, 0.0], [2000.0, 1000.0, 0.0], [0.0, 1000.0, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    return v, f


def test_km_scale_offset_never_rehits_the_plane():
    rng = np.random.default_rng(7)
    v, f = _km_ground()
    isect = EmbreeIntersector(v, f)
    n = 20000
    # Rays from an imager 70 m up, 1 km away, landing around x = 1000 m.
    o = np.tile([0.0, 0.0, 70.0], (n, 1))
    target = np.column_stack([rng.uniform(990.0, 1010.0, n), rng.uniform(-10.0, 10.0, n), np.zeros(n)])
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t, prim = isect.intersect(o, d)
    assert np.all(prim >= 0)
    pos = o + t[:, None] * d
    assert np.all(np.abs(pos[:, 2]) < 1e-9)  # float64 refinement puts hits on the plane
    nrm = np.tile([0.0, 0.0, 1.0], (n, 1))

    # Upward: the specular reflection, random directions, and grazing ones (cos = 1e-4).
    d_r = d * np.array([1.0, 1.0, -1.0])
    d_u = _random_unit(rng, n)
    d_u[:, 2] = np.abs(d_u[:, 2])
    d_g = np.column_stack([_random_unit(rng, n)[:, :2], np.full(n, 1e-4)])
    d_g /= np.linalg.norm(d_g, axis=1, keepdims=True)
    for d_up in (d_r, d_u, d_g):
        o_up = offset_origins(pos, nrm, d_up)
        assert np.all(o_up[:, 2] > 0.0)
        _, p_up = isect.intersect(o_up, d_up)
        assert np.all(p_up == -1)

    # Downward from the offset point: the plane is hit, just below.
    d_down = -d_r
    o_down = offset_origins(pos, nrm, d_r)
    t_down, p_down = isect.intersect(o_down, d_down)
    assert np.all(p_down >= 0)
    assert np.all(t_down < 1e-2)


def test_offset_with_face_scale_is_safe_for_large_slivers():
    # Random km-sized triangles (many slivers) near the origin: hit points have small
    # coordinates, but Embree places these faces at the magnitude of their vertices.
    rng = np.random.default_rng(3)
    v = rng.uniform(-1000.0, 1000.0, size=(30, 3))
    f = np.arange(30).reshape(10, 3)
    isect = EmbreeIntersector(v, f)
    n = 50000
    k = rng.integers(0, 10, n)
    target = np.einsum("ni,nij->nj", rng.dirichlet([1.0, 1.0, 1.0], n), v[f[k]])
    o = target + 1000.0 * rng.normal(size=(n, 3))
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t, prim = isect.intersect(o, d)
    h = prim >= 0
    pos = o[h] + t[h, None] * d[h]
    nrm = isect._normals[prim[h]]
    n_in = np.where(np.einsum("ij,ij->i", d[h], nrm)[:, None] < 0.0, nrm, -nrm)
    d_r = d[h] - 2.0 * np.einsum("ij,ij->i", d[h], n_in)[:, None] * n_in
    o_r = offset_origins(pos, n_in, d_r, scale=isect.face_scale[prim[h]])
    _, p_r = isect.intersect(o_r, d_r)
    assert not np.any(p_r == prim[h])


def test_offset_origins_side_and_size():
    p = np.array([[0.001, 0.0, 0.0], [0.0, 0.5, 0.0], [1000.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    nrm = np.tile([0.0, 0.0, 1.0], (4, 1))
    d = np.array([[0.0, 0.6, 0.8], [0.0, 0.6, -0.8], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    out = offset_origins(p, nrm, d)
    step = out[:, 2]
    assert step[0] > 0 and step[1] < 0 and step[2] > 0
    assert step[3] > 0  # tangent direction: the normal's side
    np.testing.assert_array_equal(out[:, :2], p[:, :2])  # along the normal only
    assert 1e-7 < abs(step[0]) < 1e-6  # sub-micron near the origin (mm-scale geometry)
    assert abs(step[0]) == abs(step[1])
    assert 1e-4 < step[2] < 1e-3  # several float32 spacings (6.1e-5 m) at 1 km
    big = offset_origins(p[:1], nrm[:1], d[:1], scale=1000.0)
    assert big[0, 2] == pytest.approx(step[2])
    assert offset_origins(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3))).shape == (0, 3)


def test_unknown_intersector_lists_known():
    with pytest.raises(ValueError, match="embree, numpy"):
        make_intersector(np.zeros((3, 3)), np.array([[0, 1, 2]]), kind="optix")


@pytest.mark.parametrize("kind", ["embree", "numpy"])
def test_grazing_hit(kind):
    # |cos(ray, normal)| = 1e-8: the plane equation is ill-conditioned, Embree's float32 distance is used.
    v = np.array([[0.0, -1.0, 0.0], [2.0, -1.0, 0.0], [0.0, 1.0, 0.0]])
    isect = make_intersector(v, np.array([[0, 1, 2]]), kind=kind)
    d = np.array([[1.0, 0.0, -1e-8]])
    d /= np.linalg.norm(d)
    t, prim = isect.intersect(np.array([[-1.0, 0.0, 1.5e-8]]), d)
    assert prim[0] == 0
    assert t[0] == pytest.approx(1.5, rel=1e-6)  # lands at x = 0.5
