"""The shipped scenarios: each validates, renders at reduced resolution, and shows the
phenomenology of seed 000 chapter 3 (checked on the ideal image, with the seed's materials)."""

from pathlib import Path

import numpy as np
import pytest

from pmmw_cli.config.schema import Region
from pmmw_cli.pipeline import make_job, region_masks, resolve, validate
from pmmw_cli.physics.jones import stokes_images
from pmmw_cli.trace.pool import assemble, render_tiles

CONFIGS = sorted(Path(__file__).resolve().parents[1].glob("configs/*.yaml"))


def _render(path, overrides):
    res = resolve(path, overrides)
    job = make_job(res, res.scenario.frequencies[0])
    return job, stokes_images(assemble(job, render_tiles(job, workers=2)).mean)


def _means(job, img, regions, chan="Ey2"):
    masks = region_masks({n: Region(**r) for n, r in regions.items()}, job.camera)
    for n, m in masks.items():
        assert m.sum() >= 3, f"region {n} has {m.sum()} pixels"
    return {n: float(img[chan][m].mean()) for n, m in masks.items()}


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_every_shipped_config_validates_and_renders_small(path):
    out = validate(path)
    assert out["geometry"]["triangles"] > 0 and not [w for w in out["warnings"] if "watertight" in w]
    job, img = _render(path, ["imager.resolution=[24, 24]", "render.spp=1"])
    for c in ("Ex2", "Ey2"):
        assert np.all(np.isfinite(img[c])) and img[c].min() > 0.0 and img[c].max() < 400.0


LANDING = Path(__file__).resolve().parents[1] / "configs/landing_95ghz.yaml"
NEAR = ["imager.position=[0, -399.03, 27.90]", "imager.look_at=[0, -2.36, 0.41]", "imager.fov=1 deg",
        "imager.resolution=[80, 80]", "render.spp=4"]
LANDING_REGIONS = {"beacon": {"center": [0, -2.36, 0.41], "radius": 2.5},
                   "runway": {"center": [0, 40.0, 0.02], "radius": 3}}


def test_landing_beacons_are_colder_than_the_runway_and_fog_lowers_the_contrast():
    """Sec. 3.1: the 45-degree metal beacons mirror the cold zenith, so in Ey2 at 95 GHz they are
    colder than the runway; fog warms the path and the zenith, lowering the contrast."""
    contrasts = {}
    for weather, layers in (("clear", "[]"), ("heavy fog", "[{kind: fog, base: 0, top: 600, liquid_water: 0.3 g/m3}]"),
                            ("extreme fog", None)):
        overrides = NEAR + ([f"atmosphere.layers={layers}"] if layers is not None else [])
        job, img = _render(LANDING, overrides)
        m = _means(job, img, LANDING_REGIONS)
        contrasts[weather] = m["runway"] - m["beacon"]
    assert contrasts["clear"] > 20.0  # beacons far colder in clear air
    assert contrasts["clear"] > contrasts["heavy fog"] > contrasts["extreme fog"] > 0.0


def test_handgun_differs_from_the_torso_by_more_than_the_noise_outdoors():
    """Sec. 3.2.2, 95 GHz, 4 m, outdoors: the gun (a mirror of the sky and ground, under the denim)
    differs from the torso by more than the imager's 4 K noise."""
    path = Path(__file__).resolve().parents[1] / "configs/cwd_outdoor_95ghz.yaml"
    job, img = _render(path, ["imager.resolution=[110, 185]", "render.spp=2"])
    regions = {"gun": {"center": [0.165, -0.2, 1.25], "radius": 1.5},  # the grip, under the shirt
               "torso": {"center": [-0.1, -0.18, 1.05], "radius": 1.5}}
    for chan in ("Ex2", "Ey2"):
        m = _means(job, img, regions, chan)
        assert abs(m["gun"] - m["torso"]) > 4.0, (chan, m)


def test_sar_targets_are_the_coldest_objects_and_visible_through_cloud():
    """Sec. 3.3: from 3000 m the metal aircraft and blankets mirror the cold sky: the coldest
    objects in clear weather; through a cloud deck at 35 GHz they stay more than the 4 K noise
    colder than the surroundings."""
    path = Path(__file__).resolve().parents[1] / "configs/sar_cessna_95ghz.yaml"
    zoom = ["imager.fov=1 deg", "imager.resolution=[60, 60]", "render.spp=2"]
    for target, mesh, r in (("cessna", "sar_cessna.glb", 4), ("blanket", "sar_beacon.glb", 3)):
        target_map = "aircraft: metal" if target == "cessna" else "blanket: metal"
        base = zoom + [f"scene[0].mesh=../scenes/sar/{mesh}", "scene[0].materials={dry_ground: sar_dry_ground, "
                       f"wet_ground: sar_wet_ground, rocks: sar_rocks, shrubs: oak_leaves, {target_map}}}"]
        job, img = _render(path, base)
        regions = {"target": {"center": [0, 0, 0.5], "radius": r}, "ground": {"center": [20, 20, 0], "radius": 3}}
        m = _means(job, img, regions)
        rest = img["Ey2"][~region_masks({"t": Region(center=(0, 0, 0.5), radius=r + 3)}, job.camera)["t"]]
        assert m["target"] < np.percentile(rest, 1), (target, m)
        cloud = base + ["frequency=35 GHz",
                        "atmosphere.layers=[{kind: cloud, base: 1000 m, top: 2000 m, liquid_water: 0.5 g/m3}]"]
        job, img = _render(path, cloud)
        m = _means(job, img, regions)
        assert m["ground"] - m["target"] > 4.0, (target, m)


def test_target_error_applies_after_the_blur_only_when_the_imager_blurs():
    """render.target_error: with an aperture the per-pixel goal is target / sqrt(sum psf^2) (the
    landing PSF spans ~15 pixels: a factor > 5); without one it is the target itself (factor 1,
    exactly)."""
    from pmmw_cli.imaging.imager import error_footprint, psf_kernel

    blurred = make_job(resolve(LANDING, ["render.target_error=0.4 K"]), 95e9)
    kern = psf_kernel(blurred.camera.pixel_angle, blurred.k0, 0.6)
    assert blurred.settings.error_footprint == error_footprint(kern) > 5.0
    ideal = make_job(resolve(LANDING, ["render.target_error=0.4 K", "imager.aperture_diameter=0 m"]), 95e9)
    assert ideal.settings.error_footprint == 1.0
