"""The detection checks of `docs/validation.md` and their controls, run small enough for CI.

`pmmw_cli.validation` judges "visible" by the matched-filter SNR of what a target changes in the
sensor image, from two renders with and without it (`Measure.detect`, Rose's criterion, SNR >= 5),
and shows a control beside each: two renders without the target that differ only in their random
numbers. These tests run the same checks on the shipped scenes, shrunk (a smaller image, fewer
samples), and require:
- each target the thesis calls visible, where pmmw agrees at full size, is detectable here too;
- each check fails on its control, and on the target replaced by what surrounds it (the gun made
  of clothed skin: an earlier check, a region contrast, still passed then);
- a target that is absent (`absent`, the material that lets every ray through) changes nothing.

Thresholds: the criterion's own (5), decided before these renders; the shrunk renders keep the
shipped imagers' noise and PSFs, so a target far above the threshold at full size stays above it.
"""

import numpy as np
import pytest

from pmmw.imaging.detection import ROSE_SNR
from pmmw_cli import validation as v

SMALL = ["imager.resolution=[96, 96]", "render.spp=4", "render.target_error=null"]
# the clothed body's Monte Carlo noise is large (skin reflects about half: each sample either mirrors
# the cold sky or sees the warm skin); the control's SNR grows as pixels^(1/4) / sqrt(spp)
SMALL_CWD = ["imager.resolution=[48, 48]", "render.spp=32", "render.target_error=null"]


@pytest.fixture(scope="module")
def measure():
    return v.Measure(workers=1, log=lambda s: None)


def _landing(measure, weather="cloudy", beacon_swap="absent", f=95, r=400):
    over = measure.landing(f, r, weather) + SMALL
    without = [f"scene[0].materials={v._mapping(dict(v.LANDING_MATERIALS, beacon=beacon_swap))}"]
    return measure.detect(v.LANDING, over, without, chans=("Ex2", "Ey2", "I"))


def test_the_landing_beacons_are_detected_and_their_control_is_not(measure):
    d = _landing(measure)
    assert d.seen(("Ey2",)) is True, d.snr
    for c in d.snr:
        assert d.control[c] < ROSE_SNR, (c, d.control)
    # the control as a detection: two renders without the beacons, other random numbers
    assert max(d.control.values()) < ROSE_SNR


def test_a_target_replaced_by_its_surroundings_is_not_detected(measure):
    """The gun made of the clothed skin around it: the earlier region contrast (gun region against
    torso region) still found it "visible"; a with/without comparison finds nothing."""
    over = measure.cwd("outdoor", 95, 4, gun="clothed_skin") + SMALL_CWD
    without = [f"scene[0].materials={v._mapping(dict(v.CWD_MATERIALS['outdoor'], gun='clothed_skin'))}"]
    d = measure.detect(v.CWD["outdoor"], over, without, chans=("I", "Q", "U", "Ex2", "Ey2"))
    assert all(s == 0.0 for s in d.snr.values()), d.snr  # the same scene and seed: nothing changes
    assert d.seen() is False


def test_the_gun_is_detected_at_4_m_and_its_control_is_not(measure):
    over = measure.cwd("outdoor", 95, 4) + SMALL_CWD
    without = [f"scene[0].materials={v._mapping(dict(v.CWD_MATERIALS['outdoor'], gun='absent'))}"]
    d = measure.detect(v.CWD["outdoor"], over, without, chans=("I", "Q", "U", "Ex2", "Ey2"))
    assert d.seen() is True, d.snr
    assert max(d.control.values()) < ROSE_SNR, d.control


def test_the_large_sar_beacon_is_detected_in_clear_air_and_its_control_is_not(measure):
    over = measure.sar("beacon", 95, "clear") + SMALL
    without = [f"scene[0].materials={v._mapping(dict(v.SAR_GROUND, blanket='absent'))}"]
    d = measure.detect(v.SAR, over, without)
    assert d.seen() is True, d.snr
    assert max(d.control.values()) < ROSE_SNR, d.control


def test_an_absent_object_changes_no_pixel(tmp_path):
    """`absent` lets every ray through, open meshes included: a scene with a block made of it is
    the scene without the block within the Monte Carlo error (the rays that cross it draw their
    random numbers in another order, so the images are equal in distribution, not bit for bit).
    Per pixel |z| < 4.5 over 384 pixels (a false alarm of about 0.3 % for independent normal
    errors); the same block of metal (the control) must exceed it."""
    import trimesh

    from pmmw.pipeline import resolve, trace_frequency
    from tests.scenes import ground_and_block

    ground_and_block(tmp_path)
    block = trimesh.creation.box(extents=[0.4, 0.2, 0.2])  # 5 cm above the ground: no coincident faces
    block.apply_translation([0, 4, 0.15])
    block.export(tmp_path / "block.obj")
    base = """
name: t
frequency: 95 GHz
imager: {position: [0, 0, 1.5], look_at: [0, 4, 0.1], fov: 20 deg, resolution: [24, 16]}
sky: {model: uniform, temperature: 40 K}
render: {spp: 64, max_depth: 16, tile: 8, seed: 3}
scene:
  - {mesh: ground.obj, material: concrete}
"""
    images = {}
    for name, extra in (
        ("bare", ""),
        ("absent", "  - {mesh: block.obj, material: absent}\n"),
        ("metal", "  - {mesh: block.obj, material: metal}\n"),
    ):
        (tmp_path / f"{name}.yaml").write_text(base + extra)
        res = resolve(tmp_path / f"{name}.yaml")
        _, img, _ = trace_frequency(res, 95e9, workers=1)
        images[name] = (img.mean[..., :2], img.stderr[..., :2])

    def z(a, b):
        return (images[a][0] - images[b][0]) / np.sqrt(images[a][1] ** 2 + images[b][1] ** 2 + 1e-12)

    assert np.abs(z("absent", "bare")).max() < 4.5
    assert np.abs(z("metal", "bare")).max() > 4.5


@pytest.mark.parametrize(
    "text, value, half",
    [
        ("2.2", 2.2, 0.05),
        ("0.17", 0.17, 0.005),
        ("500", 500, 50),
        ("13", 13, 0.5),
        ("~14", 14, 1.0),
        ("11.7", 11.7, 0.05),
    ],
)
def test_printed_numbers_carry_half_a_unit_of_their_last_digit(text, value, half):
    assert v.printed(text) == pytest.approx((value, half))


def test_the_rules_for_words():
    assert v.faint(3.0) and v.faint(9.9) and not v.faint(2.4) and not v.faint(10.0)
    assert v.similar(1.0, 1.9) and not v.similar(1.0, 2.1)
    assert v.much(2.0, 1.0) and not v.much(1.9, 1.0)
    assert v.order_of(0.7, 2.0) and not v.order_of(0.6, 2.0)
    assert v.every([True, None]) is None and v.every([True, False, None]) is False and v.every([True]) is True
