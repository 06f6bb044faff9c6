"""Jones-matrix helpers (pmmw.physics.jones) against their plain-numpy definitions."""

import numpy as np

from pmmw.physics.jones import basis_change, rebase, row_power, stokes_terms


def _bases(rng, n):
    def unit(v):
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    k1, k2 = unit(rng.normal(size=(n, 3))), unit(rng.normal(size=(n, 3)))
    s1, s2 = unit(np.cross(k1, rng.normal(size=(n, 3)))), unit(np.cross(k2, rng.normal(size=(n, 3))))
    return s1, np.cross(k1, s1), s2, np.cross(k2, s2)


def test_rebase_is_the_matrix_product_with_the_basis_change():
    """Element-wise formula = batched matmul, to rounding (1e-14 of unit-scale entries)."""
    rng = np.random.default_rng(3)
    m = rng.normal(size=(500, 2, 2)) + 1j * rng.normal(size=(500, 2, 2))
    s1, p1, s2, p2 = _bases(rng, 500)
    assert np.max(np.abs(rebase(m, s1, p1, s2, p2) - m @ basis_change(s1, p1, s2, p2))) < 1e-14


def test_rebase_within_one_plane_keeps_the_emitted_power():
    """Two orthonormal bases of the same transverse plane: B is a rotation, so the rows of M
    keep their power (row_power) and unpolarized emission its Ex2 + Ey2."""
    rng = np.random.default_rng(4)
    n = 200
    s1, p1, _, _ = _bases(rng, n)
    ang = rng.uniform(0, 2 * np.pi, n)[:, None]
    s2, p2 = np.cos(ang) * s1 + np.sin(ang) * p1, -np.sin(ang) * s1 + np.cos(ang) * p1
    m = rng.normal(size=(n, 2, 2)) + 1j * rng.normal(size=(n, 2, 2))
    m2 = rebase(m, s1, p1, s2, p2)
    assert np.allclose(row_power(m2), row_power(m), rtol=1e-12)
    t = np.full(n, 300.0)
    a, b = stokes_terms(m, t, t), stokes_terms(m2, t, t)
    assert np.allclose(a[:, 0] + a[:, 1], b[:, 0] + b[:, 1], rtol=1e-12)


def test_cross_matches_numpy_cross_with_broadcasting():
    from pmmw.physics.vec import cross

    rng = np.random.default_rng(5)
    a, b = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    assert np.array_equal(cross(a, b), np.cross(a, b))
    z = np.array([0.0, 0.0, 1.0])
    assert np.allclose(cross(z[None, :], b), np.cross(z[None, :], b), rtol=0, atol=1e-15)
    assert np.allclose(cross(a, z), np.cross(a, z), rtol=0, atol=1e-15)
