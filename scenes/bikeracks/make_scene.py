"""Write scenes/bikeracks/bikeracks{,_tree}.glb: bike racks behind Evans Hall (Murakowski 2014, sec. 2.3.4).

The last validation scene of Murakowski 2014 (sec. 2.3.4, Fig. 2.9, Table 2.3): bicycles at bike
racks on a brick-paved yard behind Evans Hall (University of Delaware), seen at 35 GHz by the
scanning cart's imager. The thesis models "a large tree directly behind the imager" and "the
buildings surrounding this area", which are not in its photograph, because "they have significant
impact on the simulated image". Its figures are not at hand, so the scene is built from the text:

* a **brick-paved yard** (Table 2.3 'Bricks', modelled as concrete) 24 m x 16.5 m, the imager on it
  at the origin looking along +y; **grass** (Table 2.3 'Grass', moist soil) around it, up to the
  buildings;
* **Evans Hall**, a brick wall 14 m ahead, 12 m high, with ground-floor windows (Table 2.3
  'Windows', fused silica panes in 12 cm recesses); brick buildings 20 m to either side (10 m
  high) and 26 m behind the imager (6 m high);
* a **fence** 9 m ahead: metal posts (8 cm, 0.9 m high) every 1.5 m, each with a **conical cap**
  (45 deg), and **chains** of metal links (6 mm round wire) sagging between them;
* two **bike racks** on the yard: pairs of capped metal posts joined by a rail, the first across
  the view, the second along it;
* two **bicycles** with metal frames (tubes), metal rims, hubs and front gear, SA-9 rubber tires
  (Table 2.3 'Tires') and plastic saddle, grips and pedals (Table 2.3 'Plastics', polypropylene):
  the *near* one in front of the first rack, leaning 25 deg away from the imager and turned
  20 deg from the image plane, so that its rims face the imager and mirror the sky; the *far* one
  stands upright beside the second rack, pointing away, its wheels edge-on: they mirror the
  ground and the horizon;
* a **U-lock** (metal) hanging on the second rack's rail, its crossbar across the view;
* the **tree** behind the imager (its own file, ``bikeracks_tree.glb``, so that a scenario can
  leave it out): a large one, a trunk and a canopy 22 m wide from 2 m to 10 m up, 2 m to 16 m
  behind the imager.

Why the tree matters (sec. 2.3.4): a fence post seen directly reflects a ray that is going down,
which the paving then sends back low over the imager's head into the building behind it: warm, and
the posts nearly vanish. Seen in the bricks, a post reflects a ray that was going up, which leaves
10-15 deg above the horizon back towards the imager's side, fanned out sideways by the round post:
over the low building behind into the cold sky without the tree (the posts' reflections in the
bricks are "very clear"); into the canopy (the middle of the fan) and the side buildings (its
edges) with it (they fade). That is why the canopy is wide, and the side buildings 10 m high.

Mesh material names: ``bricks``, ``grass``, ``windows``, ``posts`` (fence and rack posts, caps,
rails), ``chain``, ``frame`` (bicycle frames, rims, hubs, cranks, gears), ``lock``, ``tires``,
``plastics``; ``tree`` in the tree's file. Every dielectric part is a closed mesh at least
``--gap`` from every other; metal parts interpenetrate where they join (a perfect conductor has no
inside for the tracer to track). ``--omit PREFIX ...`` leaves out the nodes whose names start so
(e.g. ``lock``, ``near_bike``, ``post_3``): the controls of the detection checks.

The scene is built Z-up (pmmw's world frame) and rotated into glTF's Y-up on export; pmmw turns it
back on load. Run from anywhere:

    python scenes/bikeracks/make_scene.py [--out-dir DIR] [--omit PREFIX ...] [--no-tree] ...
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path

import numpy as np
import trimesh

from pmmw.scene.export import check_glb, export_glb
from pmmw.scene.shapes import box, cell_block

IMAGER_HEIGHT = 1.5  # [m], the thesis's cart-mounted dish

# The yard and its surroundings [m] (x across, y ahead of the imager).
PAVING = (-12.0, -6.0, 12.0, 10.5)  # x0, y0, x1, y1
GROUND_THICKNESS = 0.3
WALL_Y, WALL_HEIGHT = 14.0, 12.0  # Evans Hall's face, its height
SIDE_X, SIDE_HEIGHT = 20.0, 10.0  # the side buildings' faces at +-x, their height
BACK_Y, BACK_HEIGHT = -26.0, 6.0  # the building behind the imager
BUILDING_DEPTH = 10.0
WINDOWS = {
    "xs": np.arange(-10.5, 10.6, 3.0),
    "width": 1.2,
    "z": (0.9, 2.4),
    "recess": 0.12,
    "pane": 0.008,
    "pane_depth": 0.06,
}

# Facets of posts, rails and caps: a cylinder of n facets mirrors n directions only (16 facets
# would send a post's reflections 22.5 deg apart); 48 keep them 7.5 deg apart.
ROUND_SECTIONS = 48

# The fence: posts along y = FENCE_Y.
FENCE_Y = 9.0
FENCE_XS = np.arange(-4.5, 4.6, 1.5)
POST_RADIUS, POST_HEIGHT = 0.04, 0.90
CAP_RADIUS, CAP_HEIGHT = 0.06, 0.06  # a 45 deg cone on top of each post
CHAIN_Z, CHAIN_SAG = 0.80, 0.15  # attachment height, sag at mid-span
LINK = {"pitch": 0.045, "straight": 0.030, "radius": 0.0125, "wire": 0.006, "points": 12}

# Bike racks: the (x, y) of their two posts, a rail between them. The first runs across the view,
# the second along it.
RACKS = (((-2.3, 5.8), (-1.3, 5.8)), ((1.9, 6.75), (1.9, 7.75)))
RACK_POST_RADIUS, RACK_HEIGHT, RACK_RAIL_Z, RACK_RAIL_RADIUS = 0.03, 0.85, 0.70, 0.025
RACK_CAP = (0.045, 0.045)

# A bicycle in its own frame: X forward, Y to its left, Z up, tires on z = 0 (700c wheels).
WHEEL_RADIUS, TIRE_SECTION = 0.34, 0.014  # outer radius, tire cross-section radius
RIM = (0.270, 0.306, 0.020)  # inner, outer radius, width
WHEELBASE = 1.08
BIKE_POINTS = {  # frame joints [m]
    "rear_hub": (0.0, 0.0, WHEEL_RADIUS),
    "front_hub": (WHEELBASE, 0.0, WHEEL_RADIUS),
    "bb": (0.41, 0.0, 0.27),
    "seat": (0.28, 0.0, 0.80),
    "head_top": (0.91, 0.0, 0.84),
    "head_bottom": (0.95, 0.0, 0.72),
    "seat_post": (0.25, 0.0, 0.93),
    "stem": (0.89, 0.0, 0.97),
}
TUBE_RADIUS = 0.016
# Where the bicycles stand: (rear hub x, y, yaw [deg] of their forward axis from +x towards +y,
# lean [deg], away from the imager; front wheel steer [deg]).
NEAR_BIKE = (-0.75, 5.05, 160.0, 25.0, 0.0)
FAR_BIKE = (1.35, 6.7, 90.0, 0.0, 0.0)  # upright beside the second rack, pointing away: wheels edge-on
LOCK_AT = (1.9, 6.95)  # the U-lock hangs on the second rack's rail here, its crossbar across the view

# The tree behind the imager, a large one: trunk (x, y, radius, top) and a canopy ellipsoid
# (centre, radii) 22 m wide, 14 m deep, from 2 m to 10 m up, 2 m to 16 m behind the imager.
TRUNK = (0.0, -9.0, 0.4, 1.95)
CANOPY = ((0.0, -9.0, 6.0), (11.0, 7.0, 4.0))


# -- mesh helpers -----------------------------------------------------------------------------------


def cylinder(p0, p1, radius: float, sections: int = 12) -> trimesh.Trimesh:
    """Closed cylinder of ``radius`` [m] from p0 to p1."""
    return trimesh.creation.cylinder(radius=radius, segment=[p0, p1], sections=sections)


def tube(p0, p1, radius: float, sections: int = 24) -> trimesh.Trimesh:
    """A metal tube from joint p0 to joint p1, running half its radius into both joints: tubes
    that meet at a joint then share no cap centre (two caps about one point, turned about a
    common axis, would share an edge, and the scene's mesh would not be closed)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = (p1 - p0) / np.linalg.norm(p1 - p0)
    return cylinder(p0 - 0.5 * radius * d, p1 + 0.5 * radius * d, radius, sections)


def cone(base_centre, radius: float, height: float, sections: int = 16) -> trimesh.Trimesh:
    """Closed upright cone (with its base disc) of ``radius`` and ``height`` [m] on ``base_centre``."""
    m = trimesh.creation.cone(radius=radius, height=height, sections=sections)
    m.apply_translation(base_centre)
    return m


def annulus(r_in: float, r_out: float, width: float, sections: int) -> trimesh.Trimesh:
    """Closed annular solid about the y axis, centred on the origin: radii r_in..r_out, ``width``
    along y [m]."""
    profile = np.array(
        [[r_in, -width / 2], [r_out, -width / 2], [r_out, width / 2], [r_in, width / 2], [r_in, -width / 2]]
    )  # (radius, axial), counter-clockwise: positive volume
    m = trimesh.creation.revolve(profile, sections=sections)  # about z
    m.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))  # z -> y
    return m


def tube_loop(path: np.ndarray, radius: float, sides: int = 8) -> trimesh.Trimesh:
    """Closed round wire of ``radius`` [m] (a ``sides``-gon) around the closed polyline ``path``
    (n, 3) [m]. The polygon's faces look outwards, sideways and every 360 / sides deg between, so
    that a wire seen from the side shows faces tilted up towards the sky, as a round wire does."""
    n = len(path)
    tangent = np.roll(path, -1, axis=0) - np.roll(path, 1, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    centre = path.mean(axis=0)
    out = path - centre
    out -= np.sum(out * tangent, axis=1, keepdims=True) * tangent
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    side = np.cross(tangent, out)
    angles = (np.arange(sides) + 0.5) * 2 * np.pi / sides  # corners between the faces
    corner_r = radius / np.cos(np.pi / sides)  # the faces at ``radius``
    vertices = np.vstack(
        [path[i] + corner_r * (np.cos(a) * out[i] + np.sin(a) * side[i]) for i in range(n) for a in angles]
    )
    faces = []
    for i in range(n):
        j = (i + 1) % n
        for k in range(sides):
            a, b = sides * i + k, sides * i + (k + 1) % sides
            c, d = sides * j + (k + 1) % sides, sides * j + k
            faces += [[a, b, c], [a, c, d]]
    mesh = trimesh.Trimesh(vertices, np.array(faces), process=False)
    if mesh.volume < 0.0:
        mesh.invert()
    return mesh


def ellipsoid(centre, radii, subdivisions: int = 3) -> trimesh.Trimesh:
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    m.apply_scale(radii)
    m.apply_translation(centre)
    return m


def rotation(axis, angle_deg: float) -> np.ndarray:
    return trimesh.transformations.rotation_matrix(np.radians(angle_deg), axis)


# -- ground and buildings ---------------------------------------------------------------------------


def paving_and_grass(gap: float) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """The paved yard, and the grass around it out to the buildings with a notch that holds the
    yard (``gap`` all round); both top faces at z = 0."""
    x0, y0, x1, y1 = PAVING
    paving = box([x0, y0, -GROUND_THICKNESS], [x1, y1, 0.0])
    xs = [-SIDE_X + gap, x0 - gap, x1 + gap, SIDE_X - gap]
    ys = [BACK_Y + gap, y0 - gap, y1 + gap, WALL_Y]
    occupied = np.ones((3, 3, 1), dtype=bool)
    occupied[1, 1, 0] = False
    grass = cell_block(xs, ys, [-GROUND_THICKNESS, 0.0], occupied)
    return paving, grass


def evans_hall(gap: float) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh]]:
    """The brick wall ahead with its window recesses, and the window panes in them."""
    w = WINDOWS
    y0 = WALL_Y + gap
    edges = sorted(
        {-SIDE_X - BUILDING_DEPTH, SIDE_X + BUILDING_DEPTH}
        | {float(c + s * w["width"] / 2) for c in w["xs"] for s in (-1, 1)}
    )
    ys = [y0, y0 + w["recess"], y0 + BUILDING_DEPTH]
    zs = [-GROUND_THICKNESS - 0.2, w["z"][0], w["z"][1], WALL_HEIGHT]
    occupied = np.ones((len(edges) - 1, 2, 3), dtype=bool)
    centres = (np.array(edges[:-1]) + np.array(edges[1:])) / 2
    for i, c in enumerate(centres):
        if np.min(np.abs(c - w["xs"])) < w["width"] / 2:
            occupied[i, 0, 1] = False  # the recess
    wall = cell_block(edges, ys, zs, occupied)
    panes = []
    for c in w["xs"]:
        lo = [c - w["width"] / 2 + gap, y0 + w["pane_depth"], w["z"][0] + gap]
        hi = [c + w["width"] / 2 - gap, y0 + w["pane_depth"] + w["pane"], w["z"][1] - gap]
        panes.append(box(lo, hi))
    return wall, panes


def other_buildings(gap: float) -> dict[str, trimesh.Trimesh]:
    bottom = -GROUND_THICKNESS - 0.2
    return {
        "building_left": box([-SIDE_X - BUILDING_DEPTH, BACK_Y + gap, bottom], [-SIDE_X, WALL_Y - gap, SIDE_HEIGHT]),
        "building_right": box([SIDE_X, BACK_Y + gap, bottom], [SIDE_X + BUILDING_DEPTH, WALL_Y - gap, SIDE_HEIGHT]),
        "building_back": box(
            [-SIDE_X - BUILDING_DEPTH, BACK_Y - BUILDING_DEPTH, bottom], [SIDE_X + BUILDING_DEPTH, BACK_Y, BACK_HEIGHT]
        ),
    }


# -- fence and racks --------------------------------------------------------------------------------


def capped_post(x: float, y: float, radius: float, height: float, cap, gap: float) -> trimesh.Trimesh:
    post = cylinder([x, y, gap], [x, y, height], radius, ROUND_SECTIONS)
    return trimesh.util.concatenate([post, cone([x, y, height], cap[0], cap[1], ROUND_SECTIONS)])


def chain(xa: float, xb: float, y: float) -> trimesh.Trimesh:
    """Links hanging on a parabola from (xa, y, CHAIN_Z) to (xb, y, CHAIN_Z), sagging CHAIN_SAG,
    every other link turned 90 deg about the chain: closed square-wire stadium loops."""
    L = LINK
    xm, half = (xa + xb) / 2, (xb - xa) / 2
    xs = np.linspace(xa, xb, 400)
    zs = CHAIN_Z - CHAIN_SAG * (1.0 - ((xs - xm) / half) ** 2)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(xs), np.diff(zs)))])
    count = int(arc[-1] // L["pitch"])
    start = (arc[-1] - (count - 1) * L["pitch"]) / 2
    # stadium path in the link's own (along, across) plane
    n = L["points"]
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    s, r = L["straight"] / 2, L["radius"]
    along = np.where(np.cos(t) >= 0, s, -s) + r * np.cos(t)
    across = r * np.sin(t)
    links = []
    for k in range(count):
        a = start + k * L["pitch"]
        c = np.array([np.interp(a, arc, xs), y, np.interp(a, arc, zs)])
        i = min(np.searchsorted(arc, a), len(xs) - 1)
        tangent = np.array([xs[i] - xs[i - 1], 0.0, zs[i] - zs[i - 1]])
        tangent /= np.linalg.norm(tangent)
        normal = np.array([0.0, 1.0, 0.0]) if k % 2 else np.cross(tangent, [0.0, 1.0, 0.0])
        path = c + along[:, None] * tangent + across[:, None] * normal
        links.append(tube_loop(path, L["wire"] / 2))
    return trimesh.util.concatenate(links)


def fence(gap: float) -> dict[str, tuple[str, trimesh.Trimesh]]:
    nodes = {}
    for i, x in enumerate(FENCE_XS):
        nodes[f"post_{i}"] = ("posts", capped_post(x, FENCE_Y, POST_RADIUS, POST_HEIGHT, (CAP_RADIUS, CAP_HEIGHT), gap))
    for i in range(len(FENCE_XS) - 1):
        nodes[f"chain_{i}"] = (
            "chain",
            chain(FENCE_XS[i] + POST_RADIUS * 0.5, FENCE_XS[i + 1] - POST_RADIUS * 0.5, FENCE_Y),
        )
    return nodes


def racks(gap: float) -> dict[str, tuple[str, trimesh.Trimesh]]:
    nodes = {}
    for i, ((x0, y0), (x1, y1)) in enumerate(RACKS):
        parts = [capped_post(x, y, RACK_POST_RADIUS, RACK_HEIGHT, RACK_CAP, gap) for x, y in ((x0, y0), (x1, y1))]
        parts.append(cylinder([x0, y0, RACK_RAIL_Z], [x1, y1, RACK_RAIL_Z], RACK_RAIL_RADIUS, ROUND_SECTIONS))
        nodes[f"rack_{i}"] = ("posts", trimesh.util.concatenate(parts))
    return nodes


def u_lock(x: float, y: float) -> trimesh.Trimesh:
    """A U-lock hanging on a rail along y at (x, RACK_RAIL_Z): the shackle's bend around the
    rail, its legs down to the crossbar, all in the plane y = const (the crossbar along x)."""
    r_bend, r_wire, leg = 0.055, 0.008, 0.20
    zc = RACK_RAIL_Z
    parts = []
    angles = np.linspace(0.0, np.pi, 9)
    pts = [np.array([x + r_bend * np.cos(a), y, zc + r_bend * np.sin(a)]) for a in angles]
    for p0, p1 in itertools.pairwise(pts):
        parts.append(tube(p0, p1, r_wire, 16))
    for s in (-1.0, 1.0):
        parts.append(tube([x + s * r_bend, y, zc], [x + s * r_bend, y, zc - leg], r_wire, 16))
    parts.append(cylinder([x - r_bend - 0.03, y, zc - leg], [x + r_bend + 0.03, y, zc - leg], 0.016, 24))
    return trimesh.util.concatenate(parts)


# -- bicycles ---------------------------------------------------------------------------------------


def wheel(gap: float) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """(tire, rim and hub) about the origin, axle along y."""
    major = WHEEL_RADIUS - TIRE_SECTION
    tire = trimesh.creation.torus(major, TIRE_SECTION, major_sections=48, minor_sections=10)
    tire.apply_transform(rotation([1, 0, 0], 90.0))  # its axis from z to y
    if (major - TIRE_SECTION) - RIM[1] < gap:
        raise ValueError("rim too close to the tire")
    rim = annulus(RIM[0], RIM[1], RIM[2], 48)
    hub = cylinder([0.0, -0.05, 0.0], [0.0, 0.05, 0.0], 0.02, 12)
    return tire, trimesh.util.concatenate([rim, hub])


def bicycle(gap: float, steer_deg: float = 0.0) -> dict[str, tuple[str, trimesh.Trimesh]]:
    """One bicycle in its own frame (see BIKE_POINTS); names are suffixes of its node names."""
    P = {k: np.array(v) for k, v in BIKE_POINTS.items()}
    rear, front = P["rear_hub"], P["front_hub"]
    stay = np.array([0.0, 0.065, 0.0])  # stays and fork legs pass either side of the wheels
    wishbone = np.array([0.0, 0.02, 0.0])
    tubes = [
        (P["bb"], P["seat"]),
        (P["seat"], P["head_top"]),
        (P["bb"], P["head_bottom"]),
        (P["head_bottom"], P["head_top"]),
        (P["seat"], P["seat_post"]),
        (P["head_top"], P["stem"]),
    ]
    for s in (-1.0, 1.0):
        tubes += [
            (P["bb"] + s * stay * 0.5, rear + s * stay),
            (P["seat"] + s * wishbone, rear + s * stay),
            (P["head_bottom"] + s * stay, front + s * stay),
        ]
    tubes.append((P["head_bottom"] - stay, P["head_bottom"] + stay))  # the fork crown
    frame = [tube(a, b, TUBE_RADIUS * (0.7 if (a[1] or b[1]) else 1.0)) for a, b in tubes]
    bar = P["stem"] + [0.0, 0.0, 0.0]
    frame.append(cylinder(bar + [0.0, -0.20, 0.0], bar + [0.0, 0.20, 0.0], 0.012, 24))
    frame.append(cylinder(P["bb"] + [0.0, -0.09, 0.0], P["bb"] + [0.0, 0.09, 0.0], 0.018))  # bottom bracket axle
    gear = trimesh.creation.cylinder(radius=0.10, height=0.004, sections=24)
    gear.apply_transform(rotation([1, 0, 0], 90.0))
    gear.apply_translation(P["bb"] + [0.0, -0.075, 0.0])  # the drive side: the bicycle's right
    frame.append(gear)
    pedals = []
    for s, angle in ((-1.0, 20.0), (1.0, 200.0)):
        a = np.radians(angle)
        end = P["bb"] + [0.17 * np.cos(a), s * 0.095, 0.17 * np.sin(a)]
        frame.append(tube(P["bb"] + [0.0, s * 0.095, 0.0], end, 0.01, 8))
        pedals.append(
            box(
                end + [-0.045, s * 0.01 + (0.0 if s > 0 else -0.08), -0.012],
                end + [0.045, s * 0.01 + (0.08 if s > 0 else 0.0), 0.012],
            )
        )
    saddle = box(P["seat_post"] + [-0.16, -0.07, gap], P["seat_post"] + [0.10, 0.07, 0.05])
    grips = [cylinder(bar + [0.0, s * (0.20 + gap), 0.0], bar + [0.0, s * 0.32, 0.0], 0.016, 24) for s in (-1.0, 1.0)]
    tire_r, metal_r = wheel(gap)
    tire_f, metal_f = wheel(gap)
    for m in (tire_r, metal_r):
        m.apply_translation(rear + [0.0, 0.0, gap])
    steer = rotation([0, 0, 1], steer_deg)
    for m in (tire_f, metal_f):
        m.apply_transform(steer)
        m.apply_translation(front + [0.0, 0.0, gap])
    return {
        "frame": ("frame", trimesh.util.concatenate(frame)),
        "wheel_rear": ("frame", metal_r),
        "wheel_front": ("frame", metal_f),
        "tire_rear": ("tires", tire_r),
        "tire_front": ("tires", tire_f),
        "saddle": ("plastics", saddle),
        "grip_left": ("plastics", grips[1]),
        "grip_right": ("plastics", grips[0]),
        "pedal_left": ("plastics", pedals[1]),
        "pedal_right": ("plastics", pedals[0]),
    }


def bike_transform(x: float, y: float, yaw_deg: float, lean_deg: float) -> np.ndarray:
    """The bicycle's frame -> world: lean (top away from the imager, about its forward axis, the
    tire contact line fixed), then yaw, then the rear hub's ground point to (x, y)."""
    away = -1.0 if np.cos(np.radians(yaw_deg)) >= 0.0 else 1.0  # its left (+Y) is away when it faces +x
    return (
        trimesh.transformations.translation_matrix([x, y, 0.0])
        @ rotation([0, 0, 1], yaw_deg)
        @ rotation([1, 0, 0], away * lean_deg)
    )


# -- the tree ---------------------------------------------------------------------------------------


def tree(gap: float) -> trimesh.Trimesh:
    """Trunk and canopy as two closed meshes (one material); the trunk stops below the canopy."""
    x, y, r, top = TRUNK
    (cx, cy, cz), radii = CANOPY
    if top >= cz - radii[2] - gap:
        raise ValueError("the trunk reaches into the canopy")
    trunk = cylinder([x, y, gap], [x, y, top], r, 16)
    return trimesh.util.concatenate([trunk, ellipsoid((cx, cy, cz), radii)])


# -- the scene --------------------------------------------------------------------------------------


def build(args) -> dict[str, tuple[str, trimesh.Trimesh]]:
    """Node name -> (material name, mesh), Z-up, everything but the tree."""
    gap = args.gap
    paving, grass = paving_and_grass(gap)
    wall, panes = evans_hall(gap)
    nodes = {"paving": ("bricks", paving), "grass": ("grass", grass), "evans_hall": ("bricks", wall)}
    nodes.update({f"window_{i}": ("windows", p) for i, p in enumerate(panes)})
    nodes.update({n: ("bricks", m) for n, m in other_buildings(gap).items()})
    nodes.update(fence(gap))
    nodes.update(racks(gap))
    for label, (x, y, yaw, lean, steer) in (("near_bike", NEAR_BIKE), ("far_bike", FAR_BIKE)):
        parts = bicycle(gap, steer)
        for _, mesh in parts.values():
            mesh.apply_transform(bike_transform(x, y, yaw, lean))
        lowest = min(m.bounds[0][2] for _, m in parts.values())  # a leaning tire's edge dips: stand it on gap
        for part, (material, mesh) in parts.items():
            mesh.apply_translation([0.0, 0.0, gap - lowest])
            nodes[f"{label}_{part}"] = (material, mesh)
    nodes["lock"] = ("lock", u_lock(*LOCK_AT))
    omitted = [n for n in nodes if any(n.startswith(p) for p in args.omit)]
    for n in omitted:
        del nodes[n]
    return nodes


def check_gaps(nodes, gap: float) -> None:
    """No dielectric part reaches into another part or below the ground (sampled: vertices and
    face centres inside another closed mesh), and nothing but the ground pieces and buildings
    reaches below z = gap."""
    ground = {"paving", "grass", "evans_hall", "building_left", "building_right", "building_back"}
    for name, (material, mesh) in nodes.items():
        if name not in ground and mesh.bounds[0][2] < gap * 0.999:
            raise ValueError(f"{name} reaches below z = {gap} m")
    dielectric = [n for n, (mat, _) in nodes.items() if mat in ("tires", "plastics", "windows") or n == "tree"]
    for name in dielectric:
        mesh = nodes[name][1]
        pts = np.vstack([mesh.vertices, mesh.triangles_center])
        for other, (_, m2) in nodes.items():
            if other == name or other in ground:
                continue
            lo, hi = m2.bounds
            near = pts[(pts >= lo - gap).all(axis=1) & (pts <= hi + gap).all(axis=1)]
            if not len(near):
                continue
            for body in m2.split(only_watertight=False):  # metal parts overlap: test each closed body
                if body.contains(near).any():
                    raise ValueError(f"{name} reaches into {other}")


def main(argv=None) -> None:
    here = Path(__file__).resolve().parent
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out-dir", type=Path, default=here, help="writes bikeracks.glb and bikeracks_tree.glb there")
    p.add_argument(
        "--omit",
        nargs="*",
        default=[],
        metavar="PREFIX",
        help="leave out the nodes whose names start so (lock, near_bike, far_bike_tire, post_3, chain_, ...)",
    )
    p.add_argument("--no-tree", action="store_true", help="do not write bikeracks_tree.glb")
    p.add_argument("--gap", type=float, default=0.001, help="clearance of every dielectric part [m]")
    args = p.parse_args(argv)

    nodes = build(args)
    check_gaps(nodes, args.gap)
    out = args.out_dir / "bikeracks.glb"
    export_glb(nodes, out)
    check_glb(nodes, out)
    n_tri = sum(len(m.faces) for _, m in nodes.values())
    print(f"wrote {out} ({n_tri} triangles, {len(nodes)} nodes)")
    if not args.no_tree:
        tree_nodes = {"tree": ("tree", tree(args.gap))}
        tree_out = args.out_dir / "bikeracks_tree.glb"
        export_glb(tree_nodes, tree_out)
        check_glb(tree_nodes, tree_out)
        print(f"wrote {tree_out} ({len(tree_nodes['tree'][1].faces)} triangles)")
    print(
        f"suggested imager: position [0, 0, {IMAGER_HEIGHT}], look_at [0, 8, 0.1], up [0, 0, 1], "
        "fov 50 deg, resolution [250, 140]"
    )


if __name__ == "__main__":
    main()
