"""Write scenes/truck/truck.glb: a pickup truck in the desert (Murakowski 2014, sec. 2.3.3).

The second validation scene of Murakowski 2014 (sec. 2.3.3, Fig. 2.8, Table 2.2): a pickup truck
on open, flat sand, seen at 35 GHz by the scanning cart's imager focused at 7 m. The thesis's
truck came from a public 3D model; its figures are not at hand, so this one is built from the text:
a compact pickup, 5.0 m long, 1.80 m wide, 1.72 m high, with

* a **metal body** (Table 2.2 'Truck Body': metal): bumpers, a hood sloping 6 deg down towards
  the front, a cab whose A-pillars lean back 35 deg, a bed 0.38 m deep, and wheel wells whose
  housings stand into the bed;
* **open windows** (Table 2.2 lists no glass): windshield, side and rear window openings into a
  cab cavity lined with **leather** (Table 2.2 'Interior': a bench seat, the dash, door trims, a
  floor mat and the back wall's trim);
* four wheels: **SA-9 rubber tires** (Table 2.2 'Tires', 0.36 m radius, 0.25 m wide) on metal
  rims dished 9 cm into the tire, 13 cm below the wheel-well tops;
* an **under-body** of metal: frame rails, axle housings with the differential, the engine sump
  and transmission, the driveshaft, the fuel tank and the exhaust; the body floor is 0.45 m above
  the sand, the lowest parts 0.19 m. What enters the gap between that metal and the sand is
  bounced between them until the sand has absorbed it: the warm cavity of sec. 2.3.3 ("a bright
  cavity where rays are trapped in the underside of the truck").

The ground is a thin sand box whose top face is z = 0 (Table 2.2 'Ground'; the scenario gives it
the cinderblock scene's bump map, as the thesis did). The truck stands ``--distance`` from an
imager at the origin (its centre on the line of sight through ``--centre-x``), its front turned
``--heading`` deg from the image plane towards the imager's left: a front three-quarter view of the
hood, the driver's side, both wheel wells, the windshield and side window openings, and the
truck's reflection in the sand below it.

The body is one closed metal mesh of grid cells (boxes added and carved on a rectilinear grid, so
every face lies on the grid and the mesh is watertight by construction), then bent smoothly: the
windshield's lean and the hood's slope move vertices, not cells, so nothing opens. Metal parts of
the under-body and the rims interpenetrate the body where they join (a perfect conductor has no
inside for the tracer to track); every dielectric part (tires, leather) is a separate closed mesh
at least ``--gap`` from every other part. Mesh material names: ``ground``, ``body`` (metal),
``tires``, ``interior``.

The scene is built Z-up (pmmw's world frame) and rotated into glTF's Y-up on export; pmmw turns it
back on load. Run from anywhere:

    python scenes/truck/make_scene.py [--out-dir DIR | --out PATH] [--distance 8.2] [--heading 35] ...
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh

from pmmw.scene.export import check_glb, export_glb
from pmmw.scene.shapes import box, cell_block

IMAGER_HEIGHT = 1.5  # [m], the thesis's cart-mounted dish

# Truck frame (u, v, w) [m]: u along the truck from the rear bumper (0) to the front bumper (5.0),
# v across (+v the driver's side), w up from the ground.
LENGTH, HALF_WIDTH, HEIGHT = 5.0, 0.90, 1.72
AXLES = (1.05, 4.05)  # rear and front axle stations [m] (wheelbase 3.0 m)
TIRE_RADIUS, TIRE_INNER, TIRE_WIDTH = 0.36, 0.225, 0.25
TIRE_V = (0.61, 0.86)  # |v| of the tire's inner and outer faces; the body side is at 0.90
RIM_DISH = 0.09  # [m] the rim's face lies this far inside the tire's outer face: a dished wheel
WELL = (0.46, 0.56, 0.86)  # half length along u, inner |v|, top w of each wheel well
WINDSHIELD_LEAN_DEG = 35.0  # from the vertical
HOOD_DROP = 0.15  # [m] over the hood's 1.4 m: a 6.1 deg slope towards the front

# The body as boxes (u0, v0, w0, u1, v1, w1) added (+1) and carved (-1) in order on one grid.
BODY_OPS = [
    (+1, (0.10, -0.90, 0.45, 4.90, 0.90, 1.00)),  # lower body: bed, doors, engine bay (solid), beltline 1.0 m
    (-1, (0.16, -0.84, 0.62, 1.90, 0.84, 1.10)),  # the bed, floor at 0.62 m, open at the top
    (+1, (1.95, -0.90, 0.45, 3.50, 0.90, HEIGHT)),  # cab
    (-1, (2.01, -0.84, 0.51, 3.44, 0.84, 1.66)),  # cab cavity, 6 cm walls
    (-1, (2.15, 0.83, 1.06, 3.30, 0.91, 1.60)),  # side window openings (no glass: Table 2.2 has none)
    (-1, (2.15, -0.91, 1.06, 3.30, -0.83, 1.60)),
    (-1, (3.43, -0.78, 1.06, 3.51, 0.78, 1.64)),  # windshield opening
    (-1, (1.94, -0.60, 1.12, 2.02, 0.60, 1.52)),  # rear window opening
    (+1, (-0.02, -0.93, 0.35, 0.12, 0.93, 0.58)),  # rear bumper
    (+1, (4.88, -0.93, 0.33, 5.02, 0.93, 0.58)),  # front bumper
]
for _ua in AXLES:
    BODY_OPS += [
        (+1, (_ua - WELL[0] - 0.06, WELL[1] - 0.06, 0.62, _ua + WELL[0] + 0.06, 0.84, WELL[2] + 0.06)),  # housings
        (+1, (_ua - WELL[0] - 0.06, -0.84, 0.62, _ua + WELL[0] + 0.06, -WELL[1] + 0.06, WELL[2] + 0.06)),
        (-1, (_ua - WELL[0], WELL[1], 0.44, _ua + WELL[0], 0.91, WELL[2])),  # the wells
        (-1, (_ua - WELL[0], -0.91, 0.44, _ua + WELL[0], -WELL[1], WELL[2])),
    ]

# Leather interior (Table 2.2 'Interior'): boxes (u0, v0, w0, u1, v1, w1), each >= 2 mm inside the
# cab cavity (u 2.01-3.44, |v| < 0.84, w 0.51-1.66) and clear of the other boxes.
INTERIOR_BOXES = {
    "floor": (2.03, -0.82, 0.52, 3.42, 0.82, 0.54),
    "seat": (2.32, -0.80, 0.56, 2.95, 0.80, 0.80),
    "backrest": (2.06, -0.80, 0.56, 2.28, 0.80, 1.45),
    "dash": (3.15, -0.80, 0.56, 3.42, 0.80, 0.98),
    "back_trim": (2.03, -0.82, 1.47, 2.05, 0.82, 1.64),
    "door_left": (2.32, 0.80, 0.82, 3.12, 0.838, 1.00),
    "door_right": (2.32, -0.838, 0.82, 3.12, -0.80, 1.00),
}

# Metal under-body (may interpenetrate the body and each other): boxes and cylinders.
UNDERBODY_BOXES = [
    (0.25, 0.38, 0.26, 4.75, 0.48, 0.46),  # frame rails
    (0.25, -0.48, 0.26, 4.75, -0.38, 0.46),
    (3.85, -0.55, 0.26, 4.25, 0.55, 0.46),  # front crossmember and suspension
    (3.00, -0.25, 0.28, 3.90, 0.25, 0.46),  # engine sump and transmission
    (1.70, 0.48, 0.28, 2.45, 0.80, 0.46),  # fuel tank
]
UNDERBODY_CYLINDERS = [  # (p0, p1, radius) in (u, v, w)
    ((AXLES[0], -0.62, 0.361), (AXLES[0], 0.62, 0.361), 0.05),  # rear axle housing
    ((AXLES[1], -0.62, 0.361), (AXLES[1], 0.62, 0.361), 0.04),  # front axle
    ((1.15, 0.0, 0.33), (3.00, 0.0, 0.33), 0.04),  # driveshaft
    ((0.20, -0.30, 0.30), (3.60, -0.30, 0.30), 0.035),  # exhaust
]
DIFFERENTIAL = ((AXLES[0], 0.0, 0.33), 0.14)  # centre, radius: the lowest part, 0.19 m up

# Points of the truck frame (u, v, w) that configs/truck_35ghz.yaml's regions look at; the script
# prints them in the world. A negative w is the point's mirror image in the ground: its region is
# the point's reflection in the sand.
REGION_POINTS = {
    "hood": (4.2, 0.0, 1.0 - HOOD_DROP * 0.5),  # the hood's middle
    "door": (2.7, HALF_WIDTH, 0.75),  # the driver's door
    "cab": (2.7, HALF_WIDTH, 1.33),  # through the side window
    "front_well": (AXLES[1], HALF_WIDTH, 0.43),
    "rear_well": (AXLES[0], HALF_WIDTH, 0.43),  # the wells' openings
    "under": (2.55, HALF_WIDTH, 0.22),
    "under_reflection": (2.55, HALF_WIDTH, -0.22),  # the gap under the body
    "door_reflection": (2.7, HALF_WIDTH, -0.75),
}


# -- mesh helpers -----------------------------------------------------------------------------------


def boxes_on_grid(ops) -> trimesh.Trimesh:
    """The closed mesh of boxes added (+1) and carved (-1) in order, on the grid of all their
    faces: ``ops`` is a sequence of (sign, (x0, y0, z0, x1, y1, z1))."""
    lines = [sorted({b[a] for _, b in ops} | {b[a + 3] for _, b in ops}) for a in range(3)]
    centres = [(np.array(g[:-1]) + np.array(g[1:])) / 2 for g in lines]
    cu, cv, cw = np.meshgrid(*centres, indexing="ij")
    occupied = np.zeros(cu.shape, dtype=bool)
    for sign, (x0, y0, z0, x1, y1, z1) in ops:
        inside = (cu > x0) & (cu < x1) & (cv > y0) & (cv < y1) & (cw > z0) & (cw < z1)
        occupied = (occupied | inside) if sign > 0 else (occupied & ~inside)
    return cell_block(*lines, occupied)


def cylinder(p0, p1, radius: float, sections: int = 16) -> trimesh.Trimesh:
    """Closed cylinder of ``radius`` [m] from p0 to p1."""
    return trimesh.creation.cylinder(radius=radius, segment=[p0, p1], sections=sections)


def ring_solid(r_in: float, r_out: float, v0: float, v1: float, chamfer: float, sections: int) -> trimesh.Trimesh:
    """Closed annular solid about the v axis (the w-v plane of the truck frame turned to it):
    radii r_in..r_out [m], from v0 to v1, its outer corners chamfered (a tire's cross-section)."""
    c = chamfer
    profile = np.array(
        [[r_in, v0], [r_out - c, v0], [r_out, v0 + c], [r_out, v1 - c], [r_out - c, v1], [r_in, v1], [r_in, v0]]
    )  # (radius, axial), counter-clockwise: positive volume
    m = trimesh.creation.revolve(profile, sections=sections)  # about z
    m.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))  # z -> +y (v)
    return m


# -- the truck --------------------------------------------------------------------------------------


def bend(vertices: np.ndarray) -> np.ndarray:
    """The body's smooth bends, vertex by vertex (u, v, w) -> (u', v, w'): the cab leans back above
    the beltline, more towards the windshield (A-pillars at WINDSHIELD_LEAN_DEG), and the hood drops
    towards the bumper. Both are monotone along each grid axis, so no face folds over."""
    u, v, w = vertices.T.copy()
    front = np.clip((u - 2.6) / 0.9, 0.0, 1.0)  # 0 behind the doors' middle, 1 at the windshield
    u_new = u - np.tan(np.radians(WINDSHIELD_LEAN_DEG)) * np.clip(w - 1.0, 0.0, None) * front
    hood = np.clip((u - 3.5) / 1.4, 0.0, 1.0) * np.clip((w - 0.45) / 0.55, 0.0, 1.0)
    w_new = w - HOOD_DROP * hood
    return np.column_stack([u_new, v, w_new])


def truck_parts(gap: float) -> dict[str, tuple[str, trimesh.Trimesh]]:
    """Node name -> (material, mesh) in the truck frame (u, v, w)."""
    body = boxes_on_grid(BODY_OPS)
    body.vertices = bend(body.vertices)
    parts = {"body": ("body", body)}
    for i, b in enumerate(UNDERBODY_BOXES):
        parts[f"underbody_{i}"] = ("body", box(b[:3], b[3:]))
    for i, (p0, p1, r) in enumerate(UNDERBODY_CYLINDERS):
        parts[f"underbody_{len(UNDERBODY_BOXES) + i}"] = ("body", cylinder(p0, p1, r))
    diff = trimesh.creation.icosphere(subdivisions=2, radius=DIFFERENTIAL[1])
    diff.apply_translation(DIFFERENTIAL[0])
    parts["differential"] = ("body", diff)
    for name, b in INTERIOR_BOXES.items():
        parts[f"interior_{name}"] = ("interior", box(b[:3], b[3:]))
    axle_w = TIRE_RADIUS + gap  # the tires stand gap above the sand
    for label, ua in (("rear", AXLES[0]), ("front", AXLES[1])):
        for side, s in (("left", 1.0), ("right", -1.0)):
            v0, v1 = sorted((s * TIRE_V[0], s * TIRE_V[1]))
            tire = ring_solid(TIRE_INNER, TIRE_RADIUS, v0, v1, 0.03, 32)
            tire.apply_translation([ua, 0.0, axle_w])
            parts[f"tire_{label}_{side}"] = ("tires", tire)
            rim_v = sorted((s * (TIRE_V[0] + 0.02), s * (TIRE_V[1] - RIM_DISH)))
            rim = cylinder([ua, rim_v[0], axle_w], [ua, rim_v[1], axle_w], _rim_radius(gap), 32)
            hub = cylinder([ua, s * 0.3, axle_w], [ua, s * (TIRE_V[0] + 0.05), axle_w], 0.06)
            parts[f"wheel_{label}_{side}"] = ("body", trimesh.util.concatenate([rim, hub]))
    return parts


def place(mesh: trimesh.Trimesh, centre_xy, heading_deg: float) -> trimesh.Trimesh:
    """The truck frame -> world: the truck's middle (u = LENGTH / 2, v = 0) at ``centre_xy``, its
    front pointing ``heading_deg`` from -x towards -y (towards the imager at the origin, seen
    from there on its left), the driver's side (+v) facing the imager."""
    m = mesh.copy()
    m.apply_translation([-LENGTH / 2, 0.0, 0.0])
    # +u -> (-cos h, -sin h, 0); +v -> (sin h, -cos h, 0): a rotation about z by 180 + h deg.
    m.apply_transform(trimesh.transformations.rotation_matrix(np.radians(180.0 + heading_deg), [0, 0, 1]))
    m.apply_translation([centre_xy[0], centre_xy[1], 0.0])
    return m


def to_world(point_uvw, centre_xy, heading_deg: float) -> np.ndarray:
    """A point of the truck frame in the world, as `place` moves the meshes."""
    h = np.radians(heading_deg)
    u, v, w = np.asarray(point_uvw, float) - [LENGTH / 2, 0.0, 0.0]
    return np.array([centre_xy[0] - u * np.cos(h) + v * np.sin(h), centre_xy[1] - u * np.sin(h) - v * np.cos(h), w])


def _box_gap(a, b) -> float:
    """Distance [m] between two axis-aligned boxes (x0, y0, z0, x1, y1, z1); 0 if they overlap."""
    d = [max(a[i] - b[i + 3], b[i] - a[i + 3], 0.0) for i in range(3)]
    return float(np.sqrt(np.sum(np.square(d))))


def check_clearances(gap: float) -> float:
    """The gaps of the dielectric parts, from the dimensions (every part here is a box or a solid
    of revolution, so they are exact): each leather box inside the cab cavity and apart from the
    others, the tires below the wheel-well tops (bent hood included) and apart from the rims,
    the under-body and the sand. Returns the smallest [m]; raises ValueError below ``gap``."""
    cavity = next(b for s, b in BODY_OPS if s < 0 and b[0] == 2.01)
    gaps = {}
    for name, b in INTERIOR_BOXES.items():
        gaps[f"interior_{name}-cab"] = min(min(b[i] - cavity[i], cavity[i + 3] - b[i + 3]) for i in range(3))
        # the cab cavity's faces near the leather do not move in `bend`: it acts above w = 1 ahead of u = 2.6
        # and ahead of u = 3.5
        if (b[5] > 1.0 and b[3] > 2.6) or b[3] > 3.5:
            raise ValueError(f"interior_{name} reaches where the body is bent")
    names = list(INTERIOR_BOXES)
    for i, n1 in enumerate(names):
        for n2 in names[i + 1 :]:
            gaps[f"interior_{n1}-interior_{n2}"] = _box_gap(INTERIOR_BOXES[n1], INTERIOR_BOXES[n2])
    tire_top = 2 * TIRE_RADIUS + gap
    for ua in AXLES:
        edge = np.array([[ua + s * WELL[0], WELL[1], WELL[2]] for s in (-1.0, 1.0)])
        gaps[f"tire-well_top@{ua}"] = float(bend(edge)[:, 2].min()) - tire_top  # the well top is linear between
        gaps[f"tire-well_side@{ua}"] = WELL[0] - TIRE_RADIUS
    gaps["tire-well_inner"] = TIRE_V[0] - WELL[1]
    gaps["tire-rim"] = TIRE_INNER * np.cos(np.pi / 32) - _rim_radius(gap)
    for b in UNDERBODY_BOXES:  # each tire's bounding box against the under-body boxes, both sides
        for ua in AXLES:
            tb = (ua - TIRE_RADIUS, TIRE_V[0], gap, ua + TIRE_RADIUS, TIRE_V[1], tire_top)
            for mirrored in (b, (b[0], -b[4], b[2], b[3], -b[1], b[5])):
                gaps[f"tire-underbody@{ua}"] = min(gaps.get(f"tire-underbody@{ua}", np.inf), _box_gap(tb, mirrored))
    gaps["tire-axle"] = TIRE_INNER * np.cos(np.pi / 32) - max(r for _, _, r in UNDERBODY_CYLINDERS[:2])
    gaps["tire-ground"] = gap
    worst = min(gaps, key=gaps.get)
    if gaps[worst] < gap * (1 - 1e-9):
        raise ValueError(f"{worst}: {gaps[worst] * 1e3:.2f} mm, less than the {gap * 1e3:g} mm gap")
    return float(gaps[worst])


def _rim_radius(gap: float) -> float:
    """The rim's polygon (32 sides) stays ``gap`` inside the tire's inner polygon at any phase."""
    return TIRE_INNER * np.cos(np.pi / 32) - gap


def ground(size: float, thickness: float, cx: float, cy: float) -> trimesh.Trimesh:
    g = trimesh.creation.box(extents=[size, size, thickness])
    g.apply_translation([cx, cy, -thickness / 2])
    return g


def truck_centre(args) -> tuple[float, float]:
    return float(args.centre_x), float(np.sqrt(args.distance**2 - args.centre_x**2))


def build(args) -> dict[str, tuple[str, trimesh.Trimesh]]:
    """Node name -> (material name, mesh), Z-up world frame."""
    parts = truck_parts(args.gap)
    args.clearance = check_clearances(args.gap)
    centre = truck_centre(args)
    nodes = {"ground": ("ground", ground(args.ground_size, args.ground_thickness, *args.ground_center))}
    for name, (material, mesh) in parts.items():
        nodes[name] = (material, place(mesh, centre, args.heading))
    return nodes


def main(argv=None) -> None:
    here = Path(__file__).resolve().parent
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out-dir", type=Path, default=here, help="writes truck.glb there")
    p.add_argument("--out", type=Path, help="output file (default: OUT_DIR/truck.glb)")
    p.add_argument("--distance", type=float, default=8.2, help="imager to the truck's middle, on the ground [m]")
    p.add_argument("--centre-x", type=float, default=0.4, help="x of the truck's middle [m]")
    p.add_argument(
        "--heading",
        type=float,
        default=35.0,
        help="the front's angle from the image plane towards the imager [deg]; 0: broadside, front left",
    )
    p.add_argument("--ground-size", type=float, default=100.0, help="ground square side [m]")
    p.add_argument("--ground-thickness", type=float, default=0.5, help="[m]; the top face is z = 0")
    p.add_argument("--ground-center", type=float, nargs=2, default=(0.0, 20.0), metavar=("X", "Y"))
    p.add_argument("--gap", type=float, default=0.001, help="clearance of every dielectric part [m]")
    args = p.parse_args(argv)

    out = args.out or args.out_dir / "truck.glb"
    nodes = build(args)
    export_glb(nodes, out)
    check_glb(nodes, out)

    n_tri = sum(len(m.faces) for _, m in nodes.values())
    print(f"wrote {out} ({n_tri} triangles, {len(nodes)} nodes)")
    centre = truck_centre(args)
    for label, uvw in REGION_POINTS.items():  # the scenario's output.regions
        x, y, z = to_world(uvw, centre, args.heading)
        print(f"  {label}: [{x:.3f}, {y:.3f}, {z:.3f}]")
    look_z = IMAGER_HEIGHT - args.distance * np.tan(np.radians(9.7))  # the view centred 9.7 deg below level
    print(
        f"suggested imager: position [0, 0, {IMAGER_HEIGHT}], look_at [0.0, {args.distance:.1f}, {look_z:.1f}], "
        "up [0, 0, 1], fov 50 deg, resolution [250, 140]"
    )


if __name__ == "__main__":
    main()
