"""The octree far field (`pmmw.physical_optics.octree`) against the direct facet sum (`solver.far_field`),
which shares only the exact triangle phase integral with it."""

import numpy as np
import pytest
import trimesh

from pmmw.physical_optics import solver
from pmmw.physical_optics.command import load_target
from pmmw.physical_optics.octree import far_field_octree

F = 95e9
LAM = solver.C0 / F
K0 = 2 * np.pi / LAM
# the octree's promise (its tol): error relative to the pattern's peak, over all directions
REL_TOL = 1e-3


def _target(tmp_path, mesh, name):
    path = tmp_path / f"{name}.ply"
    mesh.export(path)
    return load_target(path, "metal", None, F)


def _compare(target, theta_i, phi_i, pol, theta, phi):
    d_inc, e_inc = solver.incident(theta_i, phi_i, pol)
    lit, J, M = solver.currents(target, d_inc, e_inc, K0)
    assert lit.any()
    ref = solver.far_field(target, lit, J, M, -d_inc, K0, theta, phi)
    got = far_field_octree(target, lit, J, M, -d_inc, K0, theta, phi, tol=REL_TOL)
    for r, g in zip(ref, got):
        assert g.shape == r.shape == np.broadcast(theta, phi).shape
        assert np.abs(g - r).max() < REL_TOL * np.abs(r).max()


def _full_grid(n_theta, n_phi):
    return np.meshgrid(
        np.linspace(0.0, np.pi, n_theta), np.linspace(0.0, 2 * np.pi, n_phi, endpoint=False), indexing="ij"
    )


@pytest.mark.parametrize("pol", ["theta", "phi"])
def test_sphere_bistatic_full_grid(tmp_path, pol):
    """A PEC sphere of radius 20 wavelengths (5120 facets, ~1.5 wavelengths each), 5 levels."""
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=20 * LAM)
    theta, phi = _full_grid(31, 60)
    _compare(_target(tmp_path, sphere, "sphere"), 0.7, 1.1, pol, theta, phi)


def test_box_and_sphere_at_random_directions(tmp_path):
    """An irregular union (a box with a sphere beside it, and a torus) at scattered directions,
    including theta outside [0, pi] and negative phi (the same directions, relabelled)."""
    box = trimesh.creation.box(extents=[12 * LAM, 7 * LAM, 4 * LAM])
    ball = trimesh.creation.icosphere(subdivisions=3, radius=4 * LAM)
    ball.apply_translation([9 * LAM, 3 * LAM, 2 * LAM])
    ring = trimesh.creation.torus(major_radius=5 * LAM, minor_radius=1.5 * LAM, major_sections=48, minor_sections=16)
    ring.apply_translation([-3 * LAM, -6 * LAM, 3 * LAM])
    mesh = trimesh.util.concatenate([box, ball, ring])
    rng = np.random.default_rng(7)
    theta = rng.uniform(-0.5, np.pi + 0.5, 1500)
    phi = rng.uniform(-np.pi, 2 * np.pi, 1500)
    _compare(_target(tmp_path, mesh, "union"), 0.4, -0.8, "phi", theta, phi)


def test_flat_plate_two_large_triangles(tmp_path):
    """A 25 x 15 wavelength plate of two triangles: facets far larger than the leaves."""
    a, b = 25 * LAM, 15 * LAM
    v = [[-a / 2, -b / 2, 0], [a / 2, -b / 2, 0], [a / 2, b / 2, 0], [-a / 2, b / 2, 0]]
    plate = trimesh.Trimesh(vertices=v, faces=[[0, 1, 2], [0, 2, 3]], process=False)
    theta, phi = _full_grid(61, 72)
    _compare(_target(tmp_path, plate, "plate"), 0.5, 0.3, "theta", theta, phi)


def test_nothing_lit_radiates_nothing(tmp_path):
    sphere = _target(tmp_path, trimesh.creation.icosphere(subdivisions=1, radius=LAM), "s")
    F_ = len(sphere.area)
    lit = np.zeros(F_, bool)
    J = M = np.zeros((F_, 3), complex)
    ft, fp = far_field_octree(sphere, lit, J, M, np.array([0.0, 0.0, -1.0]), K0, np.zeros((2, 3)), np.zeros((2, 3)))
    assert ft.shape == fp.shape == (2, 3) and not ft.any() and not fp.any()


def test_bench_po_writes_its_table(tmp_path):
    """`pmmw bench --po` on one tiny cell: a table row with both times and an error below the
    octree's 1e-3 tolerance."""
    from pmmw_cli.bench_po import run

    path = run(tmp_path / "b.md", cases=[(3.0, 2, 2000)])
    row = [line for line in path.read_text().splitlines() if line.startswith("| 320 ")]
    assert len(row) == 1
    cells = [c.strip() for c in row[0].strip("|").split("|")]
    assert float(cells[4].rstrip("*")) > 0 and float(cells[5]) > 0 and float(cells[7]) < 1e-3
    assert path.with_suffix(".png").stat().st_size > 10_000 and "b.png" in path.read_text()
