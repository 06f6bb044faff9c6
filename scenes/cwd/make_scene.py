"""Write scenes/cwd/cwd_{outdoor,indoor}[_coated].glb: a man with a concealed gun (Murakowski 2014 sec. 3.2).

A bald man in street clothing (denim) carries a metal handgun in a leather shoulder holster under
his left arm; he wears leather shoes and stands on asphalt, outdoors or in a closed room. The
imager is 1.5 m up, 4 m away (30 deg field) or 20 m away (6 deg field).

The body is one closed surface of about 1.8 m: an implicit union of round cones (head, neck,
torso, arms, hands, legs, feet) blended smoothly (polynomial smooth minimum), meshed with
numpy-only surface nets on a voxel grid and projected onto the zero level. Garments are thin
closed shells made the same way and solidified inward (Blender's "solidify"): the clothing
(shirt and trousers as one 0.8 mm denim shell over torso, arms and legs, open at the neck, wrists
and ankles, loose by ``--clothing-gap`` and draped over the holster) and the shoes (4 mm leather,
open at the ankle). The holster is a 2 mm leather cup around the slide, the gun a closed block
model (slide, frame, raked grip, trigger guard); its grip sticks out of the cup, forward.

The person stands at the origin facing -y (his left is +x); the imager stands on the -y axis.
Outdoors: a 400 m square asphalt slab (top z = 0). Indoors: the slab plus a closed room (walls,
floor and ceiling as one hollow box whose inner surface faces the cavity) large enough for the
20 m view. Every mesh is closed and outward-oriented; solids that would touch are kept apart by
a gap. Mesh material names: ``skin``, ``clothing``, ``holster``, ``gun``, ``shoes``, ``ground``,
and ``walls`` indoors. The ``_coated`` files (``--clothing coating``) leave the clothing shell
out: map ``skin`` to ``clothed_skin`` (dry skin under a 0.8 mm denim coating) there, and to
``dry_skin`` where the shell is present.

The scene is built Z-up and rotated into glTF's Y-up on export; pmmw turns it back on load.

    python scenes/cwd/make_scene.py [--variant outdoor|indoor|all] [--clothing shell|coating|all] ...
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh
from scipy import ndimage

from pmmw.scene.export import check_glb, export_glb
from pmmw.scene.shapes import box, cell_block

VARIANTS = ("outdoor", "indoor")
CLOTHINGS = ("shell", "coating")

# Murakowski 2014 sec. 3.2.1: imager 1.5 m up, 1.0 m aperture, 740 x 440 pixels, 4 K noise; 30 deg field
# at 4 m and 6 deg at 20 m. A standing person needs the long side vertical, so the image is taken
# as 440 wide x 740 high with the stated field vertical; pmmw's fov is horizontal (see main).
IMAGER_HEIGHT = 1.5
IMAGER_VIEWS = ((4.0, 30.0), (20.0, 6.0))  # (distance [m], vertical field [deg])
IMAGER_RESOLUTION = (440, 740)
LOOK_AT_HEIGHT = 0.9  # [m], the middle of the person

# The body: round cones (a, b, r_a, r_b) [m], person at the origin facing -y, left = +x.
# Each group is blended internally with its own smoothing radius, groups with BLEND.
BLEND = 0.035  # [m], between groups (torso-arms, torso-legs, ...)
CULL = 0.25  # [m], see group_field: well above every blending radius


def _mirror(cones):
    """Left (+x) round cones and their mirror images on the right."""
    out = []
    for a, b, ra, rb in cones:
        out.append((a, b, ra, rb))
        out.append(((-a[0], a[1], a[2]), (-b[0], b[1], b[2]), ra, rb))
    return out


BODY = {
    "head": (
        0.03,
        [
            ((0.0, 0.005, 1.695), (0.0, 0.005, 1.70), 0.098, 0.098),  # cranium, top at 1.798
            ((0.0, -0.015, 1.610), (0.0, -0.005, 1.675), 0.055, 0.088),  # jaw and face
            ((0.0, -0.080, 1.675), (0.0, -0.098, 1.645), 0.012, 0.016),  # nose
        ],
    ),
    "neck": (0.03, [((0.0, 0.015, 1.43), (0.0, 0.010, 1.62), 0.058, 0.052)]),
    "torso": (
        0.06,
        [
            *_mirror(
                [
                    ((0.075, 0.000, 0.90), (0.068, 0.000, 1.08), 0.110, 0.094),  # hips to waist
                    ((0.068, 0.000, 1.08), (0.075, -0.005, 1.29), 0.094, 0.108),  # waist to chest
                    ((0.075, -0.005, 1.29), (0.065, 0.010, 1.40), 0.108, 0.095),  # upper chest
                ]
            ),
            ((-0.16, 0.012, 1.420), (0.16, 0.012, 1.420), 0.058, 0.058),  # shoulder girdle
        ],
    ),
    "arms": (
        0.02,
        _mirror(
            [
                ((0.195, 0.012, 1.415), (0.295, 0.030, 1.135), 0.050, 0.041),  # upper arm, ~20 deg out
                ((0.295, 0.030, 1.135), (0.345, -0.020, 0.880), 0.041, 0.031),  # forearm
            ]
        ),
    ),
    "hands": (
        0.02,
        _mirror(
            [
                ((0.348, -0.022, 0.865), (0.366, -0.032, 0.725), 0.030, 0.022),
            ]
        ),
    ),
    "legs": (
        0.03,
        _mirror(
            [
                ((0.090, 0.000, 0.900), (0.098, 0.005, 0.500), 0.078, 0.052),  # thigh
                ((0.098, 0.005, 0.500), (0.105, 0.030, 0.106), 0.052, 0.036),  # shin, ankle at 0.106
            ]
        ),
    ),
    "feet": (
        0.02,
        _mirror(
            [
                ((0.105, 0.040, 0.054), (0.115, -0.150, 0.044), 0.038, 0.028),  # heel to toes, sole at 0.016
                ((0.105, 0.030, 0.106), (0.105, 0.040, 0.054), 0.036, 0.038),  # ankle
            ]
        ),
    ),
}
COVERED = ("neck", "torso", "arms", "legs")  # the clothing follows these
# Open ends of the garments (faces beyond these planes are cut away) [m].
NECK_CUT_Z = 1.485  # collar, below the jaw
ANKLE_CUT_Z = 0.165  # trousers end above the shoes
SHOE_TOP_Z = 0.125
WRIST_CUT_BACK = 0.03  # [m] short of the wrist, along the forearm
DRAPE_ROUNDING = 0.03  # [m], edge radius of the shirt over the holster
DRAPE_BLEND = 0.08  # [m], how far the shirt blends from the holster into the chest


# -- implicit modelling ---------------------------------------------------------------------------


def round_cone(p, a, b, ra, rb):
    """Signed distance [m] from points p (N, 3) to the round cone (a, ra) -> (b, rb).

    Exact for the convex hull of the two spheres (Inigo Quilez's formula).
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    ba = b - a
    l2 = ba @ ba
    rr = ra - rb
    a2 = l2 - rr * rr
    pa = p - a
    y = pa @ ba
    z = y - l2
    w = pa * l2 - y[:, None] * ba
    x2 = np.einsum("ij,ij->i", w, w)
    y2, z2 = y * y * l2, z * z * l2
    k = np.sign(rr) * rr * rr * x2
    end_b = np.sign(z) * a2 * z2 > k
    end_a = np.sign(y) * a2 * y2 < k
    side = (np.sqrt(np.maximum(x2 * a2 / l2, 0.0)) + y * rr) / l2 - ra
    return np.where(end_b, np.sqrt(x2 + z2) / l2 - rb, np.where(end_a, np.sqrt(x2 + y2) / l2 - ra, side))


def skin_field(p):
    """The body's implicit field [m] at points p (N, 3): negative inside, 1-Lipschitz."""
    return group_field(p, BODY)


def smin(a, b, k):
    """Polynomial smooth minimum with blending radius k [m]; <= min(a, b) and 1-Lipschitz."""
    if k <= 0.0:
        return np.minimum(a, b)
    h = np.maximum(k - np.abs(a - b), 0.0) / k
    return np.minimum(a, b) - h * h * k / 4.0


def box_sdf(p, centre, rotation, half):
    """Signed distance [m] to an oriented box: rotation (3, 3) columns are the box axes."""
    q = np.abs((p - centre) @ rotation) - half
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)


def group_field(p, groups, offset=0.0, side=None):
    """Smooth union of body groups, each grown by ``offset`` [m]; ``side`` +1 or -1 keeps the
    round cones of the left (+x) or right side only.

    A round cone is evaluated only within CULL [m] of its bounding box; beyond, its distance is
    taken as CULL (a lower bound), which leaves the field exact wherever it is within CULL minus
    the blending radii of zero, and positive elsewhere.
    """
    d = None
    cols = [np.ascontiguousarray(p[:, i]) for i in range(3)]
    for name in groups:
        k, cones = BODY[name]
        g = None
        for a, b, ra, rb in cones:
            if side is not None and np.sign(a[0]) != side:
                continue
            r = max(ra, rb) + offset + CULL
            lo, hi = np.minimum(a, b) - r, np.maximum(a, b) + r
            near = (cols[0] >= lo[0]) & (cols[0] <= hi[0]) & (cols[1] >= lo[1]) & (cols[1] <= hi[1])
            near &= (cols[2] >= lo[2]) & (cols[2] <= hi[2])
            c = np.full(len(p), CULL)
            c[near] = round_cone(p[near], a, b, ra + offset, rb + offset)
            g = c if g is None else smin(g, c, k)
        d = g if d is None else smin(d, g, BLEND)
    return d


def surface_nets(field, lo, hi, h: float) -> trimesh.Trimesh:
    """Closed, outward triangle mesh of {field < 0} by naive surface nets on a cubic grid.

    One vertex per grid cell that the surface crosses, at the mean of the edge crossings, then
    projected onto the zero level (two Newton steps of at most h / 2); one quad (two triangles,
    split along the shorter diagonal) per grid edge with a sign change, wound outward.

    Parameters
    ----------
    field : callable, (N, 3) float64 [m] -> (N,) float64 [m]
        Negative inside; must be positive on the grid's boundary.
    lo, hi : sequence of 3 float
        Grid box [m].
    h : float
        Grid step [m].
    """
    lo = np.asarray(lo, float)
    n = np.ceil((np.asarray(hi, float) - lo) / h).astype(int) + 1
    axes = [lo[i] + h * np.arange(n[i]) for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    f = field(grid.reshape(-1, 3)).reshape(n)
    if (
        (f[0] <= 0).any()
        or (f[-1] <= 0).any()
        or (f[:, 0] <= 0).any()
        or (f[:, -1] <= 0).any()
        or (f[:, :, 0] <= 0).any()
        or (f[:, :, -1] <= 0).any()
    ):
        raise ValueError("the surface reaches the grid boundary")
    inside = f < 0.0
    # One solid without cavities: fill air pockets enclosed by the solid, drop loose specks.
    air, _ = ndimage.label(~inside)
    pockets = ~inside & (air != air[0, 0, 0])
    solid, n_solid = ndimage.label(inside | pockets)
    if n_solid > 1:
        sizes = np.bincount(solid.ravel())
        sizes[0] = 0
        specks = (solid != np.argmax(sizes)) & (solid > 0)
    else:
        specks = np.zeros_like(inside)
    f = np.where(pockets, -1e-9, np.where(specks, 1e-9, f))
    inside = f < 0.0
    cells = n - 1
    acc = np.zeros((*cells, 3))
    cnt = np.zeros(cells)
    quads = []
    cell_id = np.full(cells, -1, dtype=np.int64)
    for axis in range(3):
        s0 = [slice(None)] * 3
        s1 = [slice(None)] * 3
        s0[axis], s1[axis] = slice(0, -1), slice(1, None)
        f0, f1 = f[tuple(s0)], f[tuple(s1)]
        crossing = inside[tuple(s0)] != inside[tuple(s1)]
        t = np.where(crossing, f0 / np.where(crossing, f0 - f1, 1.0), 0.0)
        point = grid[tuple(s0)] + t[..., None] * (grid[tuple(s1)] - grid[tuple(s0)])
        point = np.where(crossing[..., None], point, 0.0)
        # An edge along `axis` touches the 4 cells around it in the other two axes.
        u, v = [i for i in range(3) if i != axis]
        for du in (0, 1):
            for dv in (0, 1):
                src = [slice(None)] * 3
                src[u] = slice(du, du + cells[u])
                src[v] = slice(dv, dv + cells[v])
                acc += point[tuple(src)]
                cnt += crossing[tuple(src)]
    active = cnt > 0
    cell_id[active] = np.arange(int(active.sum()))
    vertices = acc[active] / cnt[active][:, None]
    for axis in range(3):
        u, v = [i for i in range(3) if i != axis]
        s0 = [slice(None)] * 3
        s1 = [slice(None)] * 3
        s0[axis], s1[axis] = slice(0, -1), slice(1, None)
        crossing = inside[tuple(s0)] != inside[tuple(s1)]
        out_up = inside[tuple(s0)] & crossing  # inside below, outside above: normal +axis
        # Interior edges only (the boundary is outside everywhere).
        idx = np.argwhere(crossing)
        idx = idx[(idx[:, u] > 0) & (idx[:, v] > 0) & (idx[:, u] < n[u] - 1) & (idx[:, v] < n[v] - 1)]
        up = out_up[tuple(idx.T)]
        ring = []
        for du, dv in ((-1, -1), (0, -1), (0, 0), (-1, 0)):  # counter-clockwise seen from +axis
            c = idx.copy()
            c[:, u] += du
            c[:, v] += dv
            ring.append(cell_id[tuple(c.T)])
        q = np.stack(ring, axis=1)
        if (u, v) != ((axis + 1) % 3, (axis + 2) % 3):  # (u, v, axis) must be right-handed
            q = q[:, ::-1]
        q = np.where(up[:, None], q, q[:, ::-1])
        quads.append(q)
    q = np.concatenate(quads)
    vertices = _project(field, vertices, h)
    d02 = np.linalg.norm(vertices[q[:, 0]] - vertices[q[:, 2]], axis=1)
    d13 = np.linalg.norm(vertices[q[:, 1]] - vertices[q[:, 3]], axis=1)
    split02 = d02 <= d13
    faces = np.concatenate(
        [
            np.where(split02[:, None], q[:, [0, 1, 2]], q[:, [0, 1, 3]]),
            np.where(split02[:, None], q[:, [0, 2, 3]], q[:, [1, 2, 3]]),
        ]
    )
    return trimesh.Trimesh(vertices, faces, process=False)


def closed_surface(field, lo, hi, h: float, tries: int = 8) -> trimesh.Trimesh:
    """`surface_nets` on a grid shifted by fractions of h until the mesh is closed.

    Naive surface nets give one vertex per cell, so two sheets of surface closer than a cell
    (a thin crease) can meet at a non-manifold edge; another grid offset samples them apart.
    """
    for k in range(tries):
        shift = h * np.array([0.37, 0.23, 0.11]) * k
        mesh = surface_nets(field, np.asarray(lo, float) - shift, hi, h)
        if mesh.is_watertight:
            return mesh
    raise SystemExit(f"no closed surface after {tries} grid offsets; try another --voxel")


def _gradient(field, p, eps=1e-5):
    g = np.empty_like(p)
    for i in range(3):
        d = np.zeros(3)
        d[i] = eps
        g[:, i] = (field(p + d) - field(p - d)) / (2 * eps)
    return g


def _project(field, p, h):
    for _ in range(2):
        g = _gradient(field, p)
        step = field(p)[:, None] * g / np.maximum(np.einsum("ij,ij->i", g, g), 1e-12)[:, None]
        norm = np.linalg.norm(step, axis=1, keepdims=True)
        p = p - step * np.minimum(1.0, 0.5 * h / np.maximum(norm, 1e-300))
    return p


def cut(mesh: trimesh.Trimesh, keep) -> trimesh.Trimesh:
    """The faces whose three vertices satisfy keep(vertices) -> (V,) bool."""
    ok = keep(mesh.vertices)
    m = trimesh.Trimesh(mesh.vertices, mesh.faces[ok[mesh.faces].all(axis=1)], process=False)
    m.remove_unreferenced_vertices()
    return m


def solidify(surface: trimesh.Trimesh, thickness: float) -> trimesh.Trimesh:
    """A closed shell of an open, outward surface: an inner copy offset by ``thickness`` [m]
    against the vertex normals, turned inside out, and a rim along every boundary edge."""
    v, f = surface.vertices, surface.faces
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # area-weighted
    vn = np.zeros_like(v)
    for i in range(3):
        np.add.at(vn, f[:, i], fn)
    vn /= np.linalg.norm(vn, axis=1, keepdims=True)
    nv = len(v)
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    boundary = edges[counts[inverse.ravel()] == 1]  # directed as in their face: a -> b
    a, b = boundary[:, 0], boundary[:, 1]
    rim = np.concatenate([np.stack([b, a, a + nv], axis=1), np.stack([b, a + nv, b + nv], axis=1)])
    return trimesh.Trimesh(np.vstack([v, v - thickness * vn]), np.concatenate([f, f[:, ::-1] + nv, rim]), process=False)


def hollow_box(lo, hi, wall: float) -> trimesh.Trimesh:
    """A closed shell: the wall volume between the box lo..hi (the cavity) and the box grown by
    ``wall``; the inner surface faces the cavity."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    inner = box(lo, hi)
    inner.invert()
    return trimesh.util.concatenate([box(lo - wall, hi + wall), inner])


# -- the gun and holster ----------------------------------------------------------------------------

# Gun profile in its own frame: X along the barrel (muzzle at +X), Z up, Y across (3 cm).
GUN_XS = (0.0, 0.055, 0.062, 0.098, 0.105, 0.200)
GUN_ZS = (0.0, 0.055, 0.062, 0.085, 0.095, 0.130)
GUN_CELLS = (  # rows bottom to top; columns along GUN_XS cells
    "X....",  # grip
    "XXXX.",  # grip, trigger guard bottom
    "XX.X.",  # grip, trigger (guard opening), guard front
    "XXXXX",  # frame
    "XXXXX",  # slide
)
GUN_WIDTH = 0.030
GRIP_RAKE_DEG = 16.0  # the grip leans back below the frame
HOLSTER_MOUTH_X = 0.07  # the holster covers the gun from here to the muzzle; the grip sticks out


def gun_local() -> trimesh.Trimesh:
    occ = np.array([[c == "X" for c in row] for row in GUN_CELLS]).T  # (x, z)
    m = cell_block(GUN_XS, (-GUN_WIDTH / 2, GUN_WIDTH / 2), GUN_ZS, occ[:, None, :])
    v = np.array(m.vertices)
    v[:, 0] -= np.maximum(GUN_ZS[3] - v[:, 2], 0.0) * np.tan(np.radians(GRIP_RAKE_DEG))  # rake below the frame
    return trimesh.Trimesh(v, m.faces, process=False)


def holster_local(thickness: float, clearance: float) -> trimesh.Trimesh:
    """A leather cup around the gun's front, open at X = HOLSTER_MOUTH_X (towards the grip)."""
    t, c = thickness, clearance
    x_end = GUN_XS[-1] + c
    y_in = GUN_WIDTH / 2 + c
    z_lo, z_hi = GUN_ZS[1] - c - 0.003, GUN_ZS[-1] + c
    xs = (HOLSTER_MOUTH_X, x_end, x_end + t)
    ys = (-y_in - t, -y_in, y_in, y_in + t)
    zs = (z_lo - t, z_lo, z_hi, z_hi + t)
    occ = np.ones((2, 3, 3), dtype=bool)
    occ[0, 1, 1] = False  # the cavity, open at the mouth
    return cell_block(xs, ys, zs, occ)


def gun_frame(args):
    """Rotation (columns: the gun's X, Y, Z axes in the world) and origin of the gun frame.

    The gun lies flat against the left side of the chest under the arm, its +Y side towards the
    body, barrel pointing back and down, grip forward.
    """
    az = np.radians(args.holster_azimuth)  # 0: straight out to the left (+x); >0: towards the front
    n_out = np.array([np.cos(az), -np.sin(az), 0.0])  # outward normal of the chest there
    tangent = np.array([np.sin(az), np.cos(az), 0.0])  # horizontal, towards the back
    tilt = np.radians(args.holster_tilt)
    x_axis = np.cos(tilt) * tangent - np.sin(tilt) * np.array([0.0, 0.0, 1.0])
    y_axis = -n_out
    z_axis = np.cross(x_axis, y_axis)
    rot = np.column_stack([x_axis, y_axis, z_axis])
    return rot, n_out


def place_gun(args, gap: float):
    """Gun and holster meshes in the world, the holster's body side ``gap`` off the skin."""
    rot, n_out = gun_frame(args)
    gun, holster = gun_local(), holster_local(args.holster_thickness, args.holster_clearance)
    centre_local = np.array([(GUN_XS[0] + GUN_XS[-1]) / 2, 0.0, (GUN_ZS[0] + GUN_ZS[-1]) / 2])
    # Walk out from inside the chest along n_out until the holster clears the skin by `gap`.
    anchor = np.array([0.0, 0.0, args.holster_height])
    local_samples = [surface_samples(holster), surface_samples(gun)]

    def clearance(s):
        origin = anchor + s * n_out - rot @ centre_local
        return min(skin_field(pts @ rot.T + origin).min() for pts in local_samples)

    inside, outside = 0.0, 0.4  # [m] along n_out; bisect to the smallest distance with clearance >= gap
    if clearance(inside) >= gap or clearance(outside) < gap:
        raise SystemExit("cannot place the holster")
    while outside - inside > 1e-5:
        mid = (inside + outside) / 2
        inside, outside = (inside, mid) if clearance(mid) >= gap else (mid, outside)
    origin = anchor + outside * n_out - rot @ centre_local
    h = trimesh.Trimesh(holster.vertices @ rot.T + origin, holster.faces, process=False)
    g = trimesh.Trimesh(gun.vertices @ rot.T + origin, gun.faces, process=False)
    return g, h


def surface_samples(mesh: trimesh.Trimesh, n: int = 6) -> np.ndarray:
    """Points (F * (n + 1) * (n + 2) / 2, 3) [m] on a barycentric grid over every face."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    w = np.column_stack([i[keep], j[keep], n - i[keep] - j[keep]]) / n  # (S, 3) weights
    return np.einsum("sk,fkd->fsd", w, mesh.triangles).reshape(-1, 3)


# -- the person -------------------------------------------------------------------------------------


def person(args):
    """Node name -> (material name, mesh) of the body, clothing, shoes, holster and gun."""
    body = closed_surface(skin_field, (-0.45, -0.25, -0.02), (0.45, 0.2, 1.85), args.voxel)
    gun, holster = place_gun(args, args.holster_gap)
    return {
        "body": ("skin", body),
        "clothing": ("clothing", clothing(args, np.vstack([holster.vertices, gun.vertices]))),
        "shoe_left": ("shoes", shoe(args, +1)),
        "shoe_right": ("shoes", shoe(args, -1)),
        "holster": ("holster", holster),
        "gun": ("gun", gun),
    }


def clothing(args, under) -> trimesh.Trimesh:
    """Shirt and trousers: one denim shell, open at the neck, wrists and ankles, draped over the
    points ``under`` (N, 3) [m] (the holster and the gun) as over an oriented box around them."""
    t, gap = args.clothing_thickness, args.clothing_gap
    rot, _ = gun_frame(args)
    local = under @ rot
    centre = rot @ ((local.min(axis=0) + local.max(axis=0)) / 2)
    half = (local.max(axis=0) - local.min(axis=0)) / 2

    # A rounded box that still holds every corner of the box: inner half sizes shrunk by
    # R / sqrt(3), so that each corner lies within R of the inner box.
    inner = np.maximum(half - DRAPE_ROUNDING / np.sqrt(3.0), 0.0)

    def field(p):  # the bump blends into the trunk, then the sleeves join as the body's arms do
        trunk = group_field(p, [g for g in COVERED if g != "arms"], gap + t)
        bump = box_sdf(p, centre, rot, inner) - DRAPE_ROUNDING - (gap + t)
        return smin(smin(trunk, bump, DRAPE_BLEND), group_field(p, ("arms",), gap + t), BLEND)

    outer = closed_surface(field, (-0.48, -0.27, 0.0), (0.48, 0.22, 1.75), args.voxel)
    wrists = []
    for elbow, wrist, _, _ in BODY["arms"][1][2:]:  # the two forearms
        elbow, wrist = np.asarray(elbow), np.asarray(wrist)
        axis = (wrist - elbow) / np.linalg.norm(wrist - elbow)
        wrists.append((wrist - WRIST_CUT_BACK * axis, axis))

    def keep(v):
        ok = (v[:, 2] < NECK_CUT_Z) & (v[:, 2] > ANKLE_CUT_Z)
        for point, axis in wrists:  # the plane cuts the sleeve only, not the trousers beside it
            ok &= ((v - point) @ axis < 0.0) | (np.linalg.norm(v - point, axis=1) > 0.12)
        return ok

    return solidify(cut(outer, keep), t)


def shoe(args, side: float) -> trimesh.Trimesh:
    """A leather shoe: a shell of ``--shoe-thickness`` around the foot, open at the ankle."""
    t, gap = args.shoe_thickness, args.shoe_gap

    def field(p):  # foot and leg, grown; capped well above the shoe's top
        return np.maximum(group_field(p, ("legs", "feet"), gap + t, side), p[:, 2] - (SHOE_TOP_Z + 0.05))

    x0 = side * 0.11
    outer = closed_surface(field, (x0 - 0.09, -0.25, -0.01), (x0 + 0.09, 0.12, 0.22), args.shoe_voxel)
    return solidify(cut(outer, lambda v: v[:, 2] < SHOE_TOP_Z), t)


# -- the surroundings -------------------------------------------------------------------------------


def surroundings(variant: str, args):
    g = args.gap
    if variant == "outdoor":
        half = args.ground_size / 2
        return {"ground": ("ground", box([-half, -half, -args.ground_thickness], [half, half, 0.0]))}
    w, length, height = args.room
    y1 = args.room_back
    y0 = y1 - length
    floor = box([-w / 2 + g, y0 + g, -args.ground_thickness], [w / 2 - g, y1 - g, 0.0])
    walls = hollow_box([-w / 2, y0, -args.ground_thickness - g], [w / 2, y1, height], args.wall_thickness)
    return {"ground": ("ground", floor), "room": ("walls", walls)}


# -- export and checks ------------------------------------------------------------------------------


def check_clearance(nodes) -> dict[str, float]:
    """Smallest distances [m] between parts that must not touch: to the skin from the body's
    implicit field (a lower bound on the distance to its zero level), between meshes by brute
    force near the holster, and by height between trousers and shoes, and shoes and ground."""
    out = {}
    for name, (material, mesh) in nodes.items():
        if material in ("clothing", "shoes"):
            out[f"skin-{name}"] = float(skin_field(np.vstack([mesh.vertices, mesh.triangles_center])).min())
        elif material in ("holster", "gun"):
            out[f"skin-{name}"] = float(skin_field(surface_samples(mesh)).min())
    holster, gun = nodes["holster"][1], nodes["gun"][1]
    out["gun-holster"] = _distance_to_mesh(surface_samples(gun), holster)
    shoes = [m for material, m in nodes.values() if material == "shoes"]
    out["shoes-ground"] = float(min(m.vertices[:, 2].min() for m in shoes))
    if "clothing" in nodes:
        cloth = nodes["clothing"][1]
        out["clothing-shoes"] = float(cloth.vertices[:, 2].min() - max(m.vertices[:, 2].max() for m in shoes))
        pts = np.vstack([cloth.vertices, cloth.triangles_center])
        lo, hi = holster.bounds[0] - 0.03, holster.bounds[1] + 0.03
        near = pts[(pts >= lo).all(axis=1) & (pts <= hi).all(axis=1)]
        out["clothing-holster"] = _distance_to_mesh(near, holster)
        out["clothing-gun"] = _distance_to_mesh(near, gun)
    return out


def _distance_to_mesh(points, mesh) -> float:
    """Smallest distance [m] from points (N, 3) to a small mesh's surface, by brute force."""
    tri = mesh.triangles
    best = np.inf
    for chunk in np.array_split(points, max(1, len(points) * len(tri) // 200_000)):
        q = np.repeat(chunk, len(tri), axis=0)
        c = trimesh.triangles.closest_point(np.tile(tri, (len(chunk), 1, 1)), q)
        best = min(best, float(np.linalg.norm(c - q, axis=1).min()))
    return best


def main(argv=None) -> None:
    here = Path(__file__).resolve().parent
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--variant", choices=(*VARIANTS, "all"), default="all", help="surroundings to write")
    p.add_argument(
        "--clothing",
        choices=(*CLOTHINGS, "all"),
        default="all",
        help="shell: a denim shell mesh 'clothing' (cwd_<variant>.glb); coating: no clothing mesh, "
        "map 'skin' to clothed_skin (cwd_<variant>_coated.glb)",
    )
    p.add_argument("--out-dir", type=Path, default=here, help="where the files are written")
    p.add_argument("--out", type=Path, help="output file (only with a single --variant and --clothing)")
    p.add_argument("--voxel", type=float, default=0.0125, help="surface-nets grid step of body and clothing [m]")
    p.add_argument("--shoe-voxel", type=float, default=0.008, help="surface-nets grid step of the shoes [m]")
    p.add_argument(
        "--clothing-thickness", type=float, default=0.0008, help="denim [m] (Murakowski 2014 sec. 3.2.1: 0.8 mm)"
    )
    p.add_argument("--clothing-gap", type=float, default=0.006, help="air between skin and clothing [m]")
    p.add_argument("--shoe-thickness", type=float, default=0.004, help="[m]")
    p.add_argument("--shoe-gap", type=float, default=0.003, help="air between foot and shoe [m]")
    p.add_argument(
        "--holster-thickness", type=float, default=0.002, help="leather [m] (Murakowski 2014 sec. 3.2.1: 2 mm)"
    )
    p.add_argument("--holster-clearance", type=float, default=0.002, help="gun to holster wall [m]")
    p.add_argument("--holster-gap", type=float, default=0.003, help="skin to holster [m]")
    p.add_argument("--holster-height", type=float, default=1.17, help="gun centre height [m]")
    p.add_argument(
        "--holster-azimuth",
        type=float,
        default=35.0,
        help="where on the left side of the chest [deg from +x towards the front]",
    )
    p.add_argument(
        "--holster-tilt", type=float, default=75.0, help="barrel below horizontal [deg] (muzzle down, grip forward)"
    )
    p.add_argument("--ground-size", type=float, default=400.0, help="outdoor asphalt square [m]")
    p.add_argument("--ground-thickness", type=float, default=0.3, help="[m]; the top face is z = 0")
    p.add_argument(
        "--room",
        type=float,
        nargs=3,
        default=(8.0, 26.0, 3.0),
        metavar=("W", "L", "H"),
        help="indoor room cavity [m]: x width, y length (holds the 20 m view), height",
    )
    p.add_argument("--room-back", type=float, default=3.0, help="back wall's inner face: y [m]")
    p.add_argument("--wall-thickness", type=float, default=0.2, help="[m]")
    p.add_argument("--gap", type=float, default=0.001, help="clearance between floor and walls, shoes and ground [m]")
    p.add_argument("--min-clearance", type=float, default=0.0015, help="smallest allowed gap between parts [m]")
    args = p.parse_args(argv)
    variants = VARIANTS if args.variant == "all" else (args.variant,)
    clothings = CLOTHINGS if args.clothing == "all" else (args.clothing,)
    if args.out is not None and len(variants) * len(clothings) > 1:
        p.error("--out needs a single --variant and --clothing")

    people = person(args)
    clearance = check_clearance(people)
    for pair, d in clearance.items():
        if d < args.min_clearance:
            raise SystemExit(f"{pair}: {d * 1e3:.2f} mm apart, less than {args.min_clearance * 1e3:.1f} mm")
    for variant in variants:
        for dress in clothings:
            out = args.out or args.out_dir / f"cwd_{variant}{'' if dress == 'shell' else '_coated'}.glb"
            nodes = {k: v for k, v in people.items() if dress == "shell" or k != "clothing"}
            nodes |= surroundings(variant, args)
            export_glb(nodes, out)
            check_glb(nodes, out)
            n_tri = sum(len(m.faces) for _, m in nodes.values())
            print(f"wrote {out} ({n_tri} triangles)")
    for name, (material, m) in {**people, **surroundings("indoor", args)}.items():
        lo, hi = m.bounds
        print(f"  {name} ({material}): {len(m.faces)} triangles, z {lo[2]:.3f}..{hi[2]:.3f} m")
    for pair, d in clearance.items():
        print(f"  clearance {pair}: {d * 1e3:.1f} mm")
    for dist, vfov in IMAGER_VIEWS:
        hfov = 2 * np.degrees(np.arctan(np.tan(np.radians(vfov / 2)) * IMAGER_RESOLUTION[0] / IMAGER_RESOLUTION[1]))
        print(
            f"suggested imager ({dist:g} m, {vfov:g} deg vertical field): position [0, {-dist:g}, {IMAGER_HEIGHT}], "
            f"look_at [0, 0, {LOOK_AT_HEIGHT}], up [0, 0, 1], fov {hfov:.2f} deg (horizontal), "
            f"resolution [{IMAGER_RESOLUTION[0]}, {IMAGER_RESOLUTION[1]}]"
        )


if __name__ == "__main__":
    main()
