"""Building blocks of the shipped scenes' mesh scripts (`scenes/*/make_scene.py`): closed,
outward-oriented trimesh solids made from axis-aligned boxes and rectilinear grids [m]."""

from __future__ import annotations

import numpy as np
import trimesh


def box(lo, hi) -> trimesh.Trimesh:
    """Closed, outward-oriented box between the corners lo and hi [m]."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(extents=hi - lo)
    m.apply_translation((lo + hi) / 2)
    return m


def cell_block(xs, ys, zs, occupied) -> trimesh.Trimesh:
    """Closed mesh of a set of cells of a rectilinear grid (faces where occupancy changes).

    Closed and outward for any set whose cells never meet along an edge only.

    Parameters
    ----------
    xs, ys, zs : sequence of float, lengths nx + 1, ny + 1, nz + 1
        Grid lines [m], increasing.
    occupied : ndarray, shape (nx, ny, nz), bool
    """
    xs, ys, zs = (np.asarray(a, float) for a in (xs, ys, zs))
    nx, ny, nz = len(xs) - 1, len(ys) - 1, len(zs) - 1
    occ = np.zeros((nx + 2, ny + 2, nz + 2), dtype=bool)
    occ[1:-1, 1:-1, 1:-1] = occupied
    gi, gj, gk = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1), indexing="ij")
    vertices = np.column_stack([xs[gi.ravel()], ys[gj.ravel()], zs[gk.ravel()]])

    def vid(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    quads = []
    for axis in range(3):
        s0 = [slice(1, -1)] * 3
        s1 = [slice(1, -1)] * 3
        s0[axis], s1[axis] = slice(0, -1), slice(1, None)
        lo, hi = occ[tuple(s0)], occ[tuple(s1)]
        for mask, flip in ((lo & ~hi, False), (hi & ~lo, True)):
            i, j, k = np.nonzero(mask)
            if axis == 0:
                q = [vid(i, j, k), vid(i, j + 1, k), vid(i, j + 1, k + 1), vid(i, j, k + 1)]
            elif axis == 1:
                q = [vid(i, j, k), vid(i, j, k + 1), vid(i + 1, j, k + 1), vid(i + 1, j, k)]
            else:
                q = [vid(i, j, k), vid(i + 1, j, k), vid(i + 1, j + 1, k), vid(i, j + 1, k)]
            q = np.stack(q, axis=1)
            quads.append(q[:, ::-1] if flip else q)
    q = np.concatenate(quads)
    mesh = trimesh.Trimesh(vertices, np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]), process=False)
    mesh.remove_unreferenced_vertices()
    return mesh
