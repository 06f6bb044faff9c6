"""Write scenes/landing/landing_{plate,brackets}.glb: a runway with passive beacons (Murakowski 2014 sec. 3.1).

A small aircraft makes its final approach on a 4 deg glide slope to a 20 m x 600 m asphalt runway
in moist-soil ground. Passive mmW beacons stand every 50 m along both sides of the runway and every
5 m across both ends. A beacon is a metal mirror at 45 deg that reflects the coldest sky, the
zenith, towards the approaching aircraft (Murakowski 2014 fig. 3.1):

* ``plate``: one 1 m x 1 m metal plate tilted 45 deg about the x axis, facing -y and up;
* ``brackets``: ten low angle brackets (90 deg angle iron, legs 10 cm, each leg at 45 deg, ridge
  up, 1 m long) in a row along the approach, 1 m apart. Each bracket's front leg is a 1 m x 10 cm
  mirror at 45 deg; ten of them show the aircraft the same projected area as the 1 m plate, and
  the 1 m gaps keep each front leg out of the shadow of the bracket before it at the 4 deg glide
  angle (a 7.1 cm ridge shadows 7.1 cm / tan 4 deg = 1.01 m).

Frame: Z up, metres. The runway runs along +y from the threshold y = 0 to y = 600, centred on
x = 0; the aircraft approaches from -y. The runway is a closed asphalt slab (top z = 0.02) set into
a notch of the ground box (top z = 0) with a gap on every side, so no two surfaces coincide. The
ground is a 20 km square on a graded grid (small faces near the runway keep the tracer's float32
ray offsets small there). Every mesh is closed and outward-oriented; beacons are closed thin metal
boxes. Mesh material names: ``runway``, ``ground``, ``beacon``.

The scene is built Z-up and rotated into glTF's Y-up on export; pmmw turns it back on load.

    python scenes/landing/make_scene.py [--style plate|brackets|all] [--out-dir DIR] [--tilt 45] ...
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh

from pmmw.scene.export import check_glb, export_glb
from pmmw.scene.shapes import box, cell_block

STYLES = ("plate", "brackets")
MATERIALS = {"runway", "ground", "beacon"}

# Murakowski 2014 sec. 3.1.1: 10 deg field of view, 500 x 500 pixels, 0.6 m aperture, 4 K noise.
IMAGER_FOV_DEG = 10.0
IMAGER_RESOLUTION = (500, 500)

# Ground grid lines beyond the notch [m]: faces grow with the distance from the runway.
GROUND_STEPS = (30.0, 100.0, 300.0, 1000.0, 3000.0)


# -- meshes -------------------------------------------------------------------------------------


def extrude_x(profile, caps, x0: float, x1: float) -> trimesh.Trimesh:
    """Closed prism of a simple polygon in the (y, z) plane, from x = x0 to x = x1.

    Parameters
    ----------
    profile : ndarray, shape (n, 2)
        Polygon vertices (y, z) [m], counter-clockwise seen from +x.
    caps : ndarray, shape (n - 2, 3), int
        A triangulation of the polygon, counter-clockwise seen from +x.
    """
    p = np.asarray(profile, float)
    n = len(p)
    vertices = np.vstack([np.column_stack([np.full(n, x0), p]), np.column_stack([np.full(n, x1), p])])
    caps = np.asarray(caps)
    faces = [caps[:, ::-1], caps + n]  # the x0 cap faces -x, the x1 cap +x
    for a in range(n):
        b = (a + 1) % n
        faces.append(np.array([[a, b + n, a + n], [a, b, b + n]]))  # outward for a CCW profile
    return trimesh.Trimesh(vertices, np.concatenate(faces), process=False)


def ground_mesh(args) -> trimesh.Trimesh:
    """The ground box (top z = 0) with a notch that holds the runway slab, gap all round."""
    half_w, g = args.runway_width / 2, args.gap
    notch_x = (-half_w - g, half_w + g)
    notch_y = (-g, args.runway_length + g)
    half = args.ground_size / 2
    xs = sorted({-half, *(-half_w - s for s in GROUND_STEPS), *notch_x, *(half_w + s for s in GROUND_STEPS), half})
    ys = sorted({-half, *(-s for s in GROUND_STEPS), *notch_y, *(args.runway_length + s for s in GROUND_STEPS), half})
    xs = [x for x in xs if -half <= x <= half]
    ys = [y for y in ys if -half <= y <= half]
    zs = [-args.ground_thickness, -args.runway_depth - g, 0.0]
    occ = np.ones((len(xs) - 1, len(ys) - 1, 2), dtype=bool)
    occ[xs.index(notch_x[0]), ys.index(notch_y[0]), 1] = False
    return cell_block(xs, ys, zs, occ)


def plate(args) -> trimesh.Trimesh:
    """A beacon plate (thin metal box) tilted about x, front face normal (0, -sin, cos)."""
    s, t = args.beacon_size, args.plate_thickness
    m = box([-s / 2, -s / 2, -t / 2], [s / 2, s / 2, t / 2])
    m.apply_transform(trimesh.transformations.rotation_matrix(np.radians(args.tilt), [1, 0, 0]))
    return m


def bracket(args) -> trimesh.Trimesh:
    """One angle bracket lying ridge up: a chevron of two legs at +-tilt, extruded along x.

    Front foot at y = 0, feet on z = 0; the front leg faces -y and up at the tilt angle.
    """
    th, leg, t = np.radians(args.tilt), args.bracket_leg, args.bracket_thickness
    c, s = leg * np.cos(th), leg * np.sin(th)
    foot = t / np.sin(th)  # width of each foot on the ground
    profile = np.array(
        [
            [0.0, 0.0],
            [foot, 0.0],
            [c, s - t / np.cos(th)],  # front foot (outer, inner), inner apex
            [2 * c - foot, 0.0],
            [2 * c, 0.0],
            [c, s],  # back foot (inner, outer), outer apex
        ]
    )
    legs = [[0, 1, 2], [0, 2, 5], [2, 3, 4], [2, 4, 5]]  # the two legs as two convex quads
    return extrude_x(profile, legs, -args.beacon_size / 2, args.beacon_size / 2)


def beacon_parts(style: str, args) -> list[trimesh.Trimesh]:
    """The closed meshes of one beacon, footprint centred on x = y = 0, resting above z = 0."""
    if style == "plate":
        m = plate(args)
        lo, hi = m.bounds
        m.apply_translation([0.0, -(lo[1] + hi[1]) / 2, args.plate_clearance - lo[2]])
        return [m]
    one = bracket(args)
    depth = one.bounds[1][1]
    pitch = depth + args.bracket_gap
    total = args.brackets * depth + (args.brackets - 1) * args.bracket_gap
    parts = []
    for i in range(args.brackets):
        m = one.copy()
        m.apply_translation([0.0, i * pitch - total / 2, args.gap])
        parts.append(m)
    return parts


def beacon_sites(depth: float, args) -> list[tuple[str, float, float]]:
    """(label, x, y) of every beacon's footprint centre: both sides every 50 m, both ends every 5 m."""
    half_w, length = args.runway_width / 2, args.runway_length
    n_side = int(np.floor(length / args.side_spacing + 1e-9)) + 1
    n_end = int(np.floor(args.runway_width / args.end_spacing + 1e-9)) + 1
    sites = []
    for side, sx in (("left", -1.0), ("right", 1.0)):
        for i in range(n_side):
            sites.append((f"{side}_{i:02d}", sx * (half_w + args.side_offset), i * args.side_spacing))
    for end, y in (("threshold", -(args.end_offset + depth / 2)), ("far_end", length + args.end_offset + depth / 2)):
        for i in range(n_end):
            sites.append((f"{end}_{i:02d}", -half_w + i * args.end_spacing, y))
    return sites


def build(style: str, args) -> dict[str, tuple[str, trimesh.Trimesh]]:
    """Node name -> (material name, mesh), Z-up."""
    half_w = args.runway_width / 2
    nodes = {
        "ground": ("ground", ground_mesh(args)),
        "runway": ("runway", box([-half_w, 0.0, -args.runway_depth], [half_w, args.runway_length, args.runway_top])),
    }
    parts = beacon_parts(style, args)
    depth = float(np.ptp(np.concatenate([p.vertices for p in parts])[:, 1]))
    for label, x, y in beacon_sites(depth, args):
        for i, part in enumerate(parts):
            m = part.copy()
            m.apply_translation([x, y, 0.0])
            nodes[f"beacon_{label}" + (f"_{i}" if len(parts) > 1 else "")] = ("beacon", m)
    return nodes


# -- export and checks --------------------------------------------------------------------------


def imager_pose(slant_range: float, args) -> tuple[np.ndarray, np.ndarray]:
    """Position on the glide slope at the slant range from the threshold, looking at the threshold."""
    gs = np.radians(args.glide_slope)
    position = np.array([0.0, -slant_range * np.cos(gs), slant_range * np.sin(gs)])
    return position, np.zeros(3)


def coverage_note(slant_range: float, args) -> str:
    """Where the view's central column leaves the ground: the band just below the horizon that
    sees the sky beyond the ground's far edge (the view's top edge is above the horizon)."""
    pos, look = imager_pose(slant_range, args)
    depression = np.degrees(np.arctan2(pos[2] - look[2], np.hypot(*(look - pos)[:2])))
    far_edge = args.ground_size / 2 - pos[1]
    edge_depression = np.degrees(np.arctan2(pos[2], far_edge))
    half_fov = IMAGER_FOV_DEG / 2  # square image: the vertical half field equals the horizontal
    bottom = depression + half_fov
    near_hit = pos[2] / np.tan(np.radians(bottom))
    half_width = np.tan(np.radians(half_fov)) * np.hypot(far_edge, pos[2])
    if near_hit > pos[1] + args.ground_size / 2 or half_width > args.ground_size / 2:
        raise SystemExit(f"the ground does not fill the view from {slant_range} m")
    return (
        f"view from {half_fov - depression:+.2f} to {-bottom:+.2f} deg elevation; ground from {near_hit:.0f} m "
        f"ahead to its edge at {-edge_depression:+.2f} deg (beyond it, sky near the horizon)"
    )


def main(argv=None) -> None:
    here = Path(__file__).resolve().parent
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--style", choices=(*STYLES, "all"), default="all", help="beacon style(s) to write")
    p.add_argument("--out-dir", type=Path, default=here, help="writes landing_<style>.glb there")
    p.add_argument("--out", type=Path, help="output file (only with a single --style)")
    p.add_argument("--runway-width", type=float, default=20.0, help="[m]")
    p.add_argument("--runway-length", type=float, default=600.0, help="[m], along +y from y = 0")
    p.add_argument("--runway-top", type=float, default=0.02, help="top of the asphalt slab [m]; ground top is 0")
    p.add_argument("--runway-depth", type=float, default=0.10, help="depth of the slab's bottom below ground [m]")
    p.add_argument("--ground-size", type=float, default=20000.0, help="ground square side [m], centred on the origin")
    p.add_argument("--ground-thickness", type=float, default=0.5, help="[m]")
    p.add_argument(
        "--gap", type=float, default=0.005, help="clearance between touching solids [m] (>= 10 float32 offsets at 1 km)"
    )
    p.add_argument(
        "--tilt",
        type=float,
        default=45.0,
        help="mirror tilt from horizontal [deg] (43 bisects zenith and a 4 deg glide path)",
    )
    p.add_argument("--beacon-size", type=float, default=1.0, help="plate side, bracket length along x [m]")
    p.add_argument("--plate-thickness", type=float, default=0.005, help="[m]")
    p.add_argument("--plate-clearance", type=float, default=0.05, help="plate's lower edge above the ground [m]")
    p.add_argument("--brackets", type=int, default=10, help="angle brackets per beacon")
    p.add_argument("--bracket-leg", type=float, default=0.10, help="leg width of an angle bracket [m]")
    p.add_argument("--bracket-thickness", type=float, default=0.003, help="[m]")
    p.add_argument("--bracket-gap", type=float, default=1.0, help="ground gap between brackets along y [m]")
    p.add_argument("--side-spacing", type=float, default=50.0, help="beacon pitch along the sides [m]")
    p.add_argument("--side-offset", type=float, default=2.0, help="runway edge to side beacon centre [m]")
    p.add_argument("--end-spacing", type=float, default=5.0, help="beacon pitch across the ends [m]")
    p.add_argument("--end-offset", type=float, default=2.0, help="runway end to end-beacon footprint [m]")
    p.add_argument("--glide-slope", type=float, default=4.0, help="for the suggested imager poses [deg]")
    p.add_argument(
        "--ranges", type=float, nargs="+", default=(1000.0, 400.0), help="slant ranges [m] to print poses for"
    )
    args = p.parse_args(argv)
    styles = STYLES if args.style == "all" else (args.style,)
    if args.out is not None and len(styles) > 1:
        p.error("--out needs a single --style")

    for style in styles:
        out = args.out or args.out_dir / f"landing_{style}.glb"
        nodes = build(style, args)
        export_glb(nodes, out)
        check_glb(nodes, out)
        n_tri = sum(len(m.faces) for _, m in nodes.values())
        beacon = [m for mat, m in nodes.values() if mat == "beacon"]
        print(f"wrote {out} ({n_tri} triangles)")
        for name in ("ground", "runway"):
            print(f"  {name}: {len(nodes[name][1].faces)} triangles")
        print(f"  beacon: {len(beacon)} closed meshes, {sum(len(m.faces) for m in beacon)} triangles")
    for r in args.ranges:
        pos, _ = imager_pose(r, args)
        print(
            f"suggested imager ({r:.0f} m on the {args.glide_slope:g} deg glide slope): "
            f"position [{pos[0]:.1f}, {pos[1]:.1f}, {pos[2]:.2f}], look_at [0, 0, 0], up [0, 0, 1], "
            f"fov {IMAGER_FOV_DEG:g} deg, resolution [{IMAGER_RESOLUTION[0]}, {IMAGER_RESOLUTION[1]}]"
        )
        print(f"  {coverage_note(r, args)}")


if __name__ == "__main__":
    main()
