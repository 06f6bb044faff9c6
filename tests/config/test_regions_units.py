"""Regions in scene units (a radius in metres or as an angle, a world box), pixel regions that scale
with the image, and regions checked in view by `pmmw validate`."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from pmmw.config import load_scenario
from pmmw.errors import UserError
from pmmw.pipeline import check_regions, region_masks, region_shapes
from pmmw.scene.camera import Camera
from pmmw_cli.cli import app
from tests.scenes import ground_and_block

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[2]

# the closed forms below are evaluated in float64 from the same inputs: 1e-9 px is rounding
PX = 1e-9


def _scenario(tmp_path: Path, regions: str, resolution="[40, 30]") -> Path:
    ground_and_block(tmp_path)
    path = tmp_path / "reg.yaml"
    path.write_text(f"""
name: reg
frequency: 35 GHz
imager: {{position: [0, 0, 1.5], look_at: [0, 4, 1.5], fov: 20 deg, resolution: {resolution}}}
scene:
  - {{mesh: ground.obj, material: concrete}}
  - {{mesh: block.obj, material: metal}}
sky: {{model: uniform, temperature: 40 K}}
output:
  regions: {regions}
""")
    return path


def _camera(scn):
    im = scn.imager
    return Camera.look_at(im.position, im.look_at, im.up, im.fov, im.resolution)


def test_a_radius_in_metres_and_as_an_angle_by_the_pinhole_closed_form(tmp_path):
    """A pinhole of horizontal field F over W pixels has a focal length of (W / 2) / tan(F / 2)
    pixels: a radius r [m] at distance d spans f r / d pixels, an angle a spans f tan(a)."""
    scn = load_scenario(
        _scenario(
            tmp_path,
            "{m: {center: [0, 5, 1.5], radius: 0.25 m}, "
            "a: {center: [0, 5, 1.5], radius: 0.5 deg}, p: {center: [0, 5, 1.5]}}",
        )
    )
    shapes = region_shapes(scn.output.regions, _camera(scn))
    f = 20 / math.tan(math.radians(10.0))
    assert shapes["m"][0] == "circle" and shapes["m"][1:3] == pytest.approx((20.0, 15.0), abs=PX)
    assert shapes["m"][3] == pytest.approx(f * 0.25 / 5.0, abs=PX)
    assert shapes["a"][3] == pytest.approx(f * math.tan(math.radians(0.5)), abs=PX)
    assert shapes["p"][3] == 2.0  # a bare number is pixels, as before


def test_a_world_box_is_the_rectangle_of_its_projected_corners(tmp_path):
    """A box 1 m wide (x) and 0.6 m tall (z) centred 5 m ahead on the axis, 0.2 m deep: its
    near face (y = 4.9) projects widest, to f * 0.5 / 4.9 pixels either side of the centre."""
    scn = load_scenario(_scenario(tmp_path, "{b: {bounds: [[-0.5, 4.9, 1.2], [0.5, 5.1, 1.8]]}}"))
    kind, x0, y0, x1, y1 = region_shapes(scn.output.regions, _camera(scn))["b"]
    f = 20 / math.tan(math.radians(10.0))
    half_w, half_h = f * 0.5 / 4.9, f * 0.3 / 4.9
    assert (kind, x0, x1) == ("box", math.floor(20 - half_w), math.ceil(20 + half_w))
    assert (y0, y1) == (math.floor(15 - half_h), math.ceil(15 + half_h))


@pytest.mark.parametrize(
    "regions, words",
    [
        ("{a: {center: [0, 5, 1.5], radius: 3 apples}}", "radius is pixels"),
        ("{a: {bounds: [[1, 5, 1], [0, 6, 2]]}}", "lower corner"),
        ("{a: {center: [0, 5, 1.5], box: [0, 0, 2, 2]}}", "exactly one of"),
    ],
)
def test_bad_regions_are_named(tmp_path, regions, words):
    with pytest.raises(UserError) as info:
        load_scenario(_scenario(tmp_path, regions))
    assert "output.regions.a" in str(info.value) and words in str(info.value)


def test_pixel_regions_scale_with_the_image(tmp_path):
    """The landing config's beacon box was written for 500 x 500: on a 100 x 100 image it is
    a fifth in each direction, grown outward to whole pixels; before, it fell outside the image."""
    scn = load_scenario(ROOT / "configs/landing_95ghz.yaml", ["imager.resolution=[100, 100]"])
    r = scn.output.regions
    assert r["beacons"].box == (math.floor(218 / 5), math.floor(247 / 5), math.ceil(282 / 5), math.ceil(254 / 5))
    assert r["runway"].radius == pytest.approx(3 / 5)
    assert "beacons" in check_regions(scn)  # in view
    # a circle below a pixel is the pixel holding its centre
    assert region_masks({"runway": r["runway"]}, _camera(scn))["runway"].sum() >= 1
    # the control: the file's own resolution leaves them as written
    same = load_scenario(ROOT / "configs/landing_95ghz.yaml")
    assert same.output.regions["beacons"].box == (218, 247, 282, 254) and same.output.regions["runway"].radius == 3
    # scene-unit regions do not scale
    scn = load_scenario(
        _scenario(tmp_path, "{m: {center: [0, 5, 1.5], radius: 0.25 m}}"), ["imager.resolution=[20, 15]"]
    )
    assert scn.output.regions["m"].radius == 0.25


def test_validate_checks_regions_in_view(tmp_path):
    path = _scenario(
        tmp_path,
        "{in: {center: [0, 5, 1.5], radius: 0.1 m}, out: {center: [40, 5, 1.5]}, behind: {center: [0, -5, 1.5]}}",
    )
    res = runner.invoke(app, ["validate", str(path)])
    assert res.exit_code == 2
    assert f"{path}: output.regions.out: falls outside the 40 x 30 image" in res.output
    assert f"{path}: output.regions.behind: lies behind the imager" in res.output
    assert "output.regions.in" not in res.output
    # the control: the region in view alone validates, with its pixels printed
    res = runner.invoke(
        app, ["validate", str(path), "--set", "output.regions={in: {center: [0, 5, 1.5], radius: 0.1 m}}"]
    )
    assert res.exit_code == 0, res.output
    assert "circle_px: [20.0, 15.0," in res.output
    # partly outside: a warning
    res = runner.invoke(app, ["validate", str(path), "--set", "output.regions={edge: {box: [35, 0, 45, 5]}}"])
    assert res.exit_code == 0 and "output.regions.edge lies partly outside" in res.output


def test_region_masks_of_a_box_in_metres(tmp_path):
    scn = load_scenario(_scenario(tmp_path, "{b: {bounds: [[-0.5, 4.9, 1.2], [0.5, 5.1, 1.8]]}}"))
    m = region_masks(scn.output.regions, _camera(scn))["b"]
    _, x0, y0, x1, y1 = region_shapes(scn.output.regions, _camera(scn))["b"]
    assert m.sum() == (x1 - x0) * (y1 - y0) and np.all(m[int(y0) : int(y1), int(x0) : int(x1)])


def test_pixel_regions_set_alongside_the_resolution_are_the_rendered_images():
    """A region given with --set next to a new resolution is meant for that image: not scaled."""
    scn = load_scenario(
        ROOT / "configs/landing_95ghz.yaml", ["imager.resolution=[100, 100]", "output.regions.runway.radius=2"]
    )
    assert scn.output.regions["runway"].radius == 2 and scn.output.regions["beacons"].box == (218, 247, 282, 254)


def _colour_pixels(png: Path, colour) -> int:
    import matplotlib.image as mpimg

    rgb = mpimg.imread(png)[..., :3]
    # anti-aliased outlines: pixels within 0.08 of the colour in every channel
    return int((np.abs(rgb - np.asarray(colour)).max(axis=2) < 0.08).sum())


def test_validate_preview_draws_the_view_and_the_regions(tmp_path):
    """`validate --preview` draws the view with each region outlined in its colour; the control
    without regions has no pixel of that colour."""
    from matplotlib.colors import to_rgb

    from pmmw.io.preview import REGION_COLOURS

    path = _scenario(tmp_path, "{block: {bounds: [[-0.5, 4.9, 1.2], [0.5, 5.1, 1.8]]}}")
    res = runner.invoke(app, ["validate", str(path), "--preview", str(tmp_path / "view.png")])
    assert res.exit_code == 0, res.output
    assert _colour_pixels(tmp_path / "view.png", to_rgb(REGION_COLOURS[0])) > 20
    res = runner.invoke(
        app, ["validate", str(path), "--set", "output.regions={}", "--preview", str(tmp_path / "none.png")]
    )
    assert res.exit_code == 0, res.output
    assert _colour_pixels(tmp_path / "none.png", to_rgb(REGION_COLOURS[0])) == 0
    res = runner.invoke(app, ["validate", str(ROOT / "configs/po_sphere.yaml"), "--preview", str(tmp_path / "x.png")])
    assert res.exit_code == 2 and "--preview" in res.output


def test_validate_preview_never_replaces_a_users_file(tmp_path):
    """`--preview FILE` where FILE is not a preview pmmw wrote: one error line, the file keeps its
    bytes; the control: a preview pmmw wrote there before is replaced."""
    path = _scenario(tmp_path, "{block: {bounds: [[-0.5, 4.9, 1.2], [0.5, 5.1, 1.8]]}}")
    mine = tmp_path / "holiday.png"
    mine.write_bytes(b"\x89PNG not pmmw's")
    res = runner.invoke(app, ["validate", str(path), "--preview", str(mine)])
    assert res.exit_code == 2 and "does not replace" in res.output, res.output
    assert mine.read_bytes() == b"\x89PNG not pmmw's"
    ours = tmp_path / "view.png"
    assert runner.invoke(app, ["validate", str(path), "--preview", str(ours)]).exit_code == 0
    before = ours.stat().st_mtime_ns
    res = runner.invoke(app, ["validate", str(path), "--preview", str(ours)])
    assert res.exit_code == 0, res.output
    assert ours.stat().st_mtime_ns >= before and ours.read_bytes().startswith(b"\x89PNG")
