"""A render's plain previews (the image, clipped at its 1/256 quantiles) and the figures a person
reads (``output.previews: figures``): a colour bar in kelvin, a title, the ideal|sensor pair
labelled and only when the imager changes something, small images scaled up; `pmmw view` for any
channel."""

import json

import numpy as np
import OpenImageIO as oiio
import pytest
from typer.testing import CliRunner

from pmmw.io.exr import write_exr
from pmmw.io.preview import MIN_DISPLAY_WIDTH, display_range, write_figure
from pmmw_cli.cli import app

runner = CliRunner()


def _png(path):
    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    pixels = inp.read_image("uint8")
    inp.close()
    return spec, pixels


def test_a_small_image_is_scaled_up_with_its_own_display_range(tmp_path):
    """A 20 x 12 image: the figure is wider than MIN_DISPLAY_WIDTH (scaled, not smoothed: a step
    edge stays one step) and black/white are the thesis's clipped range of the pixels."""
    img = np.full((12, 20), 280.0)
    img[:, 10:] = 300.0
    low, high = write_figure(tmp_path / "p.png", [(None, img)], title="t: I, 95 GHz")
    assert (low, high) == display_range(img)
    spec, px = _png(tmp_path / "p.png")
    assert spec.width >= MIN_DISPLAY_WIDTH and spec.nchannels >= 3
    # the colour bar adds grey levels between black and white: more than the image's two
    greys = {tuple(p[:3]) for p in px.reshape(-1, spec.nchannels) if p[0] == p[1] == p[2]}
    assert len(greys) > 20


def test_each_panel_of_a_pair_has_its_own_range(tmp_path):
    """The ideal image beside the sensor image: each on its own display range (the thesis's
    clipping of each image), the first panel's returned."""
    from pmmw.io.preview import panel_ranges

    a, b = np.full((8, 8), 250.0), np.full((8, 8), 340.0)
    a[:, 4:], b[:, 4:] = 260.0, 360.0
    low, high = write_figure(tmp_path / "pair.png", [("ideal", a), ("sensor", b)], title="pair")
    assert (low, high) == (250.0, 260.0)
    assert panel_ranges([a, b]) == [(250.0, 260.0), (340.0, 360.0)]


def _scenario(tmp_path):
    import trimesh

    ground = trimesh.creation.box(extents=[40, 40, 1])
    ground.apply_translation([0, 0, -0.5])
    ground.export(tmp_path / "ground.obj")
    scn = tmp_path / "s.yaml"
    scn.write_text("""
name: s
frequency: 35 GHz
imager: {position: [0, 0, 1.5], look_at: [0, 4, 0], fov: 20 deg, resolution: [24, 16]}
scene: [{mesh: ground.obj, material: concrete}]
sky: {model: uniform, temperature: 40 K}
render: {spp: 1, max_depth: 4, tile: 8, workers: 1}
""")
    return scn


def _render(scn, out, *sets):
    args = ["render", str(scn), "--out", str(out), "-q"]
    for s in sets:
        args += ["--figures"] if s == "--figures" else ["--set", s]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    return json.loads((out / "report.json").read_text())


def test_the_default_previews_are_the_images_clipped_at_the_1_256_quantiles(tmp_path):
    """By default a plain PNG per channel: one grey pixel per image pixel (24 x 16), black and
    white at the 1/256 and 255/256 quantiles of the channel's pixels (Murakowski 2014 sec. 3.2
    footnote), stated in the report. Checked against the EXR's channel: numpy.quantile's
    inverted CDF (the smallest value with at least that fraction of the pixels at or below it; 384
    pixels: the 2nd coldest and the 2nd hottest), to float32's rounding of the EXR (1e-6
    relative: 16 times float32's unit roundoff 2^-24); the grey levels against the thesis's linear map of that range,
    within one level (a pixel on a bin edge may fall either side after float32's rounding)."""
    from pmmw.io.exr import read_exr

    scn = _scenario(tmp_path)
    report = _render(scn, tmp_path / "c", "imager.noise=2 K")
    drawn = sorted(p.name for p in (tmp_path / "c" / "previews").iterdir())
    assert drawn == sorted(f"s_{c}.png" for c in ("I", "Q", "U", "V", "Ex2", "Ey2"))
    assert "side_by_side" not in report and "figures" not in report
    chans, _ = read_exr(tmp_path / "c" / "s.exr")
    md = (tmp_path / "c" / "report.md").read_text()
    for c in ("I", "Ex2", "U"):
        t = chans[c].astype(np.float64).ravel()
        low, high = (float(np.quantile(t, q, method="inverted_cdf")) for q in (1 / 256, 255 / 256))
        stats = report["channels"][c]
        assert stats["display_low"] == pytest.approx(low, rel=1e-6)
        assert stats["display_high"] == pytest.approx(high, rel=1e-6)
        assert f"(previews/s_{c}.png)" in md
        spec, px = _png(tmp_path / "c" / report["previews"][c])
        assert (spec.width, spec.height, spec.nchannels) == (24, 16, 1)
        want = np.clip(np.floor((chans[c] - low) * 256.0 / (high - low)), 0, 255)
        assert np.abs(px[..., 0].astype(float) - want).max() <= 1.0
        assert (px[..., 0][chans[c] < low] == 0).all() and (px[..., 0][chans[c] > high] == 255).all()


def test_figures_draws_the_annotated_set_and_false_draws_none(tmp_path):
    """``--figures`` (``output.previews: figures``): the plain previews and the matplotlib figures,
    each channel with its colour bar (wider than MIN_DISPLAY_WIDTH, more grey levels than the
    image's two), the ideal|sensor pairs, all linked from report.md; the pair only when the imager
    changes something. ``quick``: I alone; ``false``: no PNG, and none linked (the control)."""
    scn = _scenario(tmp_path)
    chans = ("I", "Q", "U", "V", "Ex2", "Ey2")
    report = _render(scn, tmp_path / "f", "imager.noise=2 K", "--figures")
    drawn = sorted(p.name for p in (tmp_path / "f" / "previews").iterdir())
    pairs = ["s_Ex2_ideal_sensor.png", "s_Ey2_ideal_sensor.png"]
    assert drawn == sorted([f"s_{c}.png" for c in chans] + [f"s_{c}_figure.png" for c in chans] + pairs)
    assert len(report["previews"]) == 6 and len(report["figures"]) == 6 and len(report["side_by_side"]) == 2
    md = (tmp_path / "f" / "report.md").read_text()
    assert all(f"(previews/{name})" in md for name in drawn)
    spec, px = _png(tmp_path / "f" / "previews" / "s_I_figure.png")
    assert spec.width >= MIN_DISPLAY_WIDTH and spec.nchannels >= 3
    greys = {tuple(p[:3]) for p in px.reshape(-1, spec.nchannels) if p[0] == p[1] == p[2]}
    assert len(greys) > 20  # the colour bar's grey levels
    report = _render(scn, tmp_path / "a", "output.previews=figures")  # the key as the flag; an ideal imager
    assert not list((tmp_path / "a" / "previews").glob("*_ideal_sensor.png")) and "side_by_side" not in report
    assert (tmp_path / "a" / "previews" / "s_I_figure.png").is_file()
    report = _render(scn, tmp_path / "b", "imager.noise=2 K", "output.previews=quick")
    assert sorted(p.name for p in (tmp_path / "b" / "previews").iterdir()) == ["s_I.png"]
    assert list(report["previews"]) == ["I"] and "side_by_side" not in report
    assert "display_low" in report["channels"]["I"] and "display_low" not in report["channels"]["Q"]
    report = _render(scn, tmp_path / "n", "imager.noise=2 K", "output.previews=false")
    assert not (tmp_path / "n" / "previews").exists() and report["previews"] == {}
    assert "previews/" not in (tmp_path / "n" / "report.md").read_text()


def test_the_default_previews_are_every_channel_and_quick_is_i_or_the_first():
    from types import SimpleNamespace

    from pmmw.pipeline import preview_channels

    def scn(channels, previews):
        return SimpleNamespace(output=SimpleNamespace(channels=channels, previews=previews))

    assert preview_channels(scn(("I", "Q", "U", "V", "Ex2", "Ey2"), True)) == ("I", "Q", "U", "V", "Ex2", "Ey2")
    assert preview_channels(scn(("I", "Q", "U", "V", "Ex2", "Ey2"), "quick")) == ("I",)
    assert preview_channels(scn(("Ey2", "Ex2"), "quick")) == ("Ey2",)
    assert preview_channels(scn(("Q", "I"), "all")) == ("Q", "I")
    assert preview_channels(scn(("Q", "I"), "figures")) == ("Q", "I")
    assert preview_channels(scn(("Q", "I"), False)) == ()


def test_view_writes_any_channel(tmp_path):
    exr = tmp_path / "x.exr"
    write_exr(
        exr,
        {"I": np.full((6, 9), 300.0, np.float32), "aux.depth": np.full((6, 9), 12.0, np.float32)},
        {"pmmw:frequency_hz": 95e9},
    )
    res = runner.invoke(app, ["view", str(exr), "--channel", "aux.depth"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "x_aux_depth.png").is_file() and "m)" in res.output
    res = runner.invoke(app, ["view", str(exr), "--channel", "Q"])
    assert res.exit_code == 2 and "no channel 'Q'" in res.output


def test_a_z_up_gltf_is_warned_about_and_validate_prints_bounds(tmp_path):
    """trimesh writes its Z-up coordinates into glTF as they are: a flat ground then stands on its
    edge. validate warns, naming up_axis: z, and prints each object's bounds and file up axis;
    with up_axis: z the warning is gone and the ground lies flat."""
    import trimesh
    import yaml

    trimesh.creation.box(extents=[40, 40, 1]).export(tmp_path / "ground.glb")
    scn = tmp_path / "z.yaml"
    scn.write_text(
        "name: z\nfrequency: 35 GHz\nimager: {position: [0, -10, 5], look_at: [0, 0, 0], fov: 20 deg, "
        "resolution: [8, 8]}\nscene: [{mesh: ground.glb, material: concrete}]\n"
    )
    res = runner.invoke(app, ["validate", str(scn)])
    assert res.exit_code == 0 and "up_axis: z" in res.output and "on its edge" in res.output, res.output
    res = runner.invoke(app, ["validate", str(scn), "--set", "scene[0].up_axis=z"])
    assert res.exit_code == 0 and "on its edge" not in res.output
    obj = yaml.safe_load(res.output)["geometry"]["objects"]["scene[0]:ground.glb"]
    assert obj["file_up_axis"] == "z" and obj["bounds_m"] == [[-20.0, -20.0, -0.5], [20.0, 20.0, 0.5]]
