"""Write scenes/sar/sar_{cessna,blanket,beacon}.glb: search and rescue in desert scrub (Murakowski 2014, sec. 3.3).

A small metal aircraft (a Cessna 172) has crashed in desert scrub land; a search aircraft at
3000 m looks straight down with a 10 deg field (a 500 m wide swath). Three targets: the wreck;
instead of it, a 1.5 m x 2 m metallized (Mylar) emergency blanket; or a 6 m x 6 m beacon made of
twelve such blankets (4 x 3). The ground is dry soil strewn with small-scale clutter, as the thesis
models it ("small-scale ground clutter such as rocks, boulders, shrubs, and trees; we do not model
large-scale clutter objects such as streams or other major terrain features", sec. 3.3.1):
basalt rocks and boulders, shrubs, and small damp patches of moist soil (Table 3.4 'Wet Ground'),
each a few metres across at most, below the 5 m (95 GHz) and 13 m (35 GHz) spots on the ground,
so that the clutter blurs out and the metal targets stay the coldest objects in the scene.

The terrain is one closed solid, 600 m x 600 m: a heightfield top with gentle relief (a seeded
sum of random plane waves, 25 m to 600 m wavelengths), vertical skirts and a flat bottom. Around
the target the relief fades out (flat within ``--pad-radius``), so the target lies flat; no
rock, shrub or wet patch comes within ``--clear-radius`` of it. Wet patches are thin closed slabs
(irregular star-shaped outlines, ``--wet-sizes`` across) sheared into the plane that fits the
terrain under them. Rocks are closed convex hulls of random points; shrubs closed, radially
perturbed icospheres. Every clutter object rests ``--gap`` above the highest terrain under it. The wreck (fuselage loft, a drooping right wing, the left
wing torn off beside it, tail, strut, bent propeller) and the blankets are closed metal meshes;
metal parts of the wreck may interpenetrate (a perfect conductor has no inside to track).

Mesh material names: ``dry_ground``, ``wet_ground``, ``rocks``, ``shrubs``, and ``aircraft`` or
``blanket``. Frame: Z up, metres, target at the origin. Everything random comes from ``--seed``,
so the output is the same on every run. The scene is built Z-up and rotated into glTF's Y-up on
export; pmmw turns it back on load.

    python scenes/sar/make_scene.py [--target cessna|blanket|beacon|all] [--out-dir DIR] [--seed 3] ...
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh

from pmmw.scene.export import check_glb, export_glb
from pmmw.scene.shapes import box

TARGETS = ("cessna", "blanket", "beacon")
TARGET_MATERIAL = {"cessna": "aircraft", "blanket": "blanket", "beacon": "blanket"}
CLUTTER_MATERIALS = {"dry_ground", "wet_ground", "rocks", "shrubs"}

# Murakowski 2014 sec. 3.3.1: imager at 3000 m pointing down, 10 deg field, 300 x 300 pixels, 2 m aperture.
IMAGER_ALTITUDE = 3000.0
IMAGER_FOV_DEG = 10.0
IMAGER_RESOLUTION = (300, 300)

# Cessna 172 (8.28 m long, 11.0 m span, cabin about 1.1 m wide): fuselage stations along x from
# the nose [m]: (x, half width, bottom z, top z), the aircraft lying on its belly (no gear).
FUSELAGE = (
    (0.00, 0.10, 0.55, 0.75),
    (0.25, 0.35, 0.30, 0.95),
    (0.90, 0.50, 0.10, 1.05),
    (1.70, 0.56, 0.02, 1.42),
    (2.60, 0.56, 0.00, 1.48),
    (3.50, 0.52, 0.05, 1.42),
    (4.50, 0.40, 0.22, 1.20),
    (5.50, 0.29, 0.38, 1.05),
    (6.50, 0.19, 0.52, 0.95),
    (7.50, 0.12, 0.62, 0.90),
    (8.10, 0.06, 0.68, 0.86),
)
WING_ROOT_X, WING_Z = 1.75, 1.50  # leading edge at the root, underside height
WING_ROOT, WING_TIP, WING_CHORDS = 0.45, 5.50, (1.63, 1.12)  # span stations from the axis, chords
FUSELAGE_RING = 20  # points per fuselage cross-section


# -- mesh helpers -----------------------------------------------------------------------------------


def loft(rings) -> trimesh.Trimesh:
    """Closed mesh through a sequence of closed rings of equal point count, capped at both ends
    by fans from the ring centroids (each end ring must be star-shaped about its centroid).

    Parameters
    ----------
    rings : sequence of ndarray, shape (m, 3)
        Cross-sections [m], in order along the loft, points in the same rotational order.
    """
    rings = [np.asarray(r, float) for r in rings]
    n, m = len(rings), len(rings[0])
    vertices = np.vstack([*rings, rings[0].mean(axis=0), rings[-1].mean(axis=0)])
    faces = []
    for i in range(n - 1):
        for j in range(m):
            a, b = i * m + j, i * m + (j + 1) % m
            faces += [[a, b, b + m], [a, b + m, a + m]]
    first, last = n * m, n * m + 1
    for j in range(m):
        faces.append([first, (j + 1) % m, j])
        faces.append([last, (n - 1) * m + j, (n - 1) * m + (j + 1) % m])
    mesh = trimesh.Trimesh(vertices, np.array(faces), process=False)
    if mesh.volume < 0.0:
        mesh.invert()
    return mesh


def rotation(axis, angle_deg: float) -> np.ndarray:
    return trimesh.transformations.rotation_matrix(np.radians(angle_deg), axis)


def airfoil(chord: float, thickness: float, n: int = 8) -> np.ndarray:
    """A convex airfoil (flat bottom, cambered top) in (chordwise, normal) coordinates [m], (2n, 2)."""
    s = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, n + 1))  # 0..1, clustered at the ends
    top = np.column_stack([s, 2.6 * thickness * np.sqrt(s) * (1.0 - s)])
    bottom = np.column_stack([s[::-1][1:-1], np.zeros(n - 1)])
    return np.vstack([top, bottom]) * chord


# -- terrain ----------------------------------------------------------------------------------------


class Terrain:
    """A heightfield on a regular grid, piecewise linear on the triangles of `solid`.

    Attributes
    ----------
    xs, ys : ndarray, shape (n + 1,)
        Grid lines [m].
    h : ndarray, shape (n + 1, n + 1)
        Heights [m] at the grid vertices.
    """

    def __init__(self, args, rng):
        half = args.terrain_size / 2
        n = round(args.terrain_size / args.cell)
        self.xs = self.ys = np.linspace(-half, half, n + 1)
        self.cell = args.terrain_size / n
        gx, gy = np.meshgrid(self.xs, self.ys, indexing="ij")
        h = random_field(gx, gy, rng, 25.0, 600.0, 1.0)
        h *= args.relief / h.std()
        self.h = h * pad_weight(np.hypot(gx, gy), args.pad_radius, args.pad_radius * 3)
        self.bottom = float(self.h.min()) - args.terrain_depth

    def height(self, x, y):
        """Terrain height [m] at points (x, y), exact on the mesh triangles (diagonal i,j -> i+1,j+1)."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        n = len(self.xs) - 1
        u = np.clip((x - self.xs[0]) / self.cell, 0.0, n - 1e-9)
        v = np.clip((y - self.ys[0]) / self.cell, 0.0, n - 1e-9)
        i, j = u.astype(int), v.astype(int)
        u, v = u - i, v - j
        h00, h10, h11, h01 = self.h[i, j], self.h[i + 1, j], self.h[i + 1, j + 1], self.h[i, j + 1]
        lower = h00 + u * (h10 - h00) + v * (h11 - h10)  # triangle (00, 10, 11): u >= v
        upper = h00 + v * (h01 - h00) + u * (h11 - h01)  # triangle (00, 11, 01)
        return np.where(u >= v, lower, upper)

    def max_under(self, x, y, radius):
        """Highest terrain [m] within the square of half side ``radius`` around (x, y)."""
        k = max(3, int(np.ceil(2 * radius / (self.cell / 4))) + 1)
        s = np.linspace(-radius, radius, k)
        px, py = np.meshgrid(x + s, y + s, indexing="ij")
        inside = [(self.xs > x - radius) & (self.xs < x + radius), (self.ys > y - radius) & (self.ys < y + radius)]
        top = self.height(px.ravel(), py.ravel()).max()
        if inside[0].any() and inside[1].any():
            top = max(top, self.h[np.ix_(inside[0], inside[1])].max())
        return float(top)

    def solid(self) -> trimesh.Trimesh:
        """The closed terrain: heightfield top, vertical skirts, a flat bottom fanned from its centre."""
        n = len(self.xs) - 1
        gx, gy = np.meshgrid(self.xs, self.ys, indexing="ij")
        top = np.column_stack([gx.ravel(), gy.ravel(), self.h.ravel()])
        vid = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
        a, b, c, d = vid[:-1, :-1].ravel(), vid[1:, :-1].ravel(), vid[1:, 1:].ravel(), vid[:-1, 1:].ravel()
        faces = [np.column_stack([a, b, c]), np.column_stack([a, c, d])]
        # The boundary ring, counter-clockwise seen from above.
        ring = np.concatenate([vid[:, 0], vid[-1, 1:], vid[-2::-1, -1], vid[0, -2:0:-1]])
        bottom = top[ring].copy()
        bottom[:, 2] = self.bottom
        base = len(top)
        centre = base + len(ring)
        vertices = np.vstack([top, bottom, [[self.xs.mean(), self.ys.mean(), self.bottom]]])
        r0, r1 = ring, np.roll(ring, -1)
        b0, b1 = base + np.arange(len(ring)), base + np.roll(np.arange(len(ring)), -1)
        faces += [np.column_stack([r0, b0, b1]), np.column_stack([r0, b1, r1])]  # skirts, outward
        faces.append(np.column_stack([np.full(len(ring), centre), b1, b0]))  # bottom, facing down
        return trimesh.Trimesh(vertices, np.concatenate(faces), process=False)


def random_field(x, y, rng, shortest: float, longest: float, slope_exponent: float):
    """A sum of 48 plane waves of random direction and phase, wavelengths log-uniform in
    [shortest, longest] [m], amplitude proportional to wavelength ** slope_exponent."""
    n = 48
    wavelength = np.exp(rng.uniform(np.log(shortest), np.log(longest), n))
    theta = rng.uniform(0.0, 2 * np.pi, n)
    phase = rng.uniform(0.0, 2 * np.pi, n)
    k = 2 * np.pi / wavelength
    f = np.zeros_like(x, dtype=float)
    for i in range(n):
        f += wavelength[i] ** slope_exponent * np.cos(k[i] * (x * np.cos(theta[i]) + y * np.sin(theta[i])) + phase[i])
    return f


def pad_weight(r, r0: float, r1: float):
    """0 inside r0, 1 beyond r1, smooth (C1) in between."""
    s = np.clip((r - r0) / (r1 - r0), 0.0, 1.0)
    return s * s * (3 - 2 * s)


# -- clutter ----------------------------------------------------------------------------------------


def rock(rng, size: float) -> trimesh.Trimesh:
    """A closed convex hull of 10-18 random points on a squashed, lumpy ellipsoid of width ~size."""
    k = int(rng.integers(10, 19))
    d = rng.normal(size=(k, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d *= rng.uniform(0.75, 1.0, (k, 1))
    d *= [1.0, rng.uniform(0.6, 1.0), rng.uniform(0.35, 0.75)]
    m = trimesh.convex.convex_hull(d * size / 2)
    m.apply_transform(rotation([0, 0, 1], rng.uniform(0.0, 360.0)))
    return m


def shrub(rng, width: float, height: float) -> trimesh.Trimesh:
    """A closed low-poly blob (an icosphere with radial noise), width x width x height [m]."""
    m = trimesh.creation.icosphere(subdivisions=1)
    v = m.vertices * rng.uniform(0.8, 1.15, (len(m.vertices), 1))
    v *= [width / 2 * rng.uniform(0.8, 1.0), width / 2 * rng.uniform(0.8, 1.0), height / 2]
    m = trimesh.Trimesh(v, m.faces, process=False)
    m.apply_transform(rotation([0, 0, 1], rng.uniform(0.0, 360.0)))
    return m


def wet_patch(rng, size: float, thickness: float) -> trimesh.Trimesh:
    """A closed slab of moist soil, ``thickness`` high [m], on an irregular outline ~``size`` [m]
    across: 14 points at increasing angles (star-shaped about the centre, so the fans close it)."""
    k = 14
    angle = (np.arange(k) + rng.uniform(-0.3, 0.3, k)) * (2 * np.pi / k)
    r = size / 2 * rng.uniform(0.6, 1.0, k)
    ring = np.column_stack([r * np.cos(angle), r * np.sin(angle) * rng.uniform(0.5, 1.0)])
    rings = [np.column_stack([ring, np.full(k, z)]) for z in (0.0, thickness)]
    m = loft(rings)
    m.apply_transform(rotation([0, 0, 1], rng.uniform(0.0, 360.0)))
    return m


def scatter(terrain: Terrain, args, rng):
    """Wet patches, rocks and shrubs: node name -> (material, mesh), apart from each other and the
    target, each resting ``--gap`` above the highest terrain under it (a wet patch sheared into
    the plane that fits the terrain under it first, so that it lies on the slope)."""
    half = args.terrain_size / 2
    placed = []  # (x, y, radius)
    nodes = {}
    kinds = (
        [("wet", i) for i in range(args.wet_patches)]
        + [("rock", i) for i in range(args.rocks)]
        + [("shrub", i) for i in range(args.shrubs)]
    )
    for kind, i in kinds:
        if kind == "wet":
            size = float(np.exp(rng.uniform(np.log(args.wet_sizes[0]), np.log(args.wet_sizes[1]))))
            mesh = wet_patch(rng, size, args.wet_thickness)
        elif kind == "rock":
            size = float(np.exp(rng.uniform(np.log(args.rock_sizes[0]), np.log(args.rock_sizes[1]))))
            mesh = rock(rng, size)
        else:
            width = float(rng.uniform(*args.shrub_sizes))
            mesh = shrub(rng, width, width * rng.uniform(0.5, 0.9))
        lo, hi = mesh.bounds
        mesh.apply_translation([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, 0.0])
        radius = float(np.linalg.norm(mesh.vertices[:, :2], axis=1).max())
        for _ in range(1000):
            x, y = rng.uniform(-half + radius + 1.0, half - radius - 1.0, 2)
            if np.hypot(x, y) < args.clear_radius + radius:
                continue
            if any(np.hypot(x - px, y - py) < radius + pr + 0.3 for px, py, pr in placed):
                continue
            break
        else:
            raise SystemExit(f"no room for {kind} {i}")
        placed.append((x, y, radius))
        if kind == "wet":
            # Least-squares plane z = c + a dx + b dy through the terrain under the patch; the
            # slab is sheared into it (a shear keeps it closed and outward) and lifted by the
            # largest terrain height above that plane.
            s = np.linspace(-radius, radius, 9)
            dx, dy = (g.ravel() for g in np.meshgrid(s, s, indexing="ij"))
            h = terrain.height(x + dx, y + dy)
            (c, a, b), *_ = np.linalg.lstsq(np.column_stack([np.ones_like(dx), dx, dy]), h, rcond=None)
            v = mesh.vertices.copy()
            lift = float((h - (c + a * dx + b * dy)).max()) + args.gap
            v[:, 2] += c + a * v[:, 0] + b * v[:, 1] + lift
            v[:, :2] += [x, y]
            mesh = trimesh.Trimesh(v, mesh.faces, process=False)
        else:
            base = terrain.max_under(x, y, radius) + args.gap
            mesh.apply_translation([x, y, base - mesh.bounds[0][2]])
        material = {"wet": "wet_ground", "rock": "rocks", "shrub": "shrubs"}[kind]
        nodes[f"{kind}_{i:03d}"] = (material, mesh)
    return nodes


# -- targets ----------------------------------------------------------------------------------------


def cessna(args) -> dict[str, trimesh.Trimesh]:
    """The wreck, nose towards -x before the heading turn; part name -> closed metal mesh."""
    t = np.linspace(0.0, 2 * np.pi, FUSELAGE_RING, endpoint=False)
    c, s = np.cos(t), np.sin(t)
    ce, se = np.sign(c) * np.abs(c) ** 0.8, np.sign(s) * np.abs(s) ** 0.8  # a rounded box section
    rings = []
    for x, hw, z0, z1 in FUSELAGE:
        rings.append(np.column_stack([np.full_like(t, x), hw * ce, (z0 + z1) / 2 + (z1 - z0) / 2 * se]))
    parts = {"fuselage": loft(rings)}

    def wing(y0, y1):
        sections = []
        for y, chord in ((y0, WING_CHORDS[0]), (y1, WING_CHORDS[1])):
            foil = airfoil(chord, 0.13)
            x = WING_ROOT_X + (WING_CHORDS[0] - chord) * 0.25 + foil[:, 0]
            sections.append(np.column_stack([x, np.full(len(foil), y), WING_Z + foil[:, 1]]))
        return loft(sections)

    right = wing(-WING_ROOT, -WING_TIP)  # right wing at -y, bent down at the root (tip near the ground)
    pivot = [0.0, -WING_ROOT, WING_Z]
    right.apply_transform(trimesh.transformations.rotation_matrix(np.radians(args.wing_droop), [1, 0, 0], pivot))
    parts["wing_right"] = right
    for name, (span, chord, z, x0) in {"stabilizer": (3.4, 0.85, 0.80, 7.05)}.items():
        foil = airfoil(chord, 0.10)
        sections = [
            np.column_stack([x0 + foil[:, 0], np.full(len(foil), y), z + foil[:, 1]]) for y in (-span / 2, span / 2)
        ]
        parts[name] = loft(sections)
    fin_sections = []
    for z, chord, x0 in ((0.85, 1.30, 6.75), (2.05, 0.70, 7.55)):
        foil = airfoil(chord, 0.10)
        fin_sections.append(
            np.column_stack([x0 + foil[:, 0], foil[:, 1] - 0.6 * foil[:, 1].max(), np.full(len(foil), z)])
        )
    parts["fin"] = loft(fin_sections)
    strut = box([-0.04, -0.015, 0.0], [0.04, 0.015, 2.5])  # right wing strut, from the cabin floor
    strut.apply_transform(rotation([1, 0, 0], 52.0))
    strut.apply_translation([2.2, -0.55, 0.25])
    parts["strut"] = strut
    for k, bend in enumerate((25.0, -60.0)):  # two propeller blades, bent back by the impact
        blade = box([-0.02, 0.0, -0.06], [0.02, 0.95, 0.06])
        blade.apply_transform(rotation([0, 0, 1], bend))
        blade.apply_transform(rotation([1, 0, 0], 180.0 * k + 20.0))
        blade.apply_translation([-0.05, 0.0, 0.65])
        parts[f"propeller_{k}"] = blade
    # Roll onto the right side a little, then lift onto the ground.
    roll = rotation([1, 0, 0], args.roll)
    for m in parts.values():
        m.apply_transform(roll)
    lowest = min(m.vertices[:, 2].min() for m in parts.values())
    for m in parts.values():
        m.apply_translation([0.0, 0.0, args.gap - lowest])
    left = wing(WING_ROOT, WING_TIP)  # torn off: lies upside down on the ground behind the left side
    left.apply_transform(rotation([1, 0, 0], 180.0))
    left.apply_transform(rotation([0, 0, 1], 35.0))
    lo, hi = left.bounds
    left.apply_translation([4.2 - (lo[0] + hi[0]) / 2, 3.6 - (lo[1] + hi[1]) / 2, args.gap - lo[2]])
    parts["wing_left"] = left
    # Turn to the heading and centre the wreck's footprint on the origin.
    heading = rotation([0, 0, 1], args.heading)
    for m in parts.values():
        m.apply_transform(heading)
    everything = np.vstack([m.vertices for m in parts.values()])
    centre = (everything.min(axis=0) + everything.max(axis=0)) / 2
    for m in parts.values():
        m.apply_translation([-centre[0], -centre[1], 0.0])
    return parts


def blanket(args, x: float = 0.0, y: float = 0.0) -> trimesh.Trimesh:
    w, length = args.blanket_size
    return box([x - w / 2, y - length / 2, args.gap], [x + w / 2, y + length / 2, args.gap + args.blanket_thickness])


def target_nodes(target: str, args) -> dict[str, tuple[str, trimesh.Trimesh]]:
    if target == "cessna":
        return {name: ("aircraft", m) for name, m in cessna(args).items()}
    if target == "blanket":
        m = blanket(args)
        m.apply_transform(rotation([0, 0, 1], args.heading))
        return {"blanket": ("blanket", m)}
    w, length = args.blanket_size
    pitch = np.array([w, length]) + args.beacon_gap
    nodes = {}
    for i in range(4):  # 4 x 1.5 m across, 3 x 2 m along: 6 m x 6 m
        for j in range(3):
            m = blanket(args, (i - 1.5) * pitch[0], (j - 1.0) * pitch[1])
            m.apply_transform(rotation([0, 0, 1], args.heading))
            nodes[f"blanket_{i}{j}"] = ("blanket", m)
    return nodes


# -- export and checks ------------------------------------------------------------------------------


def main(argv=None) -> None:
    here = Path(__file__).resolve().parent
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--target", choices=(*TARGETS, "all"), default="all", help="target(s) to write")
    p.add_argument("--out-dir", type=Path, default=here, help="writes sar_<target>.glb there")
    p.add_argument("--out", type=Path, help="output file (only with a single --target)")
    p.add_argument("--seed", type=int, default=3, help="random seed of terrain, patches, rocks and shrubs")
    p.add_argument("--terrain-size", type=float, default=600.0, help="terrain square side [m], centred on the target")
    p.add_argument("--cell", type=float, default=5.0, help="terrain grid step [m]")
    p.add_argument("--relief", type=float, default=1.5, help="RMS terrain height [m]")
    p.add_argument("--terrain-depth", type=float, default=2.0, help="flat bottom below the lowest ground [m]")
    p.add_argument(
        "--pad-radius",
        type=float,
        default=20.0,
        help="flat ground around the target [m]; the relief returns fully at 3x this",
    )
    p.add_argument("--clear-radius", type=float, default=25.0, help="no clutter this close to the target [m]")
    p.add_argument("--wet-patches", type=int, default=200, help="number of damp patches of moist soil")
    p.add_argument(
        "--wet-sizes",
        type=float,
        nargs=2,
        default=(1.0, 6.0),
        metavar=("MIN", "MAX"),
        help="wet patch size across [m], log-uniform",
    )
    p.add_argument("--wet-thickness", type=float, default=0.03, help="wet slab thickness [m]")
    p.add_argument("--rocks", type=int, default=300)
    p.add_argument(
        "--rock-sizes", type=float, nargs=2, default=(0.3, 2.5), metavar=("MIN", "MAX"), help="[m], log-uniform"
    )
    p.add_argument("--shrubs", type=int, default=400)
    p.add_argument("--shrub-sizes", type=float, nargs=2, default=(0.6, 2.5), metavar=("MIN", "MAX"), help="width [m]")
    p.add_argument("--heading", type=float, default=35.0, help="target heading [deg about z]")
    p.add_argument("--roll", type=float, default=4.0, help="wreck roll onto its right side [deg]")
    p.add_argument("--wing-droop", type=float, default=10.0, help="right wing bent down at the root [deg]")
    p.add_argument("--blanket-size", type=float, nargs=2, default=(1.5, 2.0), metavar=("W", "L"), help="[m]")
    p.add_argument("--blanket-thickness", type=float, default=0.002, help="closed metal sheet [m]")
    p.add_argument("--beacon-gap", type=float, default=0.01, help="between the beacon's 12 blankets [m]")
    p.add_argument("--gap", type=float, default=0.005, help="clearance above the ground [m]")
    args = p.parse_args(argv)
    targets = TARGETS if args.target == "all" else (args.target,)
    if args.out is not None and len(targets) > 1:
        p.error("--out needs a single --target")

    rng = np.random.default_rng(args.seed)
    terrain = Terrain(args, rng)
    clutter = {"terrain": ("dry_ground", terrain.solid()), **scatter(terrain, args, rng)}
    for target in targets:
        out = args.out or args.out_dir / f"sar_{target}.glb"
        nodes = {**clutter, **target_nodes(target, args)}
        export_glb(nodes, out)
        check_glb(nodes, out, CLUTTER_MATERIALS | {TARGET_MATERIAL[target]})
        n_tri = sum(len(m.faces) for _, m in nodes.values())
        tgt = np.vstack([m.vertices for mat, m in nodes.values() if mat == TARGET_MATERIAL[target]])
        tgt = tgt @ rotation([0, 0, 1], args.heading)[:3, :3]  # in the target's own axes
        ext = tgt.max(axis=0) - tgt.min(axis=0)
        print(
            f"wrote {out} ({n_tri} triangles); target {ext[0]:.2f} x {ext[1]:.2f} x {ext[2]:.2f} m, "
            f"{sum(len(m.faces) for mat, m in nodes.values() if mat == TARGET_MATERIAL[target])} triangles"
        )
    by_material = {}
    for material, m in clutter.values():
        by_material[material] = by_material.get(material, 0) + len(m.faces)
    print("  " + ", ".join(f"{k}: {v} triangles" for k, v in by_material.items()))
    wet_area = sum(m.area_faces[m.face_normals[:, 2] > 0.5].sum() for mat, m in clutter.values() if mat == "wet_ground")
    print(
        f"  wet ground: {args.wet_patches} patches, {wet_area:.0f} m^2 ({wet_area / args.terrain_size**2 * 100:.2f} % "
        f"of the terrain); terrain z {terrain.h.min():.2f}..{terrain.h.max():.2f} m"
    )
    print(
        f"suggested imager: position [0, 0, {IMAGER_ALTITUDE:g}], look_at [0, 0, 0], up [0, 1, 0], "
        f"fov {IMAGER_FOV_DEG:g} deg, resolution [{IMAGER_RESOLUTION[0]}, {IMAGER_RESOLUTION[1]}] "
        f"(swath {2 * IMAGER_ALTITUDE * np.tan(np.radians(IMAGER_FOV_DEG / 2)):.0f} m)"
    )


if __name__ == "__main__":
    main()
