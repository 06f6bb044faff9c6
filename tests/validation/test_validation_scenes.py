"""The validation scenes of Murakowski 2014 sec. 2.3.3 (the truck) and 2.3.4 (the bike racks):
rendered quickly (the shipped view, 4 samples per pixel, the ideal image), they show the thesis's
claims on the regions of their configs, and each claim has a control that must not show it.

Orderings ("A is colder/warmer than B") hold when the two regions' means differ by at least
``MARGIN`` = 10 K (5 x the cart's 2 K noise per pixel, sec. 2.3.1: an order that a single noisy
pixel would show); the 4-sample Monte Carlo error of a region mean is ~1 K (the renders' replicate
spread), a tenth of it. "Stands out" / "not visible" is pmmw's one detection criterion
(`pmmw.imaging.detection`): the region SNR against what is beside it, here without the PSF
(the quick renders leave the aperture off: Rose's contrast times the square root of the area),
at least 5 or below it.
"""

from pathlib import Path

from pmmw.config.schema import Region
from pmmw.physics.jones import stokes_images
from pmmw.pipeline import make_job, region_masks, resolve
from pmmw.trace.pool import assemble, render_tiles

REPO = Path(__file__).resolve().parents[2]
TRUCK = REPO / "configs/truck_35ghz.yaml"
BIKES = REPO / "configs/bikeracks_35ghz.yaml"
MARGIN = 10.0  # [K] 5 x the cart's 2 K noise (Rose 1948's detection threshold)
QUICK = ["render.spp=4", "render.target_error=null", "imager.aperture_diameter=0 m", "imager.noise=0 K"]
POLS = ("Ex2", "Ey2")


SIGMA = 2.0  # [K] the cart's noise per polarization (sec. 2.3.1)
PIXELS: dict = {}  # region -> its number of pixels in the last `_region_means`


def _snr(means, a, b, c) -> float:
    """Region ``a`` against ``b`` in channel ``c`` by the criterion, without the PSF."""
    from pmmw.imaging.detection import region_snr

    return region_snr(means[a][c] - means[b][c], [True] * PIXELS[a], None, SIGMA)


def _region_means(path, overrides=(), values=None, names=None) -> dict:
    """{region: {"Ex2": K, "Ey2": K}} of the ideal image, for the config's ``output.regions``
    (those in ``names``, default all); their pixel counts in `PIXELS`."""
    res = resolve(path, [*QUICK, *overrides], values=values)
    job = make_job(res, res.scenario.frequencies[0])
    img = stokes_images(assemble(job, render_tiles(job, workers=1)).mean)
    regions = {
        n: Region(**r.model_dump()) for n, r in res.scenario.output.regions.items() if names is None or n in names
    }
    masks = region_masks(regions, job.camera)
    assert all(m.sum() >= 1 for m in masks.values()), {n: int(m.sum()) for n, m in masks.items()}
    PIXELS.update({n: int(m.sum()) for n, m in masks.items()})
    return {n: {c: float(img[c][m].mean()) for c in POLS} for n, m in masks.items()}


def _colder_than_all(means, target, others, pols=POLS) -> bool:
    return all(means[target][c] <= means[o][c] - MARGIN for o in others for c in pols)


def _warmer(means, a, b, pols=POLS) -> bool:
    return all(means[a][c] >= means[b][c] + MARGIN for c in pols)


# -- the truck (sec. 2.3.3) -----------------------------------------------------------------------


def test_truck_shows_the_thesis_claims():
    """Sec. 2.3.3: "the reflection of the truck is clearly visible in the ground, appearing as a
    bright cavity where rays are trapped in the underside of the truck" (x polarization); in y
    "the reflections from the ground are washed out ... it does not affect the contrast in this
    scene as much, however, because the metal remains reflective at both polarizations; these
    horizontal surfaces are the coldest portions of the scene at both polarizations"; "cavities in
    the wheel wells and the cab ... show up comparatively warm"."""
    m = _region_means(TRUCK)
    objects = ["door", "cab", "front_well", "rear_well", "under", "under_reflection", "door_reflection", "ground"]

    # The hood (metal, 6 deg from horizontal) is the coldest: it mirrors the sky. Control: the
    # driver's door, vertical metal, mirrors the sand and is not.
    assert _colder_than_all(m, "hood", objects), m
    assert not _colder_than_all(m, "door", ["hood"] + [o for o in objects if o != "door"]), m

    # The cavity under the truck, warm in its reflection in the sand (Ex2). Control: open sand on
    # the other side of the truck, at the same depression, shows nothing against the sand.
    assert _warmer(m, "under_reflection", "ground", ["Ex2"]), m
    assert not _warmer(m, "ground_right", "ground", ["Ex2"]), m

    # Ey2 washes the ground's reflections out (sand's p reflectance at 76 deg incidence is a fifth
    # of its s reflectance: the contrast must fall to under half), while the metal's contrast
    # stays: the hood against the sand is not washed out (control).
    def contrast(a, c):
        return m[a][c] - m["ground"][c]

    assert abs(contrast("under_reflection", "Ey2")) < 0.5 * abs(contrast("under_reflection", "Ex2")), m
    assert not abs(contrast("hood", "Ey2")) < 0.5 * abs(contrast("hood", "Ex2")), m

    # The cab and both wheel wells are warmer than the body around them (the door) in both
    # polarizations. Control: the open sand is not (it is colder than the door in Ex2).
    for cavity in ("cab", "front_well", "rear_well", "under"):
        assert _warmer(m, cavity, "door"), (cavity, m)
    assert not _warmer(m, "ground", "door"), m


# -- the bike racks (sec. 2.3.4) ------------------------------------------------------------------

BIKE_MATERIALS = {
    "bricks": "concrete_table_2_3",
    "grass": "moist_soil_bikes",
    "windows": "fused_silica",
    "posts": "metal",
    "chain": "metal",
    "frame": "metal",
    "lock": "metal",
    "tires": "sa9_tire_table_2_3",
    "plastics": "polypropylene_table_2_3",
}
METAL = ["frame", "near_rear_wheel", "cap", "lock"]
NON_METAL = ["bricks", "wall", "window", "grass", "far_rear_wheel"]  # the far wheel: its rubber tread, edge-on


def test_bikeracks_show_the_thesis_claims():
    """Sec. 2.3.4: "the bicycle frame (or other metal parts) are the coldest objects in the scene";
    "the largest difference between the x and y-polarized images is the presence of reflections
    from the bricks"; "the conical cap on the fence posts and bike racks are major features, as
    are the chains ... the fenceposts themselves, reflecting the horizon, are significantly less
    visible"; with the tree behind the imager modelled, "the reflected images of the posts
    disappeared"."""
    m = _region_means(BIKES)

    # Metal objects colder than every other object, in both polarizations. Control: the fence post
    # (metal too, but vertical: it mirrors the horizon) is not.
    for metal in METAL:
        assert _colder_than_all(m, metal, NON_METAL), (metal, m)
    assert not _colder_than_all(m, "post", NON_METAL), m

    # The largest Ex2 - Ey2 difference: the reflection of a wheel in the bricks, larger by the margin
    # than that of every object. Control: the bricks where they mirror the warm wall show none.
    def xy(name):
        return abs(m[name]["Ex2"] - m[name]["Ey2"])

    assert all(xy("bike_in_bricks") >= xy(o) + MARGIN for o in METAL + NON_METAL + ["post", "chain"]), m
    assert not xy("bricks") >= MARGIN, m

    # The cap and the chain stand out of what is behind them; the post does not (the control).
    for target, behind in (("cap", "behind_cap"), ("chain", "above_chain")):
        assert all(_snr(m, target, behind, c) >= 5.0 for c in POLS), (target, m)
    assert not any(_snr(m, "post", "beside_post", c) >= 5.0 for c in POLS), m

    # Without the tree, the post's reflection in the bricks is colder (against the bricks beside
    # it) by the margin than with it: the rays it mirrors leave into the sky instead of the canopy.
    # Control: the cap mirrors the zenith, above the tree: the tree does not change it. The post is
    # 2.5 pixels wide, so its regions need more than 4 samples a pixel: a crop around it (the
    # shipped 0.2 deg pixels) at 64, with and without the tree, with the same seed.
    crop = ["imager.look_at=[0.2, 8.96, 0.25]", "imager.fov=8 deg", "imager.resolution=[40, 60]", "render.spp=64"]
    names = ["post_in_bricks", "bricks", "cap", "behind_cap"]
    tree = _region_means(BIKES, crop, names=names)
    bare = _region_means(
        BIKES,
        crop,
        names=names,
        values={"scene": [{"mesh": "../scenes/bikeracks/bikeracks.glb", "materials": BIKE_MATERIALS}]},
    )

    def change(target, background):
        with_tree = tree[target]["Ex2"] - tree[background]["Ex2"]
        without = bare[target]["Ex2"] - bare[background]["Ex2"]
        return without - with_tree

    assert change("post_in_bricks", "bricks") <= -MARGIN, (tree, bare)
    assert not change("cap", "behind_cap") <= -MARGIN, (tree, bare)
