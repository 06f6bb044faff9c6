"""Write scenes/cinderblocks/cinderblocks.glb: cinderblocks in the desert (Murakowski 2014 sec. 2.3.2).

The first validation scene of Murakowski 2014 (sec. 2.3.2, Fig. 2.7, Table 2.1): stacks of
cinderblocks on open, flat sand, seen at 35 GHz by an imager on a cart focused at 7 m. The top of
a block mirrors the cold sky; "the cavity inside the cinderblock is very warm". Here: a near stack
at ~3.5 m and a far stack at ~7 m from an imager at the origin, 1.5 m up, looking along +y.

Why the cavities are warm: every block lies flat, as blocks are laid, so its two cavities are
vertical wells, open at the top and closed at the bottom by the block below or by the ground.
A ray that enters a well from above meets its walls near normal incidence (concrete reflects
only ~16 % there, Table 2.1 eps 5.5 + 0.5i) and is reflected down, further into the well, not
back out towards the sky: after a few bounces nearly all its weight has been absorbed and
re-emitted at 300 K, a cavity radiator. A block on its side or on end would instead present
see-through holes whose walls mirror the sky and the ground behind (cold).

Every block is a standard concrete masonry unit, 390 x 190 x 190 mm, with two rectangular
through-cavities, built as one closed, outward-oriented (watertight, genus-2) mesh. The ground is
a thin box whose top face is z = 0. Mesh material names: ``ground`` and ``cinderblock``. Blocks
sit ``--gap`` above the ground and above each other, so no two surfaces coincide.

The scene is built Z-up (pmmw's world frame) and rotated into glTF's Y-up on export; pmmw turns it
back on load. Run from anywhere:

    python scenes/cinderblocks/make_scene.py [--out-dir DIR | --out PATH] [--ground-size 60] [--near X Y] ...
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh

from pmmw.scene.export import check_glb, export_glb

# Concrete masonry unit (nominal 400 x 200 x 200 mm with 10 mm joints) [m].
BLOCK_LENGTH, BLOCK_WIDTH, BLOCK_HEIGHT = 0.390, 0.190, 0.190
FACE_SHELL = 0.032  # the two long walls
WEB = 0.032  # the two end webs and the centre web
# -> two cavities of (390 - 3 x 32) / 2 = 147 mm x (190 - 2 x 32) = 126 mm.

IMAGER_HEIGHT = 1.5  # [m], the thesis's cart-mounted dish

# Stacks, bottom block first: (pose, yaw [deg]). Poses: "flat" (cavities vertical, open at the
# top), "side" (turned about the long axis: cavities along y, through-holes towards the imager),
# "end" (standing on end: long axis vertical; with yaw 90 the cavities point along y). The stacks
# are laid flat with their long faces towards the imager and their cavities aligned: each stack
# has two wells, open at the top and closed at the bottom by the ground (the warm cavities).
NEAR_STACK = [("flat", 0.0), ("flat", 0.0), ("flat", 0.0)]
FAR_STACK = [("flat", 0.0), ("flat", 0.0)]


def _quad(a, b, c, d, positions, outward):
    """Two triangles of the quad a-b-c-d, wound counter-clockwise seen from ``outward``."""
    tris = [[a, b, c], [a, c, d]]
    p = positions
    if np.dot(np.cross(p[b] - p[a], p[c] - p[a]), outward) < 0.0:
        tris = [[a, c, b], [a, d, c]]
    return tris


def extruded_cells(xs, ys, occupied, z0: float, z1: float) -> trimesh.Trimesh:
    """Closed mesh of a set of grid cells extruded from z0 to z1.

    Every face lies on the grid, so neighbouring faces share whole edges: the result is
    watertight whatever the set (holes included), with outward counter-clockwise winding.

    Parameters
    ----------
    xs, ys : sequence of float, lengths nx + 1, ny + 1
        Grid lines [m].
    occupied : ndarray, shape (nx, ny), bool
        Cells that are solid.
    """
    xs, ys = np.asarray(xs, float), np.asarray(ys, float)
    nx, ny = len(xs) - 1, len(ys) - 1
    gi, gj, gk = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(2), indexing="ij")
    positions = np.column_stack([xs[gi.ravel()], ys[gj.ravel()], np.array([z0, z1])[gk.ravel()]])

    def vid(i, j, k):
        return (i * (ny + 1) + j) * 2 + k

    faces = []
    for i in range(nx):
        for j in range(ny):
            if not occupied[i, j]:
                continue
            for k, sign in ((1, 1.0), (0, -1.0)):  # top, bottom
                faces += _quad(
                    vid(i, j, k), vid(i + 1, j, k), vid(i + 1, j + 1, k), vid(i, j + 1, k), positions, [0.0, 0.0, sign]
                )
            for di, dj in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                ni, nj = i + di, j + dj
                if 0 <= ni < nx and 0 <= nj < ny and occupied[ni, nj]:
                    continue  # interior: no wall
                if di:  # wall at x = xs[i] or xs[i + 1]
                    x = i + (di > 0)
                    corners = (vid(x, j, 0), vid(x, j + 1, 0), vid(x, j + 1, 1), vid(x, j, 1))
                else:
                    y = j + (dj > 0)
                    corners = (vid(i, y, 0), vid(i + 1, y, 0), vid(i + 1, y, 1), vid(i, y, 1))
                faces += _quad(*corners, positions, [di, dj, 0.0])
    mesh = trimesh.Trimesh(positions, np.array(faces), process=False)
    mesh.remove_unreferenced_vertices()
    return mesh


def cinderblock() -> trimesh.Trimesh:
    """One block, lying flat: length along x, centred on x = y = 0, from z = 0 to the height."""
    xs = np.cumsum([0.0, WEB, (BLOCK_LENGTH - 3 * WEB) / 2, WEB, (BLOCK_LENGTH - 3 * WEB) / 2, WEB])
    ys = np.array([0.0, FACE_SHELL, BLOCK_WIDTH - FACE_SHELL, BLOCK_WIDTH])
    solid = np.ones((5, 3), dtype=bool)
    solid[1, 1] = solid[3, 1] = False  # the two cavities
    mesh = extruded_cells(xs - BLOCK_LENGTH / 2, ys - BLOCK_WIDTH / 2, solid, 0.0, BLOCK_HEIGHT)
    return mesh


def posed_block(pose: str, yaw_deg: float, x: float, y: float, base_z: float) -> trimesh.Trimesh:
    """A block in one of the poses, turned by yaw about z, centred on (x, y), bottom at base_z."""
    m = cinderblock()
    m.apply_translation([0.0, 0.0, -BLOCK_HEIGHT / 2])
    if pose == "side":
        m.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    elif pose == "end":
        m.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    elif pose != "flat":
        raise ValueError(f"unknown pose {pose!r}")
    m.apply_transform(trimesh.transformations.rotation_matrix(np.radians(yaw_deg), [0, 0, 1]))
    lo, hi = m.bounds
    m.apply_translation([x - (lo[0] + hi[0]) / 2, y - (lo[1] + hi[1]) / 2, base_z - lo[2]])
    return m


def stack(recipe, x: float, y: float, gap: float) -> list[trimesh.Trimesh]:
    blocks, z = [], gap
    for pose, yaw in recipe:
        b = posed_block(pose, yaw, x, y, z)
        blocks.append(b)
        z = b.bounds[1][2] + gap
    return blocks


def ground(size: float, thickness: float, cx: float, cy: float) -> trimesh.Trimesh:
    g = trimesh.creation.box(extents=[size, size, thickness])
    g.apply_translation([cx, cy, -thickness / 2])
    return g


def build(args) -> dict[str, tuple[str, trimesh.Trimesh]]:
    """Node name -> (material name, mesh), Z-up."""
    nodes = {"ground": ("ground", ground(args.ground_size, args.ground_thickness, *args.ground_center))}
    for label, recipe, (x, y) in (("near", NEAR_STACK, args.near), ("far", FAR_STACK, args.far)):
        for i, b in enumerate(stack(recipe, x, y, args.gap)):
            nodes[f"{label}_{i}"] = ("cinderblock", b)
    return nodes


def main(argv=None) -> None:
    here = Path(__file__).resolve().parent
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out-dir", type=Path, default=here, help="writes cinderblocks.glb there")
    p.add_argument("--out", type=Path, help="output file (default: OUT_DIR/cinderblocks.glb)")
    p.add_argument("--ground-size", type=float, default=60.0, help="ground square side [m]")
    p.add_argument("--ground-thickness", type=float, default=0.5, help="[m]; the top face is z = 0")
    p.add_argument("--ground-center", type=float, nargs=2, default=(0.0, 10.0), metavar=("X", "Y"))
    p.add_argument("--near", type=float, nargs=2, default=(-0.35, 3.5), metavar=("X", "Y"), help="near stack [m]")
    p.add_argument("--far", type=float, nargs=2, default=(0.45, 7.0), metavar=("X", "Y"), help="far stack [m]")
    p.add_argument("--gap", type=float, default=0.001, help="clearance under each block [m]")
    args = p.parse_args(argv)

    out = args.out or args.out_dir / "cinderblocks.glb"
    nodes = build(args)
    export_glb(nodes, out)
    check_glb(nodes, out)

    n_tri = sum(len(m.faces) for _, m in nodes.values())
    print(f"wrote {out} ({n_tri} triangles)")
    for name, (material, m) in nodes.items():
        if material == "cinderblock":
            lo, hi = m.bounds
            c = (lo + hi) / 2
            print(f"  {name}: centre ({c[0]:.3f}, {c[1]:.3f}), z {lo[2]:.3f}..{hi[2]:.3f} m, {len(m.faces)} triangles")
    mid = (np.array(args.near) + np.array(args.far)) / 2
    dist = float(np.hypot(*mid))
    look_z = IMAGER_HEIGHT - dist * np.tan(np.radians(18.0))  # centre the view 18 deg below level
    print(
        f"suggested imager: position [0, 0, {IMAGER_HEIGHT}], look_at [{mid[0]:.2f}, {mid[1]:.2f}, {look_z:.2f}], "
        "up [0, 0, 1], fov 30 deg, resolution [256, 256]"
    )


if __name__ == "__main__":
    main()
