"""The landing configs' report regions are what their comments and the README say they are: the
`beacons` box of `configs/landing_95ghz.yaml` and of every range of `configs/landing_trade.yaml`
holds the row of five beacons across the threshold (plates and their reflections in the ground)
and no other beacon; every region is in view; and a sweep keeps the regions in their written
order, which names each pair "a - b" with a the target whose blurred footprint its SNR uses
(`pmmw.imaging.detection.region_snr`). Geometry only: no render."""

from pathlib import Path

import numpy as np
import pytest
import trimesh

from pmmw.config import load_scenario
from pmmw.pipeline import region_shapes
from pmmw.scene.camera import Camera
from pmmw.sweeps.run import load_sweep_file, overrides_of, variants

REPO = Path(__file__).resolve().parents[2]
LANDING = REPO / "configs/landing_95ghz.yaml"
TRADE = REPO / "configs/landing_trade.yaml"


def _beacons() -> dict[str, np.ndarray]:
    """Each beacon's vertices in the world frame (Z up) [m], with their mirror images in the
    ground plane z = 0 (the ground reflects them toward a low imager), by mesh node name."""
    scene = trimesh.load(REPO / "scenes/landing/landing_plate.glb")
    out = {}
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        if not name.startswith("beacon"):
            continue
        v = trimesh.transformations.transform_points(scene.geometry[name].vertices, transform)
        v = np.c_[v[:, 0], -v[:, 2], v[:, 1]]  # glTF Y up -> Z up (pmmw.scene.geometry)
        out[name] = np.vstack([v, v * [1.0, 1.0, -1.0]])
    return out


def _camera(scn) -> Camera:
    im = scn.imager
    return Camera.look_at(im.position, im.look_at, im.up, im.fov, im.resolution)


# the headline config, and the trade study at each of its five ranges (slant range [m] -> the
# index of its pose; the regions depend on the pose only)
CASES = ["landing_95ghz.yaml"] + [f"landing_trade.yaml {r} m" for r in (2000, 1500, 1000, 500, 200)]


def _scenario(label: str):
    if label == "landing_95ghz.yaml":
        return load_scenario(LANDING)
    spec = load_sweep_file(TRADE)
    poses = dict(spec.grid)["imager.position"]
    pose = poses[spec.names["imager.position"].index(label.split(" ", 1)[1])]
    params = next(p for p in variants(spec) if p["imager.position"] == pose)
    return load_scenario(REPO / "configs" / spec.scenario.name, overrides_of(params))


@pytest.mark.parametrize("label", CASES)
def test_beacons_box_holds_the_five_threshold_beacons_and_no_other(label):
    """Every vertex of the five threshold beacons (and of their reflections) projects inside the
    box; no vertex of any other beacon does (the side beacons at the threshold's corners stand
    1 m beyond the row's end: a box that reached them would count seven beacons as five)."""
    scn = _scenario(label)
    cam = _camera(scn)
    shape = region_shapes(scn.output.regions, cam)["beacons"]
    assert shape[0] == "box", (label, shape)
    x0, y0, x1, y1 = shape[1:]
    threshold = 0
    for name, pts in _beacons().items():
        u, v, depth = cam.image_coordinates(pts)
        assert (depth > 0).all()
        inside = (u >= x0) & (u < x1) & (v >= y0) & (v < y1)
        if name.startswith("beacon_threshold"):
            threshold += 1
            assert inside.all(), (label, name, "outside the box", u.min(), u.max(), v.min(), v.max())
        else:
            assert not inside.any(), (label, name, "inside the box", u[inside], v[inside])
    assert threshold == 5


@pytest.mark.parametrize("label", CASES)
def test_every_region_is_in_view(label):
    """A circle's centre at least its radius inside the image, a box within it: a region outside
    the view has no pixels and its pairs no SNR."""
    scn = _scenario(label)
    cam = _camera(scn)
    for name, shape in region_shapes(scn.output.regions, cam).items():
        assert shape is not None, (label, name)
        if shape[0] == "box":
            x0, y0, x1, y1 = shape[1:]
            assert 0 <= x0 < x1 <= cam.width and 0 <= y0 < y1 <= cam.height, (label, name, shape)
        else:
            u, v, r = shape[1:]
            assert r <= u <= cam.width - r and r <= v <= cam.height - r, (label, name, shape)


def test_a_sweep_keeps_the_regions_in_their_written_order():
    """The trade study writes beacons, runway, ground: its reports' pairs are "beacons - runway",
    "beacons - ground", "runway - ground", as the headline config's (an alphabetical order would
    make the ground the target of "ground - runway")."""
    spec = load_sweep_file(TRADE)
    for params in variants(spec):
        scn = load_scenario(REPO / "configs" / spec.scenario.name, overrides_of(params))
        assert list(scn.output.regions) == ["beacons", "runway", "ground"], params
    assert list(load_scenario(LANDING).output.regions) == ["beacons", "runway", "ground"]


def test_a_sweep_passes_a_mapping_in_its_written_order():
    """A grid value that is a mapping reaches the scenario in the order written (the override is
    its YAML text): regions listed target first stay target first."""
    regions = {"runway": {"center": [0, 40, 0.02], "radius": 3}, "beacon": {"center": [0, -2.36, 0.41], "radius": 2}}
    scn = load_scenario(LANDING, overrides_of({"output.regions": regions}))
    assert list(scn.output.regions) == ["runway", "beacon"]


@pytest.mark.parametrize("label", CASES)
def test_the_background_regions_share_no_pixel_with_the_beacons(label):
    """A background region that reaches over the beacon row's pixels would take part of the
    target into its mean (from 1500 m a disc of 3 pixels at 40 m past the threshold did: a pixel
    spans 7.5 m of runway in depth there). The control: that old disc, at 2000 m, is found to share
    pixels with the row."""
    from pmmw.pipeline import region_masks

    scn = _scenario(label)
    masks = region_masks(scn.output.regions, _camera(scn))
    beacons = masks["beacons"]
    assert (beacons & beacons).any()  # the row's box is not empty (else nothing could overlap it)
    for name, mask in masks.items():
        if name != "beacons":
            assert not (mask & beacons).any(), (label, name, int((mask & beacons).sum()))


def test_the_overlap_check_finds_the_old_runway_disc_at_2000_m():
    """The control of `test_the_background_regions_share_no_pixel_with_the_beacons`: the runway
    disc the trade used before (3 pixels at 40 m past the threshold) overlaps the row's box at
    2000 m, and the check above would have said so."""
    from pmmw.pipeline import region_masks

    spec = load_sweep_file(TRADE)
    pose = dict(spec.grid)["imager.position"][spec.names["imager.position"].index("2000 m")]
    params = next(p for p in variants(spec) if p["imager.position"] == pose)
    regions = dict(params["output.regions"], runway={"center": [0, 40, 0.02], "radius": 3})
    old = load_scenario(REPO / "configs" / spec.scenario.name, overrides_of({**params, "output.regions": regions}))
    masks = region_masks(old.output.regions, _camera(old))
    assert (masks["runway"] & masks["beacons"]).any()
