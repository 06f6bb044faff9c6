"""The generated scenes of Murakowski 2014 sec. 2.3 and chapter 3 (scenes/{cinderblocks,truck,
bikeracks,landing,cwd,sar}): shipped assets load with the expected material names, every part is
closed and outward, the key dimensions match the thesis, and each script regenerates its assets
byte for byte."""

from __future__ import annotations

import subprocess
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from pmmw.scene.geometry import load_entry_mesh

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "scenes"

# Vertices are float32 in a GLB: 6e-5 m spacing at 600 m, 1e-7 m at 1 m.
GLB_REL = 2e-7  # relative position tolerance after the float32 round trip
ANGLE_TOL_DEG = 1e-3  # [deg], float32 vertices about each beacon's own metre (see export_glb)

LANDING = {"runway", "ground", "beacon"}
CWD = {"skin", "clothing", "holster", "gun", "shoes", "ground"}
SAR = {"dry_ground", "wet_ground", "rocks", "shrubs"}
SHIPPED = {
    "cinderblocks/cinderblocks.glb": {"ground", "cinderblock"},
    "truck/truck.glb": {"ground", "body", "tires", "interior"},
    "bikeracks/bikeracks.glb": {"bricks", "grass", "windows", "posts", "chain", "frame", "lock", "tires", "plastics"},
    "bikeracks/bikeracks_tree.glb": {"tree"},
    "landing/landing_plate.glb": LANDING,
    "landing/landing_brackets.glb": LANDING,
    "cwd/cwd_outdoor.glb": CWD,
    "cwd/cwd_indoor.glb": CWD | {"walls"},
    "cwd/cwd_outdoor_coated.glb": CWD - {"clothing"},
    "cwd/cwd_indoor_coated.glb": (CWD - {"clothing"}) | {"walls"},
    "sar/sar_cessna.glb": SAR | {"aircraft"},
    "sar/sar_blanket.glb": SAR | {"blanket"},
    "sar/sar_beacon.glb": SAR | {"blanket"},
}
SCRIPTS = {  # script -> the files it writes with its default arguments
    "cinderblocks": ["cinderblocks.glb"],
    "truck": ["truck.glb"],
    "bikeracks": ["bikeracks.glb", "bikeracks_tree.glb"],
    "landing": ["landing_plate.glb", "landing_brackets.glb"],
    "cwd": ["cwd_outdoor.glb", "cwd_outdoor_coated.glb", "cwd_indoor.glb", "cwd_indoor_coated.glb"],
    "sar": ["sar_cessna.glb", "sar_blanket.glb", "sar_beacon.glb"],
}


@cache
def parts(rel: str) -> list[tuple[str, trimesh.Trimesh]]:
    return load_entry_mesh(SCENES / rel)


def merged(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    m = mesh.copy()
    m.merge_vertices()
    return m


def of(rel: str, material: str) -> list[trimesh.Trimesh]:
    return [m for n, m in parts(rel) if n == material]


def section_loops(mesh: trimesh.Trimesh, z: float) -> int:
    """Number of closed curves where the plane at height z cuts the mesh."""
    seg = trimesh.intersections.mesh_plane(mesh, [0.0, 0.0, 1.0], [0.0, 0.0, z])
    keys = np.round(seg.reshape(-1, 3) / 1e-7).astype(np.int64)
    _, ids = np.unique(keys, axis=0, return_inverse=True)
    ids = ids.reshape(-1, 2)
    n = int(ids.max()) + 1
    graph = coo_matrix((np.ones(len(ids)), (ids[:, 0], ids[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[0]


def tilt_deg(mesh: trimesh.Trimesh) -> float:
    """Tilt from horizontal of the mirror faces (facing -y and up), area-weighted."""
    n, a = mesh.face_normals, mesh.area_faces
    front = (n[:, 1] < -0.1) & (n[:, 2] > 0.1)
    normal = (n[front] * a[front, None]).sum(axis=0)
    normal /= np.linalg.norm(normal)
    assert abs(normal[0]) < 1e-6
    return float(np.degrees(np.arccos(normal[2])))


# -- every shipped asset -------------------------------------------------------------------------


@pytest.mark.parametrize("rel", sorted(SHIPPED))
def test_shipped_scene_loads_closed_and_named(rel):
    loaded = parts(rel)
    assert {name for name, _ in loaded} == SHIPPED[rel]
    for name, mesh in loaded:
        m = merged(mesh)
        # Every part, metal included, is a closed outward mesh (dielectrics must be).
        assert m.is_watertight and m.is_winding_consistent, name
        assert m.volume > 0.0, name


# -- cinderblocks (Murakowski 2014 sec. 2.3.2) ----------------------------------------------------


def test_cinderblock_cavities_are_wells_closed_by_the_ground():
    """Every block lies flat on the stack below or on the ground (1 mm gap), its long face towards
    the imager (+y), so its cavities are vertical wells open at the top and closed at the bottom:
    a vertical ray down the middle of each cavity meets no block before the ground (z = 0)."""
    loaded = parts("cinderblocks/cinderblocks.glb")
    blocks = [m for n, m in loaded if n == "cinderblock"]
    (ground,) = [m for n, m in loaded if n == "ground"]
    for b in blocks:
        ext = b.bounds[1] - b.bounds[0]
        assert ext == pytest.approx([0.390, 0.190, 0.190], abs=1e-6)  # flat, long axis along x
    stacks = {}
    for b in blocks:
        stacks.setdefault(tuple(np.round(b.centroid[:2], 3)), []).append(b)
    assert sorted(len(v) for v in stacks.values()) == [2, 3]
    for (x, y), stack in stacks.items():
        everything = trimesh.util.concatenate(stack + [ground])
        for dx in (-0.0895, 0.0895):  # the two cavity centres, 32 + 147 / 2 mm from the middle
            origin = [[x + dx, y, max(b.bounds[1][2] for b in stack) + 1.0]]
            hits, _, _ = everything.ray.intersects_location(origin, [[0.0, 0.0, -1.0]])
            assert hits[:, 2].max() == pytest.approx(0.0, abs=1e-6)  # first hit: the ground


# -- truck (Murakowski 2014 sec. 2.3.3) -----------------------------------------------------------


def test_truck_body_tires_and_open_cab():
    """A compact pickup (5.0 m, 1.72 m high) standing on its four SA-9 tires 1 mm above the sand,
    its metal 0.19 m or more above it (the under-body cavity is open to the rays), and a cab seen
    through its open side window (Table 2.2 lists no glass): the imager's ray to the window's
    middle meets the leather interior first."""
    rel = "truck/truck.glb"
    body = trimesh.util.concatenate(of(rel, "body"))
    extents = np.sort(trimesh.bounds.oriented_bounds(body)[1])
    assert extents[-1] == pytest.approx(5.04, abs=0.01)  # with the bumpers
    assert body.bounds[1][2] == pytest.approx(1.72, abs=1e-4)
    tires = of(rel, "tires")
    assert len(tires) == 4
    wheel_centres = [t.bounds.mean(axis=0) for t in tires]
    under = [m for m in of(rel, "body") if min(np.linalg.norm(m.bounds.mean(axis=0) - c) for c in wheel_centres) > 0.2]
    assert min(m.bounds[0][2] for m in under) == pytest.approx(0.19, abs=0.005)  # the differential, the lowest
    for t in tires:
        assert t.bounds[0][2] == pytest.approx(0.001, abs=1e-4)
        assert np.ptp(t.vertices[:, 2]) == pytest.approx(0.72, abs=0.002)  # 0.36 m radius
    everything = trimesh.util.concatenate([m for _, m in parts(rel)])
    owner = np.concatenate([np.full(len(m.faces), n) for n, m in parts(rel)])
    window = np.array([0.752, 7.338, 1.33])  # printed by the script: the side window's middle
    origin = np.array([0.0, 0.0, 1.5])
    _, _, tri = everything.ray.intersects_location(
        [origin], [(window - origin) / np.linalg.norm(window - origin)], multiple_hits=False
    )
    assert owner[tri[0]] == "interior"


# -- bike racks (Murakowski 2014 sec. 2.3.4) ------------------------------------------------------


def test_bikeracks_fence_bicycles_and_tree():
    """Seven capped fence posts with six chains between them, two racks, two bicycles (four tires
    of 0.34 m, the near pair leaning 25 deg, the far pair upright), a lock; and the large tree
    behind the imager (sec. 2.3.4), in its own file: 22 m wide, 2 m to 10 m up, wholly behind
    the imager, which is outside it."""
    rel = "bikeracks/bikeracks.glb"
    posts = of(rel, "posts")
    assert len(posts) == 7 + 2
    fence = [p for p in posts if abs(p.centroid[1] - 9.0) < 0.01]
    assert len(fence) == 7
    for p in fence:
        assert p.bounds[1][2] == pytest.approx(0.96, abs=1e-4)  # 0.9 m post, 6 cm cap
    chains = of(rel, "chain")
    assert len(chains) == 6
    for c in chains:
        assert c.bounds[0][2] == pytest.approx(0.80 - 0.15 - 0.0125 - 0.003, abs=0.01)  # the sag, a link, the wire
    tires = of(rel, "tires")
    assert len(tires) == 4
    for t in tires:
        # the wheel's plane from the tire's vertices: its normal's tilt from horizontal is the lean
        centred = t.vertices - t.vertices.mean(axis=0)
        normal = np.linalg.svd(centred, full_matrices=False)[2][-1]
        lean = np.degrees(np.arcsin(abs(normal[2])))
        near = t.centroid[1] < 6.0
        assert lean == pytest.approx(25.0 if near else 0.0, abs=0.1)
        assert np.linalg.norm(centred, axis=1).max() == pytest.approx(0.34, abs=0.002)  # 700c: 0.34 m radius
    assert len(of(rel, "lock")) == 1
    (tree,) = of("bikeracks/bikeracks_tree.glb", "tree")
    lo, hi = tree.bounds
    assert hi[1] < -1.9 and hi[0] - lo[0] > 21.5 and hi[2] == pytest.approx(10.0, abs=0.05)
    assert not merged(tree).contains([[0.0, 0.0, 1.5]]).any()


# -- landing (Murakowski 2014 sec. 3.1) -----------------------------------------------------------------


@pytest.mark.parametrize("style", ["plate", "brackets"])
def test_landing_runway_and_ground(style):
    rel = f"landing/landing_{style}.glb"
    (runway,) = of(rel, "runway")
    lo, hi = runway.bounds
    assert hi[:2] - lo[:2] == pytest.approx([20.0, 600.0], rel=GLB_REL)
    assert lo[:2] == pytest.approx([-10.0, 0.0], abs=1e-4)
    assert hi[2] == pytest.approx(0.02, abs=1e-6)
    (ground,) = of(rel, "ground")
    glo, ghi = ground.bounds
    assert ghi[2] == pytest.approx(0.0, abs=1e-6)
    # Ground under the whole 10 deg view from 1000 m on the glide slope, runway inside its notch.
    assert glo[0] < -2000.0 and ghi[0] > 2000.0 and glo[1] < -1000.0 and ghi[1] > 5000.0
    assert lo[2] < 0.0 < hi[2]


def test_landing_plate_beacons():
    rel = "landing/landing_plate.glb"
    plates = of(rel, "beacon")
    assert len(plates) == 2 * 13 + 2 * 5
    for p in plates:
        assert tilt_deg(p) == pytest.approx(45.0, abs=ANGLE_TOL_DEG)
        front = (p.face_normals[:, 1] < -0.1) & (p.face_normals[:, 2] > 0.1)
        assert p.area_faces[front].sum() == pytest.approx(1.0, rel=1e-4)  # 1 m x 1 m
        assert p.bounds[0][2] > 0.0
    centres = np.array([(p.bounds[0] + p.bounds[1]) / 2 for p in plates])
    for side in (-1.0, 1.0):  # every 50 m along both sides
        row = centres[np.sign(centres[:, 0]) == side]
        row = row[np.abs(row[:, 0]) > 10.5]
        assert np.diff(np.sort(row[:, 1])) == pytest.approx(np.full(12, 50.0), abs=1e-3)
    for end in (centres[:, 1] < -1.0, centres[:, 1] > 601.0):  # every 5 m across both ends
        assert np.diff(np.sort(centres[end, 0])) == pytest.approx(np.full(4, 5.0), abs=1e-3)


def test_landing_bracket_beacons():
    brackets = of("landing/landing_brackets.glb", "beacon")
    assert len(brackets) == 36 * 10
    leg = 0.10
    for b in brackets[:20]:
        assert tilt_deg(b) == pytest.approx(45.0, abs=ANGLE_TOL_DEG)
        assert np.ptp(b.vertices[:, 0]) == pytest.approx(1.0, rel=1e-5)
        assert np.ptp(b.vertices[:, 1]) == pytest.approx(2 * leg * np.cos(np.radians(45.0)), rel=1e-4)
    # Ten brackets per beacon in a row along y, 1 m of ground between them.
    centres = np.array([(b.bounds[0] + b.bounds[1]) / 2 for b in brackets])
    row = centres[(np.abs(centres[:, 0] - 12.0) < 0.1) & (np.abs(centres[:, 1] - 300.0) < 6.0)]
    assert len(row) == 10
    assert np.diff(np.sort(row[:, 1])) == pytest.approx(np.full(9, 1.0 + 2 * leg * np.cos(np.radians(45.0))), abs=1e-3)


# -- concealed weapon detection (Murakowski 2014 sec. 3.2) ----------------------------------------------


def test_cwd_person():
    rel = "cwd/cwd_outdoor.glb"
    (body,) = of(rel, "skin")
    lo, hi = body.bounds
    assert hi[2] == pytest.approx(1.8, abs=0.03)  # height
    assert lo[2] > 0.0
    # Head, arms and legs separate from the trunk: one loop through the neck, three at the elbows
    # (two arms, trunk), two through the thighs.
    assert section_loops(body, 1.60) == 1
    assert section_loops(body, 1.10) == 3
    assert section_loops(body, 0.60) == 2
    # Garments: denim 0.8 mm, holster leather 2 mm (volume / one side's area).
    for material, thickness in (("clothing", 0.0008), ("holster", 0.002)):
        (m,) = of(rel, material)
        assert m.volume / (m.area / 2) == pytest.approx(thickness, rel=0.15), material
    (gun,) = of(rel, "gun")
    extents = np.sort(trimesh.bounds.oriented_bounds(gun)[1])
    assert extents == pytest.approx([0.03, 0.13, 0.22], abs=0.01)
    (holster,) = of(rel, "holster")
    assert np.linalg.norm(gun.centroid - holster.centroid) < 0.1
    assert gun.centroid[0] > 0.1  # under his left arm (+x; he faces -y)
    for shoe in of(rel, "shoes"):
        assert shoe.bounds[0][2] > 0.0


def test_cwd_room_holds_both_views():
    (walls,) = of("cwd/cwd_indoor.glb", "walls")
    lo, hi = walls.bounds
    assert lo[1] < -20.0 and hi[1] > 0.5 and hi[2] > 2.5
    imager = np.array([[0.0, -20.0, 1.5], [0.0, -4.0, 1.5]])
    assert not merged(walls).contains(imager).any()  # in the cavity, not in the wall


# -- search and rescue (Murakowski 2014 sec. 3.3) -------------------------------------------------------


def test_sar_terrain_and_clutter():
    """Sec. 3.3.1: small-scale clutter only ("rocks, boulders, shrubs, and trees"; no large-scale
    features): every clutter object, wet patches included, is smaller than the 5 m spot of the
    95 GHz imager on the ground, so that it blurs out, and none comes near the target."""
    rel = "sar/sar_blanket.glb"
    (terrain,) = of(rel, "dry_ground")
    lo, hi = terrain.bounds
    assert hi[:2] - lo[:2] == pytest.approx([600.0, 600.0], rel=GLB_REL)
    assert np.ptp(terrain.vertices[:, 2]) < 12.0  # gentle relief
    assert len(of(rel, "rocks")) >= 200 and len(of(rel, "shrubs")) >= 200 and len(of(rel, "wet_ground")) == 200
    for name in ("rocks", "shrubs", "wet_ground"):
        across = [np.ptp(m.vertices[:, :2], axis=0).max() for m in of(rel, name)]
        assert max(across) < 6.0, name
    for name in ("rocks", "shrubs", "wet_ground"):
        centres = np.array([m.centroid for m in of(rel, name)])
        assert np.hypot(centres[:, 0], centres[:, 1]).min() > 25.0  # clear of the target


def test_sar_targets():
    (blanket,) = of("sar/sar_blanket.glb", "blanket")
    extents = np.sort(trimesh.bounds.oriented_bounds(blanket)[1])
    assert extents[1:] == pytest.approx([1.5, 2.0], abs=1e-4)
    beacon = of("sar/sar_beacon.glb", "blanket")
    assert len(beacon) == 12
    extents = np.sort(trimesh.bounds.oriented_bounds(trimesh.util.concatenate(beacon))[1])
    assert extents[1:] == pytest.approx([6.0, 6.0], abs=0.05)
    wreck = {n: m for n, m in parts("sar/sar_cessna.glb") if n == "aircraft"}
    meshes = of("sar/sar_cessna.glb", "aircraft")
    assert wreck and len(meshes) >= 5
    lengths = [np.sort(trimesh.bounds.oriented_bounds(m)[1])[-1] for m in meshes]
    assert max(lengths) == pytest.approx(8.1, abs=0.3)  # the fuselage
    assert sorted(lengths)[-2] == pytest.approx(5.05, abs=0.2)  # a wing, root to tip
    everything = np.vstack([m.vertices for m in meshes])
    assert np.hypot(everything[:, 0], everything[:, 1]).max() < 10.0
    assert everything[:, 2].min() > 0.0


# -- regeneration --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "scene",
    [
        "cinderblocks",
        "truck",  # ~2 s
        "bikeracks",  # ~3 s: 50 nodes, chains of links
        "landing",
        pytest.param("cwd", marks=pytest.mark.slow),  # ~8 s: implicit body, clothing, shoes
        pytest.param("sar", marks=pytest.mark.slow),  # ~4 s: terrain, 700 rocks and shrubs
    ],
)
def test_script_regenerates_shipped_files(scene, tmp_path):
    script = SCENES / scene / "make_scene.py"
    subprocess.run([sys.executable, str(script), "--out-dir", str(tmp_path)], check=True, capture_output=True, cwd=REPO)
    for name in SCRIPTS[scene]:
        new, shipped = tmp_path / name, SCENES / scene / name
        if new.read_bytes() == shipped.read_bytes():
            continue
        # Not byte-identical: library versions may break ties differently (seen: trimesh 5.2 splits
        # 16 of 34000 quads of the voxel body along the other diagonal). The same scene means the
        # same objects and vertices, and surfaces that differ only in such splits: equal area and
        # enclosed volume (to rounding), and at most 0.1 % of the faces changed.
        a, b = trimesh.load(new, force="scene"), trimesh.load(shipped, force="scene")
        assert sorted(a.geometry) == sorted(b.geometry), name
        for key in a.geometry:
            ga, gb = a.geometry[key], b.geometry[key]
            assert ga.vertices.shape == gb.vertices.shape and ga.faces.shape == gb.faces.shape, (name, key)
            assert np.allclose(ga.vertices, gb.vertices, rtol=0, atol=1e-9), (name, key)
            assert np.mean(np.any(ga.faces != gb.faces, axis=1)) <= 1e-3, (name, key)
            assert ga.area == pytest.approx(gb.area, rel=1e-9), (name, key)
            if gb.is_watertight:
                assert ga.is_watertight and ga.volume == pytest.approx(gb.volume, rel=1e-9), (name, key)
